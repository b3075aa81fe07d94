"""The canonical program IR: a few frozen block types and ``Program``.

This is the seam between the toolpath post, the G-code text (emitter and parser) and the
simulator. Units inside the IR are ALWAYS millimetres for lengths, degrees for rotary
axes A/B/C, mm/min for feeds (1/min in inverse-time mode G93), rev/min for the spindle and
seconds for dwells. Inches exist only in G-code text: the parser converts them in and the
emitter converts them out. There is no text formatting and no spline maths here.

Axis values are as programmed: absolute or incremental according to the distance mode in
force (``SetDistanceMode``), ``None`` when the axis word is absent. Motion blocks carry the
*effective* feed of the move, so a program does not depend on which F words a particular
emitter chose to suppress.

Examples
--------
>>> from gcode.program import Linear, Program, Rapid
>>> p = Program((Rapid(x=0.0, y=0.0, z=5.0), Linear(z=-1.0, feed=300.0)), name="demo")
>>> len(p), p.blocks[1].feed
(2, 300.0)
"""

from __future__ import annotations

import math
from abc import abstractmethod
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any, TypeAlias, overload

__all__ = [
    "AXES",
    "ROTARY_AXES",
    "Arc",
    "Block",
    "Comment",
    "Coolant",
    "CoolantMode",
    "DistanceMode",
    "Dwell",
    "FeedMode",
    "Linear",
    "MotionBlock",
    "Plane",
    "Program",
    "ProgramEnd",
    "Rapid",
    "SetDistanceMode",
    "SetFeedMode",
    "SetPlane",
    "SetUnits",
    "SetWorkOffset",
    "Spindle",
    "SpindleDirection",
    "StoredBlocks",
    "ToolChange",
    "Units",
]

#: Axis field names in word order. X, Y, Z are lengths (mm); A, B, C are angles (degrees).
AXES: tuple[str, ...] = ("x", "y", "z", "a", "b", "c")
#: Rotary axes: never scaled by units.
ROTARY_AXES: frozenset[str] = frozenset({"a", "b", "c"})


class Units(IntEnum):
    """Length units of G-code *text* (value = the G number)."""

    INCH = 20
    MM = 21


class Plane(IntEnum):
    """Arc plane (value = the G number); axes listed as (first, second, normal)."""

    XY = 17
    ZX = 18
    YZ = 19

    @property
    def axes(self) -> tuple[str, str, str]:
        """In-plane axes (first, second) and the normal axis, as field names."""
        return _PLANE_AXES[self]

    @property
    def offsets(self) -> tuple[str, str]:
        """Centre-offset field names matching the in-plane axes (``i``, ``j``, ``k``)."""
        return _PLANE_OFFSETS[self]


_PLANE_AXES = {Plane.XY: ("x", "y", "z"), Plane.ZX: ("z", "x", "y"), Plane.YZ: ("y", "z", "x")}
_PLANE_OFFSETS = {Plane.XY: ("i", "j"), Plane.ZX: ("k", "i"), Plane.YZ: ("j", "k")}


class DistanceMode(IntEnum):
    """Absolute (G90) or incremental (G91) axis words."""

    ABSOLUTE = 90
    INCREMENTAL = 91


class FeedMode(IntEnum):
    """Feed interpretation: inverse time (G93, F in 1/min) or units per minute (G94)."""

    INVERSE_TIME = 93
    UNITS_PER_MINUTE = 94


class SpindleDirection(IntEnum):
    """Spindle state (value = the M number)."""

    CW = 3
    CCW = 4
    OFF = 5


class CoolantMode(IntEnum):
    """Coolant command (value = the M number): M7 mist on, M8 flood on, M9 all off."""

    MIST = 7
    FLOOD = 8
    OFF = 9


def _check_axes(obj: Any) -> None:
    for name in AXES:
        v = getattr(obj, name)
        if v is not None and not math.isfinite(v):
            raise ValueError(f"{type(obj).__name__}.{name} must be finite, got {v!r}")


