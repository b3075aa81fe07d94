"""One machine axis: letter, kind, travel, rate, acceleration and rotary wrap behaviour.

Units: linear axes in mm, mm/min and mm/s^2; rotary axes in deg, deg/min and deg/s^2.

Examples
--------
>>> x = Axis("X", AxisKind.LINEAR, -400.0, 400.0, max_rate=30000.0, max_accel=2000.0)
>>> bool(x.within(399.0))
True
>>> c = Axis("C", AxisKind.ROTARY, max_rate=18000.0, max_accel=1440.0, wrap=Wrap.CONTINUOUS)
>>> c.is_limited
False
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from machines.errors import MachineError
from machines.units import LINEAR_LETTERS, ROTARY_LETTERS

__all__ = ["Axis", "AxisKind", "Wrap"]


class AxisKind(StrEnum):
    """Linear (mm) or rotary (deg)."""

    LINEAR = "linear"
    ROTARY = "rotary"


class Wrap(StrEnum):
    """How a rotary axis treats angles beyond one turn.

    Attributes
    ----------
    NONE
        Linear axes: no wrapping.
    LIMITED
        Rotary axis with hard travel (cables, hoses): values are absolute degrees and are
        checked against ``min``/``max``.
    CONTINUOUS
        Rotary axis that turns without limit and counts past 360 (the controller position
        is the unwrapped angle, e.g. 725 deg).
    SHORTEST
        Modulo-360 axis (LinuxCNC ``WRAPPED_ROTARY``): the controller takes a value in
        [0, 360) and moves the shorter way. Kinematics still return unwrapped angles so
        differences are real motion; :meth:`Axis.controller_value` maps them to [0, 360).
    """

    NONE = "none"
    LIMITED = "limited"
    CONTINUOUS = "continuous"
    SHORTEST = "shortest"


@dataclass(frozen=True, slots=True)
class Axis:
    """A machine axis.

    Parameters
    ----------
    letter : str
        Axis letter: X, Y, Z (U, V, W) for linear axes, A, B, C for rotary axes about X, Y, Z.
    kind : AxisKind
        Linear or rotary; must agree with the letter.
    min, max : float
        Travel limits: mm for linear axes, deg for rotary axes. Unbounded (``-inf``/``inf``)
        for continuous and modulo rotary axes, finite otherwise.
    max_rate : float
        Maximum rate, mm/min or deg/min (> 0).
    max_accel : float
        Maximum acceleration, mm/s^2 or deg/s^2 (> 0).
    wrap : Wrap
        Rotary wrap behaviour; ``Wrap.NONE`` for linear axes. Defaults to ``NONE`` for a
        linear axis and ``LIMITED`` for a rotary one.

    Raises
    ------
    MachineError
        For an unknown letter, a kind that contradicts the letter, ``min >= max``,
        non-finite limits on a limited axis, finite limits on a continuous axis, or a
        non-positive rate or acceleration.
    """

    letter: str
    kind: AxisKind
    min: float = -math.inf  # mm or deg
    max: float = math.inf  # mm or deg
    max_rate: float = 1.0  # mm/min or deg/min
    max_accel: float = 1.0  # mm/s^2 or deg/s^2
    wrap: Wrap | None = None

    def __post_init__(self) -> None:
        letter = self.letter
        if not isinstance(letter, str) or len(letter) != 1 or letter.upper() != letter:
            raise MachineError(f"axis letter must be one upper-case letter, got {letter!r}")
        kind = AxisKind(self.kind)
        object.__setattr__(self, "kind", kind)
        if letter in LINEAR_LETTERS:
            expected = AxisKind.LINEAR
        elif letter in ROTARY_LETTERS:
            expected = AxisKind.ROTARY
        else:
            raise MachineError(f"unknown axis letter {letter!r}")
        if kind is not expected:
            raise MachineError(f"axis {letter!r} is {expected.value}, not {kind.value!r}")
        wrap = self.wrap
        if wrap is None:
            wrap = Wrap.NONE if kind is AxisKind.LINEAR else Wrap.LIMITED
        wrap = Wrap(wrap)
        object.__setattr__(self, "wrap", wrap)
        if kind is AxisKind.LINEAR and wrap is not Wrap.NONE:
            raise MachineError(f"linear axis {letter!r} cannot wrap ({wrap.value!r})")
        if kind is AxisKind.ROTARY and wrap is Wrap.NONE:
            raise MachineError(f"rotary axis {letter!r} needs wrap limited/continuous/shortest")
        lo, hi = float(self.min), float(self.max)
        object.__setattr__(self, "min", lo)
        object.__setattr__(self, "max", hi)
        if wrap in (Wrap.CONTINUOUS, Wrap.SHORTEST):
            if math.isfinite(lo) or math.isfinite(hi):
                raise MachineError(
                    f"{wrap.value} axis {letter!r} has no travel limits, got min={lo!r}, max={hi!r}"
                )
        else:
            if not (math.isfinite(lo) and math.isfinite(hi)):
                raise MachineError(
                    f"axis {letter!r} needs finite travel limits, got min={lo!r}, max={hi!r}"
                )
            if not lo < hi:
                raise MachineError(f"axis {letter!r}: min={lo!r} is not below max={hi!r}")
        for name in ("max_rate", "max_accel"):
            value = float(getattr(self, name))
            if not (math.isfinite(value) and value > 0.0):
                raise MachineError(f"axis {letter!r}: {name} must be > 0, got {value!r}")
            object.__setattr__(self, name, value)

    @property
    def is_rotary(self) -> bool:
        """True for A, B, C."""
        return self.kind is AxisKind.ROTARY

    @property
    def is_limited(self) -> bool:
        """True when the axis has finite travel limits (every linear axis, LIMITED rotary)."""
        return self.wrap in (Wrap.NONE, Wrap.LIMITED)

    @property
    def unit(self) -> str:
        """Unit of positions on this axis: ``"mm"`` or ``"deg"``."""
        return "deg" if self.is_rotary else "mm"

    @property
    def span(self) -> float:
        """Travel length ``max - min`` in mm or deg (``inf`` when unlimited)."""
        return self.max - self.min

    def within(self, values: ArrayLike, *, tol: float = 0.0) -> NDArray[np.bool_]:
        """Test positions against the travel limits.

        Parameters
        ----------
        values : array_like
            Positions, mm or deg.
        tol : float, optional
            Allowance beyond each limit, mm or deg (default 0).

        Returns
        -------
        numpy.ndarray of bool
            True where ``min - tol <= value <= max + tol``; NaN is never within.
        """
        v = np.asarray(values, dtype=float)
        return (v >= self.min - tol) & (v <= self.max + tol)

    def controller_value(self, values: ArrayLike) -> NDArray[np.float64]:
        """Map unwrapped angles to what the controller is sent.

        Parameters
        ----------
        values : array_like
            Positions, mm or deg (unwrapped for rotary axes).

        Returns
        -------
        numpy.ndarray
            For ``Wrap.SHORTEST`` the angle modulo 360 in [0, 360) deg; otherwise a copy.
        """
        v = np.array(values, dtype=float)
        if self.wrap is Wrap.SHORTEST:
            v = np.mod(v, 360.0)
            v[v >= 360.0] = 0.0  # np.mod(-1e-17, 360) == 360.0
        return v
