"""Units at the edges: millimetres inside, inches only on conversion.

Inside :mod:`machines` (and the whole project) lengths are mm, feeds mm/min, times s,
accelerations mm/s^2, and rotary axes deg, deg/min and deg/s^2. Only the G-code parser and
emitter know about G20. Rotary values are degrees in both unit modes and are never scaled
by :data:`MM_PER_INCH` (the Carvera firmware #209 bug: rotary angles divided by 25.4).

Examples
--------
>>> to_mm(1.0, Unit.INCH)
25.4
>>> convert_joints([[1.0, 0.0, 0.0, 90.0]], "XYZA", Unit.INCH, Unit.MM).tolist()
[[25.4, 0.0, 0.0, 90.0]]
"""

from __future__ import annotations

from enum import StrEnum
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from machines.errors import MachineError

__all__ = [
    "LINEAR_LETTERS",
    "MM_PER_INCH",
    "ROTARY_LETTERS",
    "Unit",
    "convert_feed",
    "convert_joints",
    "convert_length",
    "from_mm",
    "to_mm",
]

MM_PER_INCH: Final[float] = 25.4
"""Millimetres per inch, exact by definition (1959). Never use a truncated reciprocal."""

LINEAR_LETTERS: Final[str] = "XYZUVW"
"""Axis letters of linear axes (mm)."""

ROTARY_LETTERS: Final[str] = "ABC"
"""Axis letters of rotary axes (deg), about X, Y and Z respectively."""


class Unit(StrEnum):
    """A length unit for linear values at the edges of the program."""

    MM = "mm"
    INCH = "inch"

    @classmethod
    def parse(cls, text: str) -> Unit:
        """Read ``"mm"``, ``"inch"``, ``"in"``, ``"G21"`` or ``"G20"`` (any case).

        Parameters
        ----------
        text : str
            The unit name.

        Returns
        -------
        Unit
            The unit.

        Raises
        ------
        MachineError
            For any other text.
        """
        key = text.strip().lower()
        if key in ("mm", "g21", "millimetre", "millimeter"):
            return cls.MM
        if key in ("inch", "in", "g20", "inches"):
            return cls.INCH
        raise MachineError(f"unknown length unit {text!r}; expected 'mm' or 'inch'")

    @property
    def mm_per_unit(self) -> float:
        """Millimetres per one of this unit (1.0 or exactly 25.4)."""
        return 1.0 if self is Unit.MM else MM_PER_INCH

    @property
    def gcode(self) -> str:
        """The G-code word selecting this unit (``"G21"`` or ``"G20"``)."""
        return "G21" if self is Unit.MM else "G20"


def _factor(from_unit: Unit, to_unit: Unit) -> float:
    if from_unit is to_unit:
        return 1.0
    return MM_PER_INCH if from_unit is Unit.INCH else 1.0 / MM_PER_INCH


def convert_length(value: ArrayLike, from_unit: Unit, to_unit: Unit) -> NDArray[np.float64]:
    """Convert linear lengths between units.

    Parameters
    ----------
    value : array_like
        Lengths in `from_unit` (mm or inch).
    from_unit, to_unit : Unit
        Source and target units.

    Returns
    -------
    numpy.ndarray
        Lengths in `to_unit`. Inch to mm multiplies by exactly 25.4; mm to inch divides by
        25.4 (never multiplies by a rounded reciprocal).
    """
    a = np.asarray(value, dtype=float)
    if from_unit is to_unit:
        return a.copy()
    return a * MM_PER_INCH if from_unit is Unit.INCH else a / MM_PER_INCH


def to_mm(value: float, unit: Unit) -> float:
    """Convert one length to mm.

    Parameters
    ----------
    value : float
        Length in `unit`.
    unit : Unit
        Its unit.

    Returns
    -------
    float
        Length, mm.
    """
    return float(value) * MM_PER_INCH if unit is Unit.INCH else float(value)


def from_mm(value: float, unit: Unit) -> float:
    """Convert one length from mm.

    Parameters
    ----------
    value : float
        Length, mm.
    unit : Unit
        Target unit.

    Returns
    -------
    float
        Length in `unit`.
    """
    return float(value) / MM_PER_INCH if unit is Unit.INCH else float(value)


def convert_feed(value: ArrayLike, from_unit: Unit, to_unit: Unit) -> NDArray[np.float64]:
    """Convert linear feed rates (unit/min) between units.

    Parameters
    ----------
    value : array_like
        Feeds in `from_unit` per minute (mm/min or inch/min).
    from_unit, to_unit : Unit
        Source and target units.

    Returns
    -------
    numpy.ndarray
        Feeds in `to_unit` per minute. Time units never change (always per minute).
    """
    return convert_length(value, from_unit, to_unit)


def convert_joints(
    joints: ArrayLike, letters: str, from_unit: Unit, to_unit: Unit
) -> NDArray[np.float64]:
    """Convert the linear columns of joint values; rotary columns stay in degrees.

    Parameters
    ----------
    joints : array_like, shape (..., len(letters))
        Joint values: linear columns in `from_unit`, rotary columns in deg.
    letters : str
        Axis letter of each column, e.g. ``"XYZAC"``.
    from_unit, to_unit : Unit
        Source and target units of the linear columns.

    Returns
    -------
    numpy.ndarray
        A converted copy. Columns whose letter is A, B or C are copied unchanged.

    Raises
    ------
    MachineError
        If the last dimension does not match `letters` or a letter is unknown.
    """
    a = np.array(joints, dtype=float)
    if a.ndim == 0 or a.shape[-1] != len(letters):
        raise MachineError(
            f"joints of shape {a.shape!r} do not match the {len(letters)} axis letters {letters!r}"
        )
    bad = [ch for ch in letters.upper() if ch not in LINEAR_LETTERS + ROTARY_LETTERS]
    if bad:
        raise MachineError(f"unknown axis letter {bad[0]!r} in {letters!r}")
    factor = _factor(from_unit, to_unit)
    linear = np.array([ch in LINEAR_LETTERS for ch in letters.upper()])
    if from_unit is Unit.MM and to_unit is Unit.INCH:
        a[..., linear] = a[..., linear] / MM_PER_INCH
    else:
        a[..., linear] = a[..., linear] * factor
    return a