def _check_feed(obj: Any) -> None:
    if not (math.isfinite(obj.feed) and obj.feed > 0.0):
        raise ValueError(f"{type(obj).__name__}.feed must be finite and > 0, got {obj.feed!r}")


@dataclass(frozen=True, slots=True, kw_only=True)
class Rapid:
    """Rapid positioning move (G0). Lengths in mm, rotary axes in degrees."""

    x: float | None = None  #: mm
    y: float | None = None  #: mm
    z: float | None = None  #: mm
    a: float | None = None  #: degrees
    b: float | None = None  #: degrees
    c: float | None = None  #: degrees

    def __post_init__(self) -> None:
        _check_axes(self)


@dataclass(frozen=True, slots=True, kw_only=True)
class Linear:
    """Linear feed move (G1) at ``feed`` (mm/min, or 1/min in inverse-time mode)."""

    x: float | None = None  #: mm
    y: float | None = None  #: mm
    z: float | None = None  #: mm
    a: float | None = None  #: degrees
    b: float | None = None  #: degrees
    c: float | None = None  #: degrees
    feed: float  #: mm/min (G94) or 1/min (G93); > 0

    def __post_init__(self) -> None:
        _check_axes(self)
        _check_feed(self)


@dataclass(frozen=True, slots=True, kw_only=True)
class Arc:
    """Circular (helical) feed move: G2 (``clockwise``) or G3, in ``plane``.

    The centre is given either by offsets ``i, j, k`` (mm, from the start point, always
    incremental) or by radius ``r`` (mm; negative selects the arc longer than 180 degrees).
    """

    clockwise: bool
    x: float | None = None  #: mm
    y: float | None = None  #: mm
    z: float | None = None  #: mm
    a: float | None = None  #: degrees
    b: float | None = None  #: degrees
    c: float | None = None  #: degrees
    i: float | None = None  #: mm, centre offset along X
    j: float | None = None  #: mm, centre offset along Y
    k: float | None = None  #: mm, centre offset along Z
    r: float | None = None  #: mm, radius form
    plane: Plane = Plane.XY
    feed: float  #: mm/min (G94) or 1/min (G93); > 0

    def __post_init__(self) -> None:
        _check_axes(self)
        _check_feed(self)
        offs = (self.i, self.j, self.k)
        if self.r is None and all(v is None for v in offs):
            raise ValueError("Arc needs centre offsets (i, j, k) or a radius r")
        if self.r is not None and any(v is not None for v in offs):
            raise ValueError("Arc takes either offsets (i, j, k) or a radius r, not both")
        for v in (*offs, self.r):
            if v is not None and not math.isfinite(v):
                raise ValueError(f"Arc centre values must be finite, got {v!r}")


@dataclass(frozen=True, slots=True)
class Dwell:
    """Pause (G4) for ``seconds`` (s, >= 0)."""

    seconds: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.seconds) and self.seconds >= 0.0):
            raise ValueError(f"Dwell.seconds must be finite and >= 0, got {self.seconds!r}")


@dataclass(frozen=True, slots=True)
class Spindle:
    """Spindle command (M3/M4/M5) with speed ``rpm`` (rev/min, >= 0)."""

    direction: SpindleDirection
    rpm: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.rpm) and self.rpm >= 0.0):
            raise ValueError(f"Spindle.rpm must be finite and >= 0, got {self.rpm!r}")


@dataclass(frozen=True, slots=True)
class Coolant:
    """Coolant command: M7 (mist on), M8 (flood on) or M9 (all off)."""

    mode: CoolantMode


@dataclass(frozen=True, slots=True)
class ToolChange:
    """Tool change to ``tool`` (T<n> M6); tool numbers are >= 0."""

    tool: int

    def __post_init__(self) -> None:
        if self.tool < 0:
            raise ValueError(f"ToolChange.tool must be >= 0, got {self.tool!r}")


@dataclass(frozen=True, slots=True)
class SetUnits:
    """Switch the text's length units (G20/G21) mid-program; the IR stays in mm."""

    units: Units


