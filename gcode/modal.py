"""Modal groups, the frozen ``ModalState`` and its transition rules.

The parser, the emitter, the interpreter and (later) the simulator all track state with
:class:`ModalState` and :meth:`ModalState.apply`, so "what G2 means after G18 G91" is
decided in one place. The state is immutable: a block is checked against the old state
and the new state is committed only when the whole block is good (practice 2).

Lengths in the state are mm, angles degrees, feed mm/min (1/min in inverse time).

Examples
--------
>>> from gcode.modal import ModalState
>>> from gcode.program import Linear, SetDistanceMode, DistanceMode
>>> s = ModalState().apply(Linear(x=10.0, feed=500.0))
>>> s.position[0], s.feed
(10.0, 500.0)
>>> s = s.apply(SetDistanceMode(DistanceMode.INCREMENTAL)).apply(Linear(x=2.5, feed=500.0))
>>> s.position[0]
12.5
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from enum import Enum, IntEnum

from gcode.program import (
    AXES,
    Arc,
    Block,
    Comment,
    Coolant,
    CoolantMode,
    DistanceMode,
    Dwell,
    FeedMode,
    Linear,
    Plane,
    ProgramEnd,
    Rapid,
    SetDistanceMode,
    SetFeedMode,
    SetPlane,
    SetUnits,
    SetWorkOffset,
    Spindle,
    SpindleDirection,
    ToolChange,
    Units,
)

__all__ = [
    "EXECUTION_ORDER",
    "G_GROUPS",
    "M_GROUPS",
    "ModalGroup",
    "ModalState",
    "MotionMode",
]


class MotionMode(IntEnum):
    """Motion modal group (value = the G number)."""

    RAPID = 0
    LINEAR = 1
    ARC_CW = 2
    ARC_CCW = 3


class ModalGroup(Enum):
    """Modal groups of the words we support (RS274/NGC and GRBL numbering)."""

    NON_MODAL = "G group 0 (G4)"
    MOTION = "G group 1 (G0-G3)"
    PLANE = "G group 2 (G17-G19)"
    DISTANCE = "G group 3 (G90/G91)"
    FEED_MODE = "G group 5 (G93/G94)"
    UNITS = "G group 6 (G20/G21)"
    WCS = "G group 12 (G54-G59)"
    STOP = "M group 4 (M2/M30)"
    TOOL_CHANGE = "M group 6 (M6)"
    SPINDLE = "M group 7 (M3-M5)"
    COOLANT = "M group 8 (M7-M9)"


#: Supported G numbers and their modal group.
G_GROUPS: dict[int, ModalGroup] = {
    0: ModalGroup.MOTION,
    1: ModalGroup.MOTION,
    2: ModalGroup.MOTION,
    3: ModalGroup.MOTION,
    4: ModalGroup.NON_MODAL,
    17: ModalGroup.PLANE,
    18: ModalGroup.PLANE,
    19: ModalGroup.PLANE,
    20: ModalGroup.UNITS,
    21: ModalGroup.UNITS,
    54: ModalGroup.WCS,
    55: ModalGroup.WCS,
    56: ModalGroup.WCS,
    57: ModalGroup.WCS,
    58: ModalGroup.WCS,
    59: ModalGroup.WCS,
    90: ModalGroup.DISTANCE,
    91: ModalGroup.DISTANCE,
    93: ModalGroup.FEED_MODE,
    94: ModalGroup.FEED_MODE,
}

#: Supported M numbers and their modal group.
M_GROUPS: dict[int, ModalGroup] = {
    2: ModalGroup.STOP,
    30: ModalGroup.STOP,
    3: ModalGroup.SPINDLE,
    4: ModalGroup.SPINDLE,
    5: ModalGroup.SPINDLE,
    6: ModalGroup.TOOL_CHANGE,
    7: ModalGroup.COOLANT,
    8: ModalGroup.COOLANT,
    9: ModalGroup.COOLANT,
}

#: Order in which the parts of one block take effect (RS274/NGC "order of execution",
#: LinuxCNC docs table; F, S and T selection happen between FEED_MODE and TOOL_CHANGE).
#: A block yields its IR blocks in this order.
EXECUTION_ORDER: tuple[type, ...] = (
    Comment,
    SetFeedMode,
    ToolChange,
    Spindle,
    Coolant,
    Dwell,
    SetPlane,
    SetUnits,
    SetWorkOffset,
    SetDistanceMode,
    Rapid,
    Linear,
    Arc,
    ProgramEnd,
)

_ZERO6 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True, slots=True)
class ModalState:
    """The interpreter state between blocks (GRBL's power-on defaults by default).

    Parameters
    ----------
    motion : MotionMode
        Current motion mode (G0-G3); axis words without a G word use it.
    plane : Plane
        Arc plane (G17-G19).
    units : Units
        Units of the *text* being read or written (G20/G21). Internal values stay mm.
    distance : DistanceMode
        Absolute (G90) or incremental (G91).
    feed_mode : FeedMode
        Units per minute (G94) or inverse time (G93).
    wcs : int
        Work coordinate system 1-6 (G54-G59).
    feed : float or None
        Modal feed, mm/min (G94) or 1/min (G93); None when undefined.
    spindle : SpindleDirection
        Spindle state (M3/M4/M5).
    rpm : float
        Modal spindle speed S, rev/min.
    mist, flood : bool
        Coolant states (M7, M8; M9 clears both).
    tool : int
        Tool in the spindle (after the last M6).
    selected_tool : int
        Tool selected by the last T word.
    position : tuple of float
        Programmed position X Y Z A B C in the current work system (mm, degrees).
    """

    motion: MotionMode = MotionMode.RAPID
    plane: Plane = Plane.XY
    units: Units = Units.MM
    distance: DistanceMode = DistanceMode.ABSOLUTE
    feed_mode: FeedMode = FeedMode.UNITS_PER_MINUTE
    wcs: int = 1
    feed: float | None = None
    spindle: SpindleDirection = SpindleDirection.OFF
    rpm: float = 0.0
    mist: bool = False
    flood: bool = False
    tool: int = 0
    selected_tool: int = 0
    position: tuple[float, float, float, float, float, float] = _ZERO6

    def target(self, block: Rapid | Linear | Arc) -> tuple[float, ...]:
        """Return the programmed end position of a motion block (mm, degrees).

        Parameters
        ----------
        block : Rapid, Linear or Arc
            Axis words as programmed (absolute or incremental per ``distance``).

        Returns
        -------
        tuple of float
            X Y Z A B C after the move, in the current work system.
        """
        pos = self.position
        incremental = self.distance is DistanceMode.INCREMENTAL
        out = list(pos)
        for n, name in enumerate(AXES):
            v = getattr(block, name)
            if v is not None:
                out[n] = pos[n] + v if incremental else v
        return tuple(out)

    def apply(self, block: Block) -> ModalState:
        """Return the state after ``block`` has executed.

        Parameters
        ----------
        block : Block
            Any IR block.

        Returns
        -------
        ModalState
            The new state (``self`` when the block changes nothing).
        """
        if isinstance(block, Linear):
            return replace(
                self, motion=MotionMode.LINEAR, feed=block.feed, position=self.target(block)
            )
        if isinstance(block, Rapid):
            return replace(self, motion=MotionMode.RAPID, position=self.target(block))
        if isinstance(block, Arc):
            mode = MotionMode.ARC_CW if block.clockwise else MotionMode.ARC_CCW
            return replace(self, motion=mode, feed=block.feed, position=self.target(block))
        if isinstance(block, Comment | Dwell):
            return self
        if isinstance(block, Spindle):
            return replace(self, spindle=block.direction, rpm=block.rpm)
        if isinstance(block, Coolant):
            if block.mode is CoolantMode.MIST:
                return replace(self, mist=True)
            if block.mode is CoolantMode.FLOOD:
                return replace(self, flood=True)
            return replace(self, mist=False, flood=False)
        if isinstance(block, ToolChange):
            return replace(self, tool=block.tool, selected_tool=block.tool)
        if isinstance(block, SetUnits):
            return replace(self, units=block.units)
        if isinstance(block, SetDistanceMode):
            return replace(self, distance=block.mode)
        if isinstance(block, SetPlane):
            return replace(self, plane=block.plane)
        if isinstance(block, SetFeedMode):
            return self.with_feed_mode(block.mode)
        if isinstance(block, SetWorkOffset):
            return replace(self, wcs=block.index)
        if isinstance(block, ProgramEnd):
            return self.after_program_end()
        raise TypeError(f"not a G-code block: {block!r}")

    def with_feed_mode(self, mode: FeedMode) -> ModalState:
        """Switch feed mode; a change between G93 and G94 leaves the feed undefined.

        LinuxCNC sets F to 0 on the switch and GRBL resets it, so the next feed move
        must carry an F word (error 22 otherwise).
        """
        if mode is self.feed_mode:
            return self
        return replace(self, feed_mode=mode, feed=None)

    def after_program_end(self) -> ModalState:
        """Return the state after M2/M30 (GRBL 1.1 ``gc_state`` program-end reset).

        Motion G1, plane G17, G90, G94, G54, spindle off, coolant off; units, feed value,
        spindle speed, tool and position are kept.
        """
        return replace(
            self,
            motion=MotionMode.LINEAR,
            plane=Plane.XY,
            distance=DistanceMode.ABSOLUTE,
            feed_mode=FeedMode.UNITS_PER_MINUTE,
            feed=self.feed if self.feed_mode is FeedMode.UNITS_PER_MINUTE else None,
            wcs=1,
            spindle=SpindleDirection.OFF,
            mist=False,
            flood=False,
        )
