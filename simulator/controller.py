"""The controller core: parse, plan and execute lines on a virtual clock.

:class:`Controller` is what every front end (GRBL serial, Modbus) drives. It accepts one
line at a time (:meth:`Controller.submit`), parses it with :class:`gcode.BlockParser`
(atomic: a bad line changes nothing), checks soft limits against the machine's travel,
splits arcs into chords within ``$12``, and queues straight blocks in a 15-block
:class:`~simulator.planner.PlannerQueue`. Time moves only through :meth:`advance_to` /
:meth:`step` (no sleeps, no wall clock), and the axes follow trapezoidal profiles with
grbl's look-ahead, so positions, feeds and durations are what a real machine would show.

Lines that must wait for the machine to stop (dwell ``G4``, spindle, coolant, tool
change, program end) hold the input until done, as grbl's ``protocol_buffer_synchronize``
does, and so do lines whose blocks do not all fit in the queue yet (long arcs). A front
end asks :attr:`Controller.accepting` before submitting and :attr:`Controller.line_pending`
before answering ``ok``.

States: Idle, Run, Hold (``hold_complete`` False while decelerating), Alarm, Check.
Alarms 1 and 2 are critical: nothing but a soft reset is served until then.

Examples
--------
>>> from machines import load_machine
>>> c = Controller(load_machine("grbl-router"))
>>> c.submit("G1X-10F600").accepted
True
>>> c.run_until_idle()
>>> c.position(), round(c.now_s, 3), c.state.value
((-10.0, 0.0, 0.0), 1.012, 'Idle')
"""

from __future__ import annotations

import math
import re
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import Enum, IntEnum

from gcode import BlockParser, Dialect, GCodeError, ModalState, Program
from gcode.dialects import GRBL, LINUXCNC
from gcode.interpreter import interpret
from gcode.program import (
    Arc,
    Coolant,
    Dwell,
    FeedMode,
    Linear,
    ProgramEnd,
    Rapid,
    Spindle,
    SpindleDirection,
    ToolChange,
)
from machines import Machine
from machines.limits import TRAVEL_TOLERANCE
from simulator.clock import VirtualClock
from simulator.journal import Journal
from simulator.motion import (
    AxisLimits,
    advance_in_block,
    block_kinematics,
    junction_speed_sq,
)
from simulator.planner import GRBL_PLANNER_BLOCKS, MotionBlock, PlannerQueue
from simulator.settings import Settings

__all__ = ["MODES", "SYNC_BLOCK_TYPES", "Alarm", "Controller", "State", "SubmitResult"]

_SLOTS = "XYZABC"
_ZERO6 = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
_N_WORD = re.compile(r"N(\d+)")
#: Blocks that wait for the planner to empty before they run (as grbl synchronises
#: dwells, spindle, coolant, tool changes and program end with motion).
SYNC_BLOCK_TYPES = (Dwell, Spindle, Coolant, ToolChange, ProgramEnd)
#: Protocol modes: ``grbl`` (XYZ only, like the firmware) and ``linuxcnc`` (the
#: machine's axes, G93 inverse time, M6), both over the GRBL serial protocol.
MODES = ("grbl", "linuxcnc")


class State(Enum):
    """Machine state as a status report names it."""

    IDLE = "Idle"
    RUN = "Run"
    HOLD = "Hold"
    ALARM = "Alarm"
    CHECK = "Check"


class Alarm(IntEnum):
    """GRBL 1.1 alarm numbers (``ALARM:N``)."""

    HARD_LIMIT = 1
    SOFT_LIMIT = 2
    ABORT_CYCLE = 3
    PROBE_FAIL_INITIAL = 4
    PROBE_FAIL_CONTACT = 5
    HOMING_FAIL_RESET = 6
    HOMING_FAIL_DOOR = 7
    HOMING_FAIL_PULLOFF = 8
    HOMING_FAIL_APPROACH = 9

    @property
    def critical(self) -> bool:
        """Hard and soft limits: only a soft reset is served afterwards."""
        return self in (Alarm.HARD_LIMIT, Alarm.SOFT_LIMIT)