@dataclass(frozen=True, slots=True)
class SetDistanceMode:
    """Absolute (G90) or incremental (G91) axis words from here on."""

    mode: DistanceMode


@dataclass(frozen=True, slots=True)
class SetPlane:
    """Select the arc plane (G17/G18/G19)."""

    plane: Plane


@dataclass(frozen=True, slots=True)
class SetFeedMode:
    """Units-per-minute (G94) or inverse-time (G93) feed from here on."""

    mode: FeedMode


@dataclass(frozen=True, slots=True)
class SetWorkOffset:
    """Select work coordinate system ``index`` 1-6 (G54-G59)."""

    index: int

    def __post_init__(self) -> None:
        if not 1 <= self.index <= 6:
            raise ValueError(f"SetWorkOffset.index must be 1..6 (G54..G59), got {self.index!r}")


@dataclass(frozen=True, slots=True)
class Comment:
    """A comment; emitted in the dialect's comment style."""

    text: str


@dataclass(frozen=True, slots=True)
class ProgramEnd:
    """End of program: M30 (``rewind``) or M2."""

    rewind: bool = True


MotionBlock: TypeAlias = Rapid | Linear | Arc
Block: TypeAlias = (
    Rapid
    | Linear
    | Arc
    | Dwell
    | Spindle
    | Coolant
    | ToolChange
    | SetUnits
    | SetDistanceMode
    | SetPlane
    | SetFeedMode
    | SetWorkOffset
    | Comment
    | ProgramEnd
)


class StoredBlocks(Sequence["Block"]):
    """Base of immutable block sequences stored otherwise than as a tuple.

    ``Program.blocks`` is a tuple or one of these (see :mod:`gcode.block_sequence`, where
    parsed runs of plain moves stay numpy columns). Implementations are read-only, hold
    the same values as ``tuple(self)``, and compare equal to that tuple.
    """

    __slots__ = ()

    @overload
    def __getitem__(self, index: int) -> Block: ...
    @overload
    def __getitem__(self, index: slice) -> Sequence[Block]: ...
    @abstractmethod
    def __getitem__(self, index: int | slice) -> Block | Sequence[Block]:
        """Block ``index`` (or the blocks of a slice)."""


@dataclass(frozen=True, slots=True)
class Program:
    """A G-code program: a tuple of blocks plus metadata.

    Parameters
    ----------
    blocks : tuple of Block or StoredBlocks
        The blocks in execution order (other sequences are converted to tuples). Parsed
        programs hold a :class:`~gcode.block_sequence.BlockSequence`, equal to the tuple
        of its blocks.
    name : str or None
        Program name (written as the O-line comment by dialects with program numbers).
    number : int or None
        Program number (``O`` word) for dialects that use one.
    units : Units
        Length units of the G-code text the emitter writes (G20 inch or G21 mm). The
        blocks themselves are always in mm whatever this says.
    source_lines : tuple of int or None
        For parsed programs, the 1-based source line of each block (not compared).
    """

    blocks: tuple[Block, ...] | StoredBlocks = ()
    name: str | None = None
    number: int | None = None
    units: Units = Units.MM
    source_lines: tuple[int, ...] | None = field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.blocks, tuple | StoredBlocks):
            object.__setattr__(self, "blocks", tuple(self.blocks))
        if self.source_lines is not None:
            if not isinstance(self.source_lines, tuple):
                object.__setattr__(self, "source_lines", tuple(self.source_lines))
            if len(self.source_lines) != len(self.blocks):
                raise ValueError(
                    f"source_lines has {len(self.source_lines)} entries for "
                    f"{len(self.blocks)} blocks"
                )
        if self.number is not None and self.number < 0:
            raise ValueError(f"Program.number must be >= 0, got {self.number!r}")

    def __len__(self) -> int:
        return len(self.blocks)

    def __iter__(self) -> Iterator[Block]:
        return iter(self.blocks)

    def line_of(self, index: int) -> int | None:
        """Return the 1-based source line of block ``index`` (None if not parsed)."""
        return None if self.source_lines is None else self.source_lines[index]
