"""The ``$n`` settings table of the simulated controller, built from a machine definition.

Numbers and meanings are grbl 1.1's (``doc/markdown/settings.md``); rates are shown in
mm/min, accelerations in mm/s^2 (grbl stores mm/min^2 inside but prints mm/s^2), travel
as the axis span in mm. Differences from a stock grbl: ``$10=3`` (machine position and
buffer state, so every status report carries ``Bf:``) and ``$20=1`` (soft limits on,
from the machine's travel). Axes beyond Z use grbl's numbering by axis slot
(``$113`` is A's rate, ``$124`` B's acceleration, ...).

Examples
--------
>>> from machines import load_machine
>>> s = Settings.from_machine(load_machine("grbl-router"), "XYZ")
>>> s.value(110), s.junction_deviation_mm, s.format_lines()[0]
(8000.0, 0.01, '$0=10')
"""

from __future__ import annotations

import math

from machines import Machine
from simulator.motion import AxisLimits

__all__ = ["SETTING_NAMES", "Settings"]

_AXES = "XYZABC"

#: Description of each setting (grbl ``doc/csv/setting_codes_en_US.csv``).
SETTING_NAMES: dict[int, str] = {
    0: "Step pulse time, microseconds",
    1: "Step idle delay, milliseconds",
    2: "Step pulse invert, mask",
    3: "Step direction invert, mask",
    4: "Invert step enable pin, boolean",
    5: "Invert limit pins, boolean",
    6: "Invert probe pin, boolean",
    10: "Status report options, mask",
    11: "Junction deviation, millimeters",
    12: "Arc tolerance, millimeters",
    13: "Report in inches, boolean",
    20: "Soft limits enable, boolean",
    21: "Hard limits enable, boolean",
    22: "Homing cycle enable, boolean",
    23: "Homing direction invert, mask",
    24: "Homing locate feed rate, mm/min",
    25: "Homing search seek rate, mm/min",
    26: "Homing switch debounce delay, milliseconds",
    27: "Homing switch pull-off distance, millimeters",
    30: "Maximum spindle speed, RPM",
    31: "Minimum spindle speed, RPM",
    32: "Laser-mode enable, boolean",
}
_INTEGER = {0, 1, 2, 3, 4, 5, 6, 10, 13, 20, 21, 22, 23, 26, 30, 31, 32}
_DEFAULTS: dict[int, float] = {
    0: 10, 1: 25, 2: 0, 3: 0, 4: 0, 5: 0, 6: 0, 10: 3, 11: 0.010, 12: 0.002, 13: 0,
    20: 1, 21: 0, 22: 0, 23: 0, 24: 25.0, 25: 500.0, 26: 250, 27: 1.0, 30: 1000, 31: 0,
    32: 0,
}  # fmt: skip


class Settings:
    """Mutable ``$n`` table (one per controller).

    Parameters
    ----------
    values : dict of int to float
        Setting number -> value.
    axes : str
        Axis letters the table covers, e.g. ``"XYZ"`` or ``"XYZAC"``.
    """

    def __init__(self, values: dict[int, float], axes: str) -> None:
        self._values = dict(values)
        self.axes = axes

    @classmethod
    def from_machine(cls, machine: Machine, axes: str) -> Settings:
        """Grbl defaults plus the machine's rates, accelerations and travel spans."""
        values = dict(_DEFAULTS)
        for ax in machine.axes:
            if ax.letter not in axes:
                continue
            slot = _AXES.index(ax.letter)
            values[100 + slot] = 250.0  # steps/mm (or /deg): not simulated, shown only
            values[110 + slot] = ax.max_rate
            values[120 + slot] = ax.max_accel
            values[130 + slot] = ax.span if math.isfinite(ax.span) else 0.0
        return cls(values, axes)

    def numbers(self) -> list[int]:
        """Setting numbers in ascending order."""
        return sorted(self._values)

    def value(self, number: int) -> float:
        """The value of ``$number``.

        Raises
        ------
        KeyError
            For a setting that does not exist.
        """
        return self._values[number]

    def set(self, number: int, value: float) -> int:
        """Store ``$number=value``; return 0 or the grbl error number.

        Returns
        -------
        int
            0 on success, 3 for an unknown setting, 4 for a negative value.
        """
        if number not in self._values:
            return 3
        if value < 0.0:
            return 4
        if number in (110, 111, 112, 113, 114, 115, 120, 121, 122, 123, 124, 125) and value <= 0:
            return 4
        self._values[number] = float(int(value)) if number in _INTEGER else float(value)
        return 0

    def format_lines(self) -> list[str]:
        """``$n=value`` lines as ``$$`` prints them (integers without decimals)."""
        out = []
        for n in self.numbers():
            v = self._values[n]
            out.append(f"${n}={int(v)}" if n in _INTEGER else f"${n}={v:.3f}")
        return out

    @property
    def junction_deviation_mm(self) -> float:
        """``$11``, mm."""
        return self._values[11]

    @property
    def arc_tolerance_mm(self) -> float:
        """``$12``, mm (chord tolerance used to split arcs into planner blocks)."""
        return self._values[12]

    @property
    def soft_limits(self) -> bool:
        """``$20``: soft limits enabled."""
        return bool(self._values[20])

    @property
    def report_mpos(self) -> bool:
        """``$10`` bit 0: status reports show MPos (else WPos)."""
        return bool(int(self._values[10]) & 1)

    @property
    def report_buffer(self) -> bool:
        """``$10`` bit 1: status reports show ``Bf:``."""
        return bool(int(self._values[10]) & 2)

    def axis_limits(self, base: AxisLimits) -> AxisLimits:
        """``base`` with rates and accelerations replaced by ``$11x``/``$12x`` (mm/s, mm/s^2)."""
        rate = list(base.rate_per_s)
        accel = list(base.accel_per_s2)
        for slot in range(6):
            if (110 + slot) in self._values:
                rate[slot] = self._values[110 + slot] / 60.0
                accel[slot] = self._values[120 + slot]
        return AxisLimits(tuple(rate), tuple(accel), base.present)