@dataclass(frozen=True, slots=True)
class SubmitResult:
    """Outcome of :meth:`Controller.submit`.

    Attributes
    ----------
    status : str
        ``"accepted"`` (answer ``ok`` once :attr:`Controller.line_pending` is False),
        ``"error"`` (answer ``error:code``) or ``"alarm"`` (no answer: an alarm follows).
    seq : int
        Controller sequence number of an accepted line (0 otherwise).
    code : int
        GRBL error number, or the alarm number.
    message : str
        What went wrong, for logs.
    """

    status: str
    seq: int = 0
    code: int = 0
    message: str = ""

    @property
    def accepted(self) -> bool:
        """True for an accepted line."""
        return self.status == "accepted"


@dataclass(slots=True, eq=False)
class _Sync:
    """A line that waits for the queue to empty, then dwells (s)."""

    dwell_s: float
    state: ModalState
    seq: int
    riders: list = field(default_factory=list)
    end_s: float | None = None


_Record = tuple[int, int, int | None, str]  # seq, line, n_word, text


def dialect_for(machine: Machine, mode: str) -> Dialect:
    """The parser dialect of a protocol mode on a machine.

    Parameters
    ----------
    machine : Machine
        Its axes limit what ``linuxcnc`` mode accepts.
    mode : str
        ``"grbl"`` or ``"linuxcnc"``.

    Returns
    -------
    Dialect
        ``grbl``: X Y Z, no G93, no M6 (A/B/C answer ``error:20``). ``linuxcnc``: the
        machine's axes, G93, M6. Both keep GRBL's 79-character line limit.

    Raises
    ------
    ValueError
        For an unknown mode.
    """
    if mode == "grbl":
        return GRBL
    if mode == "linuxcnc":
        axes = tuple(a.letter.lower() for a in machine.axes)
        return replace(LINUXCNC, axes=axes, max_line_length=GRBL.max_line_length)
    raise ValueError(f"unknown protocol mode {mode!r}; use one of {', '.join(MODES)}")


