"""Decimals written for each kind of value: the G-code number grid (standard library only).

:class:`Decimals` is data of every :class:`~gcode.dialects.Dialect`; the formatter that
applies it is :mod:`gcode.numbers`. Kept apart so the dialect presets (and a command's
``--help`` listing their names) load without numpy.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

__all__ = ["Decimals", "NumberKind"]


class NumberKind(Enum):
    """Kinds of values that get their own number of decimals."""

    COORD_MM = "coordinate, mm"
    COORD_INCH = "coordinate, inch"
    ANGLE = "rotary angle, degrees"
    FEED_MM = "feed, mm/min"
    FEED_INCH = "feed, inch/min"
    INVERSE_TIME = "inverse-time feed, 1/min"
    SPINDLE = "spindle speed, rev/min"
    DWELL = "dwell, s"


@dataclass(frozen=True, slots=True)
class Decimals:
    """Decimals written for each kind of value.

    Parameters
    ----------
    coord_mm : int
        3: 1 um, finer than the step size of hobby and most industrial machines, and the
        resolution GRBL reports (``N_DECIMAL_COORDVALUE_MM``).
    coord_inch : int
        4: 0.0001 in = 2.54 um, GRBL's ``N_DECIMAL_COORDVALUE_INCH``.
    angle : int
        3: 0.001 degree, about 1.7 um of arc at 100 mm radius.
    feed_mm : int
        1: 0.1 mm/min; feeds are not positions and need no more.
    feed_inch : int
        2: 0.01 in/min = 0.254 mm/min.
    inverse_time : int
        4: inverse-time F (1/min) of slow long moves can be well below 1, where a
        relative resolution better than 0.1 % needs 4 decimals.
    spindle : int
        0: whole rev/min.
    dwell : int
        3: 1 ms.
    """

    coord_mm: int = 3
    coord_inch: int = 4
    angle: int = 3
    feed_mm: int = 1
    feed_inch: int = 2
    inverse_time: int = 4
    spindle: int = 0
    dwell: int = 3

    def __post_init__(self) -> None:
        for name in self.__dataclass_fields__:
            d = getattr(self, name)
            if not isinstance(d, int) or not 0 <= d <= 9:
                raise ValueError(f"Decimals.{name} must be an int in 0..9, got {d!r}")

    def of(self, kind: NumberKind) -> int:
        """Return the decimals for ``kind``."""
        return int(getattr(self, _KIND_FIELD[kind]))


_KIND_FIELD = {
    NumberKind.COORD_MM: "coord_mm",
    NumberKind.COORD_INCH: "coord_inch",
    NumberKind.ANGLE: "angle",
    NumberKind.FEED_MM: "feed_mm",
    NumberKind.FEED_INCH: "feed_inch",
    NumberKind.INVERSE_TIME: "inverse_time",
    NumberKind.SPINDLE: "spindle",
    NumberKind.DWELL: "dwell",
}