class Controller:
    """A simulated CNC controller core (no I/O, virtual time).

    Parameters
    ----------
    machine : Machine
        Axes, travel (soft limits), rates and accelerations.
    mode : str or None
        ``"grbl"`` or ``"linuxcnc"``; default from ``machine.dialect``.
    clock : VirtualClock or None
        Injected clock (a new one at 0 s if None).
    planner_blocks : int
        Planner queue size (grbl: 15).
    work_offsets : mapping of int to sequence of float, optional
        G54..G59 (keys 1..6) offsets X Y Z A B C, mm and deg; zero by default (programs
        carry machine coordinates, as :mod:`machines.kinematics` produces them).

    Attributes
    ----------
    journal : Journal
        Executed lines.
    settings : Settings
        The ``$n`` table.
    """

    def __init__(
        self,
        machine: Machine,
        *,
        mode: str | None = None,
        clock: VirtualClock | None = None,
        planner_blocks: int = GRBL_PLANNER_BLOCKS,
        work_offsets: Mapping[int, Sequence[float]] | None = None,
    ) -> None:
        self.machine = machine
        self.mode = (
            mode if mode is not None else ("grbl" if machine.dialect == "grbl" else "linuxcnc")
        )
        self.dialect = dialect_for(machine, self.mode)
        self.clock = clock if clock is not None else VirtualClock()
        letters = "".join(a.letter for a in machine.axes)
        self.report_axes = (
            "XYZ" if self.mode == "grbl" else "".join(c for c in _SLOTS if c in letters)
        )
        self._report_idx = tuple(_SLOTS.index(c) for c in self.report_axes)
        self.settings = Settings.from_machine(machine, self.report_axes)
        self._base_limits = AxisLimits.from_machine(machine)
        self.limits = self.settings.axis_limits(self._base_limits)
        self._travel = tuple(
            (_SLOTS.index(a.letter), a.min - TRAVEL_TOLERANCE, a.max + TRAVEL_TOLERANCE, a.letter)
            for a in machine.axes
            if a.is_limited
        )
        offsets = {k: tuple(float(v) for v in vals) for k, vals in (work_offsets or {}).items()}
        for k, vals in offsets.items():
            if k not in range(1, 7) or len(vals) != 6:
                raise ValueError(
                    f"work offset {k!r} must be G54..G59 as 1..6 with 6 values X Y Z A B C, "
                    f"got {vals!r}"
                )
        self.work_offsets = {k: offsets.get(k, _ZERO6) for k in range(1, 7)}
        self.planner = PlannerQueue(planner_blocks)
        self.journal = Journal(self.report_axes)
        self._seq = 0
        self.done_seq = 0
        self.restarts = 0
        self.resets = 0
        self.alarm: Alarm | None = None
        self.alarm_critical = False
        self.alarm_events: deque[Alarm] = deque()
        self.lines_checked = 0
        self._pos = _ZERO6
        self._power_on()

    # ------------------------------------------------------------------ life cycle
    def _power_on(self) -> None:
        self._bp = BlockParser(self.dialect, state=self._fresh_state())
        self.planner.clear()
        self._pending: deque[MotionBlock | _Sync] = deque()
        self._plan_pos = self._pos
        self._prev_unit = _ZERO6
        self._prev_speed = 0.0
        self._s = 0.0  # mm done in the head block
        self._v = 0.0  # mm/s
        self.hold = False
        self.check_mode = False
        self._soft_limit_pending = False
        self._active = self._bp.state  # spindle/coolant as executed

    def _fresh_state(self) -> ModalState:
        off = self.work_offsets[1]
        return ModalState(position=tuple(p - o for p, o in zip(self._pos, off, strict=True)))  # type: ignore[arg-type]

    def soft_reset(self) -> Alarm | None:
        """Ctrl-X: stop at once, flush everything, reset the parser; position is kept.

        Returns
        -------
        Alarm or None
            ``ABORT_CYCLE`` (3) when the axes were moving (position may be lost, the
            controller comes back locked in Alarm); None otherwise.
        """
        raised = None
        self._pos = self.position6()
        if self._v > 0.0 or (self.planner and not self.hold):
            raised = Alarm.ABORT_CYCLE
            self.alarm = raised
            self.alarm_events.append(raised)
        self._power_on()
        self.alarm_critical = False
        self.resets += 1
        return raised

    def restart(self) -> None:
        """Power cycle (fault injection): like a reset, no alarm, Idle; position is kept."""
        self._pos = self.position6()
        self.alarm = None
        self.alarm_critical = False
        self._power_on()
        self.restarts += 1

    def raise_alarm(self, code: int) -> Alarm:
        """Stop at once and lock in ``ALARM:code`` (1 and 2 are critical).

        Raises
        ------
        ValueError
            For a number that is not a GRBL alarm (1-9).
        """
        try:
            alarm = Alarm(code)
        except ValueError:
            raise ValueError(f"alarm code must be 1..9 (GRBL ALARM:N), got {code!r}") from None
        self._pos = self.position6()
        self._power_on()
        self.alarm = alarm
        self.alarm_critical = alarm.critical
        self.alarm_events.append(alarm)
        return alarm

    def unlock(self) -> bool:
        """``$X``: leave a non-critical alarm; returns True if there was one to clear."""
        if self.alarm is None or self.alarm_critical:
            return False
        self.alarm = None
        return True

    # ------------------------------------------------------------------ state
    @property
    def now_s(self) -> float:
        """Virtual time, s."""
        return self.clock.now_s

    @property
    def critical(self) -> bool:
        """A hard or soft limit alarm (or one pending): only a soft reset helps."""
        return self._soft_limit_pending or self.alarm_critical

    @property
    def state(self) -> State:
        """Idle, Run, Hold, Alarm or Check."""
        if self.alarm is not None:
            return State.ALARM
        if self.check_mode:
            return State.CHECK
        if self.hold:
            return State.HOLD
        if self.planner:
            return State.RUN
        return State.IDLE

    @property
    def hold_complete(self) -> bool:
        """In a hold, True once the axes have stopped (``Hold:0``)."""
        return self.hold and self._v == 0.0

    @property
    def accepting(self) -> bool:
        """True when a new line would be taken now (room in the planner, no line waiting)."""
        return not self._pending and not self.planner.full and not self.critical

    @property
    def line_pending(self) -> bool:
        """True while the last accepted line still waits (its ``ok`` is not due yet)."""
        return bool(self._pending)

    @property
    def planner_free(self) -> int:
        """Free planner blocks (``Bf:`` first field)."""
        return self.planner.free

    @property
    def parser_state(self) -> ModalState:
        """Modal state of the parser (what ``$G`` reports)."""
        return self._bp.state

    @property
    def executed_state(self) -> ModalState:
        """Modal state of the last synchronizing line executed (spindle, coolant)."""
        return self._active

    @property
    def last_seq(self) -> int:
        """Sequence number of the last accepted line."""
        return self._seq

    @property
    def executing_seq(self) -> int:
        """Sequence number of the line whose block is moving (0 when none)."""
        head = self.planner.head
        return head.seq if head is not None else 0

    @property
    def unfinished_seq(self) -> int | None:
        """Sequence number of the oldest line not yet executed (None when all are done)."""
        head = self.planner.head
        if head is not None:
            return head.seq
        return self._pending[0].seq if self._pending else None

    def position6(self) -> tuple[float, ...]:
        """Machine position in all six slots X Y Z A B C (mm, deg)."""
        head = self.planner.head
        if head is None or self._s == 0.0:
            return self._pos if head is None else head.start
        s = self._s
        return tuple(a + u * s for a, u in zip(head.start, head.unit, strict=True))

    def position(self) -> tuple[float, ...]:
        """Machine position of the reported axes (mm, deg)."""
        p = self.position6()
        return tuple(p[i] for i in self._report_idx)

    def work_position(self) -> tuple[float, ...]:
        """Position in the active work system (machine minus the work offset)."""
        p = self.position6()
        off = self.work_offsets[self._bp.state.wcs]
        return tuple(p[i] - off[i] for i in self._report_idx)

    def work_offset(self) -> tuple[float, ...]:
        """Active work offset of the reported axes (``WCO:``)."""
        off = self.work_offsets[self._bp.state.wcs]
        return tuple(off[i] for i in self._report_idx)

    def feed_mm_per_min(self) -> float:
        """Current feed as a status report shows it (XYZ speed), mm/min."""
        head = self.planner.head
        if head is None:
            return 0.0
        return self._v * 60.0 * head.feed_ratio

    def spindle_rpm(self) -> float:
        """Spindle speed as executed, rev/min (0 when off)."""
        st = self._active
        return 0.0 if st.spindle is SpindleDirection.OFF else st.rpm

    # ------------------------------------------------------------------ commands
    def feed_hold(self) -> None:
        """``!``: decelerate to a stop and hold (ignored in Alarm and Check)."""
        if self.alarm is None and not self.check_mode:
            self.hold = True

    def cycle_start(self) -> None:
        """``~``: resume from a completed hold (ignored while still decelerating)."""
        if self.hold and self._v == 0.0:
            self.hold = False

    def set_check_mode(self, on: bool) -> int:
        """``$C``: enter check mode (only from Idle); leaving it soft-resets.

        Returns
        -------
        int
            0, or GRBL error 8 when the controller is not idle.
        """
        if on:
            if self.state is not State.IDLE or self._pending:
                return 8
            self.check_mode = True
            return 0
        if self.check_mode:
            self.soft_reset()
        return 0

    def set_setting(self, number: int, value: float) -> int:
        """``$n=value``; returns 0 or the GRBL error number."""
        code = self.settings.set(number, value)
        if code == 0:
            self.limits = self.settings.axis_limits(self._base_limits)
        return code

    # ------------------------------------------------------------------ input
    def submit(self, text: str, *, line: int = 0) -> SubmitResult:
        """Take one G-code line (upper case, no comments, as a front end assembled it).

        Parameters
        ----------
        text : str
            The block, e.g. ``"G1X10F500"``.
        line : int
            Source line as the front end numbers it (journaled).

        Returns
        -------
        SubmitResult
            Accepted (with its sequence number), an error (GRBL number), or an alarm.

        Raises
        ------
        RuntimeError
            If called while :attr:`accepting` is False (the front end must wait).
        """
        if not self.accepting:
            raise RuntimeError(
                "controller is not accepting a line now (planner full, a line waiting, "
                "or a critical alarm); wait for Controller.accepting"
            )
        if self.alarm is not None:
            return SubmitResult("error", code=9, message="G-code locked out during alarm")
        bp = self._bp
        before = bp.state
        try:
            blocks = bp.parse_line(text, line)
        except GCodeError as err:
            return SubmitResult("error", code=err.code.grbl, message=str(err))
        after = bp.state
        motion = None
        syncs = []
        for b in blocks:
            t = type(b)
            if t is Linear or t is Rapid or t is Arc:
                motion = b
            elif isinstance(b, SYNC_BLOCK_TYPES):
                syncs.append(b)
        chords = self._targets(motion, before, after) if motion is not None else []
        bad = self._soft_limit_violation(chords)
        if bad is not None:
            bp.state = before
            return self._soft_limit(bad)
        self._seq += 1
        seq = self._seq
        m = _N_WORD.match(text)
        record: _Record = (seq, line, int(m.group(1)) if m else None, text)
        if self.check_mode:
            self.lines_checked += 1
            self.done_seq = seq
            return SubmitResult("accepted", seq=seq)
        if not blocks:  # nothing to execute (F alone, G21 first): done in turn, not journaled
            record = (seq, line, None, "")
        pending = self._pending
        if syncs:
            dwell = sum(b.seconds for b in syncs if type(b) is Dwell)
            pending.append(_Sync(dwell, after, seq))
        blocks_out = self._make_blocks(chords, motion, after, seq)
        pending.extend(blocks_out)
        if pending:
            pending[-1].riders.append(record)
            self._feed_planner()
        else:
            tail = self.planner.tail
            if tail is not None:
                tail.riders.append(record)
            else:
                self._journal(record)
        return SubmitResult("accepted", seq=seq)

    def _targets(
        self, motion: Rapid | Linear | Arc, before: ModalState, after: ModalState
    ) -> list[tuple[float, ...]]:
        off = self.work_offsets[after.wcs]
        if type(motion) is not Arc:
            p = after.position
            return [tuple(p[i] + off[i] for i in range(6))]
        start_prog = tuple(a - o for a, o in zip(self._plan_pos, off, strict=True))
        st = replace(after, position=start_prog)  # type: ignore[arg-type]
        seg = interpret(Program((motion,)), state=st, work_offsets={after.wcs: off})
        seg = seg.linearize(self.settings.arc_tolerance_mm)
        return [tuple(row) for row in seg.end.tolist()]

    def _soft_limit_violation(self, targets: list[tuple[float, ...]]) -> str | None:
        if not self.settings.soft_limits:
            return None
        for p in targets:
            for i, lo, hi, letter in self._travel:
                v = p[i]
                if not lo <= v <= hi:
                    return f"axis {letter} target {v:.3f} is outside travel [{lo:.3f}, {hi:.3f}]"
        return None

    def _soft_limit(self, message: str) -> SubmitResult:
        if self.check_mode or (self._v == 0.0 and not self.planner):
            self._alarm_now(Alarm.SOFT_LIMIT)
        else:
            self._soft_limit_pending = True
            self.hold = True
        return SubmitResult("alarm", code=int(Alarm.SOFT_LIMIT), message=message)

    def _alarm_now(self, alarm: Alarm) -> None:
        self._pos = self.position6()
        check = self.check_mode
        self._power_on()
        self.check_mode = check and not alarm.critical
        self.alarm = alarm
        self.alarm_critical = alarm.critical
        self.alarm_events.append(alarm)

    def _make_blocks(
        self,
        chords: list[tuple[float, ...]],
        motion: Rapid | Linear | Arc | None,
        after: ModalState,
        seq: int,
    ) -> list[MotionBlock]:
        if motion is None:
            return []
        out = []
        rapid = type(motion) is Rapid
        inverse = after.feed_mode is FeedMode.INVERSE_TIME
        feed = 0.0 if rapid else motion.feed  # type: ignore[union-attr]
        if inverse and len(chords) > 1:
            feed *= len(chords)  # each chord takes its share of the move's time
        start = self._plan_pos
        limits = self.limits
        jd = self.settings.junction_deviation_mm
        for end in chords:
            delta = tuple(e - s for e, s in zip(end, start, strict=True))
            k = block_kinematics(delta, feed, rapid=rapid, inverse_time=inverse, limits=limits)
            if k.length == 0.0:
                continue  # grbl drops zero-length blocks
            j2 = junction_speed_sq(self._prev_unit, k.unit, limits, jd)
            vn = k.nominal_speed
            max_entry = min(j2, vn * vn, self._prev_speed * self._prev_speed)
            out.append(
                MotionBlock(start, end, k.length, k.unit, vn, k.accel, max_entry, k.feed_ratio, seq)
            )
            self._prev_unit, self._prev_speed = k.unit, vn
            start = end
        self._plan_pos = start
        return out

    def _feed_planner(self) -> None:
        pending = self._pending
        planner = self.planner
        while pending:
            item = pending[0]
            if type(item) is MotionBlock:
                if planner.full:
                    return
                planner.append(item)
                pending.popleft()
                continue
            # a synchronizing line: the queue must be empty and the axes stopped
            if planner or self._v > 0.0:
                return
            if item.end_s is None:
                item.end_s = self.clock.now_s + item.dwell_s
            if self.clock.now_s < item.end_s:
                return
            pending.popleft()
            self._active = item.state
            for r in item.riders:
                self._journal(r)

    def _journal(self, record: _Record) -> None:
        seq, line, n_word, text = record
        self.done_seq = seq
        if not text:
            return
        p = self._pos
        self.journal.record(
            seq=seq,
            line=line,
            n_word=n_word,
            text=text,
            position=tuple(p[i] for i in self._report_idx),
            time_s=self.clock.now_s,
        )

    # ------------------------------------------------------------------ time
    def step(self, dt_s: float) -> None:
        """Advance virtual time by ``dt_s`` seconds, moving the axes."""
        self.advance_to(self.clock.now_s + dt_s)

    def advance_to(self, t_s: float, until: Callable[[], bool] | None = None) -> None:
        """Run the machine until virtual time ``t_s`` (or until ``until()`` is True).

        Parameters
        ----------
        t_s : float
            Target time, s (``inf`` with ``until`` runs until the condition holds or
            nothing more can happen).
        until : callable or None
            Checked after every event (block done, hold complete, dwell done).
        """
        clock = self.clock
        planner = self.planner
        while clock.now_s < t_s:
            if until is not None and until():
                return
            if self.alarm_critical:
                clock.advance_to(t_s if math.isfinite(t_s) else clock.now_s)
                return
            head = planner.head
            now = clock.now_s
            if head is None or (self.hold and self._v == 0.0):
                if self._soft_limit_pending:
                    self._soft_limit_pending = False
                    self._alarm_now(Alarm.SOFT_LIMIT)
                    return
                sync = self._pending[0] if self._pending else None
                if type(sync) is _Sync and head is None:
                    if sync.end_s is None:
                        self._feed_planner()
                        continue
                    end = min(t_s, sync.end_s)
                    clock.advance_to(end)
                    self._feed_planner()
                    continue
                if math.isfinite(t_s):
                    clock.advance_to(t_s)
                return
            vx2 = planner.head_exit_bound_sq()
            s, v, used = advance_in_block(
                self._s,
                self._v,
                head.length,
                head.nominal_speed,
                math.sqrt(vx2),
                head.accel,
                t_s - now,
                self.hold,
            )
            self._s, self._v = s, v
            if now + used == now and s < head.length and not (self.hold and v == 0.0):
                clock.advance_to(t_s if math.isfinite(t_s) else now)
                return
            clock.advance(used)
            if s >= head.length:
                planner.pop()
                self._pos = head.end
                self._s = 0.0
                for r in head.riders:
                    self._journal(r)
                if not planner:
                    self._v = 0.0
                self._feed_planner()
        if until is not None:
            until()

    def run_until_idle(self, max_s: float = math.inf) -> None:
        """Run until nothing is queued or waiting (a hold stops it too), at most ``max_s``."""
        self.advance_to(
            self.clock.now_s + max_s,
            until=lambda: not self.planner and not self._pending and not self._soft_limit_pending,
        )

    def run_until_accepting(self) -> None:
        """Run just long enough for :attr:`accepting` (instant mode: the wait is free)."""
        self.advance_to(math.inf, until=lambda: self.accepting or self.hold_complete)

    def run_until_line_done(self) -> None:
        """Run until the last accepted line no longer waits (its ``ok`` is due)."""
        self.advance_to(math.inf, until=lambda: not self._pending or self.hold_complete)

    def run_until_stopped(self) -> None:
        """Run until the axes stand still (a hold completes, a pending soft limit fires)."""
        self.advance_to(
            math.inf,
            until=lambda: (
                (self._v == 0.0 and not self._soft_limit_pending)
                and (self.hold or not self.planner)
            ),
        )
