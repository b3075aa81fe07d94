r"""The GRBL 1.1 sender: drives :class:`~gcode.senders.grbl_stream.GrblStream` over a link.

:class:`GrblSender` is the blocking driver around the sans-IO protocol (its recovery
half, safe stops and resume location, is :mod:`gcode.senders.grbl_recovery`). It only moves
bytes between a :class:`~gcode.senders.link.Link` and the stream and decides what to do
about events, with every wait bounded (:class:`~gcode.senders.grbl_stream.Timeouts`):

:meth:`GrblSender.connect`
    Start-up handshake: ``?`` (and the boot banner of a board reset by opening its port),
    wait while the machine still moves, soft reset, wait for the banner, read the state
    (refusing an Alarm unless asked to unlock with ``$X``), then ``$I`` (receive-buffer
    size) and ``$#`` (work offsets, for locating a stop on the program's path).
:meth:`GrblSender.check`
    ``$C`` dry run: every line parsed by the controller, every ``error:N`` collected,
    ``$C`` again (the controller resets).
:meth:`GrblSender.run`
    Streams a job (or a resume preamble plus the rest of it), journals every line sent
    and answered, reports progress, and ends only when every line is answered and the
    machine is Idle. Stops:

    * ``error:N``: nothing more is sent. With lines sent after the bad one (character
      counting) the machine is feed-held at once, and once stopped reset, so no line after
      the bad one runs; the position then tells where to resume
      (:func:`~gcode.senders.resume.locate_resume_line`). With nothing sent after it
      (send-response) the lines before it finish and the resume line is the bad line.
    * ``ALARM:N``: no line is answered any more; the sender resets the stopped controller
      (so the position can be read) and reports the alarm, the line being processed and
      where to resume once the machine is homed or unlocked.
    * an unasked banner (the controller restarted): feed hold at once, reset, report.
    * a lost link: reported with the last answered and unanswered lines; never retried.
    * a feed hold asked from another thread or a signal handler (:meth:`request_hold`,
      Ctrl-C in the CLI): ``!``, wait for ``Hold:0``, then ``on_hold(progress)`` decides:
      ``"resume"`` (``~``) or ``"cancel"`` (reset while held: position kept, no alarm).

Examples
--------
A sender needs a link; against the simulator (see the tests)::

    with run_simulator("grbl-router", serial="pty") as sim:
        link = open_serial_link(sim.serial_url)
        sender = GrblSender(link)
        sender.connect()
        result = sender.run(Job.from_file("part.nc"))
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from gcode.dialects import GENERIC, Dialect
from gcode.senders.errors import (
    AlarmError,
    HandshakeError,
    LineRejectedError,
    LineTooLongError,
    LinkLostError,
    LinkTimeoutError,
    SenderError,
)
from gcode.senders.grbl_messages import Feedback, StatusReport, error_text
from gcode.senders.grbl_recovery import GrblRecovery, HoldChoice, StreamStop
from gcode.senders.grbl_stream import (
    RX_BUFFER_BYTES,
    STATUS_INTERVAL_S,
    AlarmRaised,
    ControllerReset,
    Event,
    GrblStream,
    LineAcked,
    LineRejected,
    LineSent,
    Pushed,
    StatusUpdate,
    StreamMode,
    Timeouts,
    Unexpected,
)
from gcode.senders.job import Job, JobLine
from gcode.senders.journal import JobJournal
from gcode.senders.link import Link
from gcode.senders.progress import PROGRESS_INTERVAL_S, Progress
from gcode.senders.resume import ResumePlan, planned_line_ends

__all__ = [
    "BOOT_WAIT_S",
    "BUSY_WAIT_S",
    "CheckReport",
    "ControllerInfo",
    "GrblSender",
    "HoldChoice",
    "JobResult",
]

#: Longest wait for a first sign of life after opening the link (an Arduino resets
#: when its port opens and needs about 2 s to boot), s.
BOOT_WAIT_S = 3.0
#: Longest wait for a machine found moving at connection to stop by itself, s.
BUSY_WAIT_S = 300.0
#: A status report older than this no longer gives the progress position, s (then the
#: planned end of the last acknowledged line does).
STALE_REPORT_S = 1.0


@dataclass(frozen=True)
class ControllerInfo:
    """What the handshake learned.

    Attributes
    ----------
    version : str
        From the banner (``1.1h``).
    rx_buffer_bytes : int
        Receive buffer used for character counting (from ``$I`` when it says).
    planner_blocks : int or None
        Planner size from ``$I``.
    work_offsets : dict of int to tuple of float
        G54-G59 (1-6) offsets from ``$#``, mm (empty when not reported).
    state : str
        State after the reset.
    """

    version: str
    rx_buffer_bytes: int
    planner_blocks: int | None
    work_offsets: dict[int, tuple[float, ...]] = field(default_factory=dict)
    state: str = "Idle"


@dataclass(frozen=True)
class JobResult:
    """A job that ran to its end.

    Attributes
    ----------
    lines_sent : int
        Lines written (program and preamble).
    blocks_done : int
        Program lines acknowledged.
    elapsed_s : float
        Duration, s.
    bytes_sent : int
        Line bytes written.
    final_status : StatusReport or None
        The Idle report that ended the job.
    start_line : int
        First program line of this run.
    streaming_s : float
        From the first line written to the last answer received, s (what the link
        throughput is measured over; ``elapsed_s`` adds the wait for Idle).
    last_line : int
        Source line of the last block answered (where the program stopped).
    status_queries, status_missed : int
        ``?`` sent during the run, and of those left unanswered (grbl does not promise a
        report; the job never depends on them).
    """

    lines_sent: int
    blocks_done: int
    elapsed_s: float
    bytes_sent: int
    final_status: StatusReport | None
    start_line: int
    streaming_s: float = 0.0
    last_line: int = 0
    status_queries: int = 0
    status_missed: int = 0


@dataclass(frozen=True)
class CheckReport:
    """Outcome of a ``$C`` dry run.

    Attributes
    ----------
    lines : int
        Lines checked.
    errors : tuple of LineRejectedError
        Every line the controller rejected, in order.
    """

    lines: int
    errors: tuple[LineRejectedError, ...]

    @property
    def ok(self) -> bool:
        """No line was rejected."""
        return not self.errors


class GrblSender(GrblRecovery):
    """Stream G-code to a GRBL 1.1 controller over a link.

    Parameters
    ----------
    link : Link
        An open link (:func:`~gcode.senders.serial_link.open_serial_link`).
    mode : StreamMode or str
        ``char-count`` (default) or ``send-response``.
    rx_buffer_bytes : int
        Receive buffer for character counting; the handshake lowers it to what ``$I``
        reports.
    status_interval_s : float
        Status query period, s (0.2 = 5 Hz).
    timeouts : Timeouts or None
        Bounds on every wait.
    dialect : Dialect
        Dialect used to parse the program for resume planning.
    clock : callable
        Monotonic time in seconds (injectable).
    on_progress : callable or None
        ``on_progress(Progress)``, at most every 0.1 s and at the end.
    on_message : callable or None
        ``on_message(str)`` for controller messages worth showing (``[MSG:...]``).
    """

    def __init__(
        self,
        link: Link,
        *,
        mode: StreamMode | str = StreamMode.CHAR_COUNT,
        rx_buffer_bytes: int = RX_BUFFER_BYTES,
        status_interval_s: float = STATUS_INTERVAL_S,
        timeouts: Timeouts | None = None,
        dialect: Dialect = GENERIC,
        clock: Callable[[], float] = time.monotonic,
        on_progress: Callable[[Progress], None] | None = None,
        on_message: Callable[[str], None] | None = None,
    ) -> None:
        self.link = link
        self.mode = StreamMode(mode)
        self.timeouts = timeouts if timeouts is not None else Timeouts()
        self.dialect = dialect
        self.clock = clock
        self.on_progress = on_progress
        self.on_message = on_message
        self.stream = GrblStream(
            mode=self.mode,
            rx_buffer_bytes=rx_buffer_bytes,
            status_interval_s=status_interval_s,
            timeouts=self.timeouts,
        )
        self.info: ControllerInfo | None = None
        self.status: StatusReport | None = None
        self._status_at = -1.0
        self._banner_at = -1.0
        self._banner_version = ""
        self._feedback: list[Feedback] = []
        self._hold_request = threading.Event()
        self._journal: JobJournal | None = None
        self._collect: list[tuple[JobLine, int]] | None = None
        self._stale_answers_ok = False
        self._stale_answers = 0
        self._job: Job | None = None
        self._done = 0
        self._total = 0
        self._last_line = 0
        self._last_acked: JobLine | None = None
        self._last_sent: JobLine | None = None
        self._sent_lines = 0
        self._first_sent_s = 0.0
        self._last_ack_s = 0.0
        self._t0 = 0.0
        self._last_progress = -1.0
        self._wco: tuple[float, ...] | None = None
        self._on_hold: Callable[[Progress], HoldChoice | str] | None = None
        self._finish_asked = -1.0
        self._hold_unconfirmed = False
        self._start_line = 0
        self._planned: tuple[Job, np.ndarray, np.ndarray] | None = None

    # ------------------------------------------------------------------ pumping
    def request_hold(self) -> None:
        """Ask for a feed hold (safe from a signal handler or another thread)."""
        self._hold_request.set()

    def _pump(
        self, until: Callable[[], bool], *, limit_s: float | None = None, what: str = ""
    ) -> None:
        stream = self.stream
        link = self.link
        clock = self.clock
        start = clock()
        while True:
            now = clock()
            if self._hold_request.is_set() and self._on_hold is not None:
                self._hold_request.clear()
                self._interactive_hold()
                now = clock()
            out = stream.outgoing(now)
            if out:
                link.write(out)
            stream.check(now)
            for ev in stream.pop_events():
                self._handle(ev, now)
            if until():
                return
            if limit_s is not None and now - start > limit_s:
                raise LinkTimeoutError(f"{what}: not done after {limit_s:g} s")
            wait = stream.deadline(now) - now
            if limit_s is not None:
                wait = min(wait, start + limit_s - now)
            data = link.read(max(wait, 0.0))
            if data:
                stream.receive(data, clock())

    def _handle(self, ev: Event, now: float) -> None:
        t = type(ev)
        j = self._journal
        if t is LineSent:
            if self._sent_lines == 0:
                self._first_sent_s = now
            self._sent_lines += 1
            self._last_sent = ev.line  # type: ignore[union-attr]
            if j is not None:
                j.sent(ev.line)  # type: ignore[union-attr]
            return
        if t is LineAcked:
            line = ev.line  # type: ignore[union-attr]
            self._last_acked = line
            self._last_ack_s = now
            if j is not None:
                j.acked(line)
            if line.number > 0:
                self._done += 1
                self._last_line = line.number
                self._progress(now)
            return
        if t is StatusUpdate:
            report = ev.report  # type: ignore[union-attr]
            self.status = report
            self._status_at = now
            if report.work_offset is not None:
                self._wco = report.work_offset
            return
        if t is LineRejected:
            if j is not None:
                j.rejected(ev.line, ev.code)  # type: ignore[union-attr]
            if self._collect is not None:
                self._collect.append((ev.line, ev.code))  # type: ignore[union-attr]
                return
            raise StreamStop(ev)
        if t is ControllerReset:
            if ev.expected:  # type: ignore[union-attr]
                self._banner_at = now
                self._banner_version = ev.version  # type: ignore[union-attr]
                return
            raise StreamStop(ev)
        if t is Pushed:
            msg = ev.message  # type: ignore[union-attr]
            if isinstance(msg, Feedback):
                self._feedback.append(msg)
                if msg.kind == "MSG":
                    if j is not None:
                        j.message(f"[MSG:{msg.text}]")
                    if self.on_message is not None:
                        self.on_message(f"[MSG:{msg.text}]")
            return
        if t is Unexpected and self._stale_answers_ok:
            # answers to lines sent before a reset (an earlier session's, or ours in transit
            # when the controller restarted): nothing of ours is outstanding for them
            self._stale_answers += 1
            return
        if t is AlarmRaised and j is not None:
            j.alarm(ev.code, ev.suspect)  # type: ignore[union-attr]
        raise StreamStop(ev)

    def _progress(self, now: float, *, force: bool = False) -> None:
        if self.on_progress is None:
            return
        if not force and now - self._last_progress < PROGRESS_INTERVAL_S:
            return
        self._last_progress = now
        self.on_progress(self.progress(now))

    def progress(self, now: float | None = None) -> Progress:
        """The current job's progress (from acknowledgements; reports only add to it)."""
        t = self.clock() if now is None else now
        state = self.status.state if self.status is not None else ""
        position, source = self._position_for_progress(t)
        return Progress(
            self._done, self._total, max(t - self._t0, 0.0), self._last_line, state,
            position, source,
        )  # fmt: skip

    def _position_for_progress(self, now: float) -> tuple[tuple[float, ...] | None, str]:
        s = self.status
        if s is not None and now - self._status_at <= STALE_REPORT_S:
            if s.work_position is not None:
                return s.work_position, "report"
            offsets = self.info.work_offsets if self.info is not None else {}
            wco = self._wco or offsets.get(1)
            if s.machine_position is not None and wco is not None:
                pos = tuple(m - o for m, o in zip(s.machine_position, wco, strict=False))
                return pos, "report"
        if not self._last_line or self._job is None:
            return None, ""
        if self._planned is None or self._planned[0] is not self._job:
            self._planned = (self._job, *planned_line_ends(self._job, self.dialect))
        _, lines, ends = self._planned
        i = int(np.searchsorted(lines, self._last_line, side="right")) - 1
        if i < 0:
            return None, ""
        return tuple(float(v) for v in ends[i, :3]), "planned"

    def _fresh_status(self, *, limit_s: float | None = None) -> StatusReport:
        """Ask for a status report and wait for it (bounded)."""
        asked = self.clock()
        self.stream.polling = True
        self.stream.query_status(asked)
        self._pump(
            lambda: self._status_at >= asked,
            limit_s=limit_s or self.timeouts.status_wait_s,
            what="status report",
        )
        assert self.status is not None
        return self.status

    def _reset(self) -> None:
        """Soft reset and wait for the banner (bounded)."""
        asked = self.clock()
        self.stream.soft_reset(asked)
        self._pump(
            lambda: self._banner_at >= asked, limit_s=self.timeouts.reset_s + 0.5, what="soft reset"
        )

    def _wait_stopped(self, limit_s: float) -> None:
        """Wait until a report says the axes stand still (Hold:0, Idle, Alarm, Check)."""

        def stopped() -> bool:
            s = self.status
            return s is not None and self._status_at >= asked and not s.moving

        asked = self.clock()
        self.stream.polling = True
        self.stream.query_status(asked)
        self._pump(stopped, limit_s=limit_s, what="waiting for the machine to stop")

    # ------------------------------------------------------------------ handshake
    def connect(
        self,
        *,
        unlock: bool = False,
        boot_wait_s: float = BOOT_WAIT_S,
        busy_wait_s: float = BUSY_WAIT_S,
    ) -> ControllerInfo:
        """Start-up handshake (see the module docstring).

        Parameters
        ----------
        unlock : bool
            Send ``$X`` when the controller comes up in Alarm (otherwise refuse).
        boot_wait_s : float
            Longest wait for a status report or a boot banner, s.
        busy_wait_s : float
            Longest wait for a machine found moving to stop, s.

        Returns
        -------
        ControllerInfo
            Version, buffer sizes, work offsets, state.

        Raises
        ------
        HandshakeError
            No answer, no banner after the reset, or an Alarm without ``unlock``.
        LinkLostError
            The link failed.
        """
        name = getattr(self.link, "name", "the link")
        t0 = self.clock()
        self._stale_answers_ok = True
        try:
            try:
                self.stream.query_status(t0)
                self._pump(
                    lambda: self._status_at >= t0 or self._banner_at >= t0,
                    limit_s=boot_wait_s,
                    what="handshake",
                )
            except LinkTimeoutError:
                raise HandshakeError(
                    f"{name}: no status report and no banner within {boot_wait_s:g} s: is a "
                    f"GRBL 1.1 controller there, at the right baud rate?"
                ) from None
            except StreamStop as stop:
                if not isinstance(stop.event, ControllerReset):
                    raise HandshakeError(f"{name}: unexpected {stop.event!r} at start-up") from None
                self._banner_at = self.clock()  # the board rebooted when the port opened
            s = self.status if self._status_at >= t0 else self._fresh_status(limit_s=boot_wait_s)
            if s.moving:
                self._wait_stopped(busy_wait_s)
            try:
                self._reset()
            except LinkTimeoutError:
                raise HandshakeError(
                    f"{name}: no GRBL banner within {self.timeouts.reset_s:g} s after a soft reset"
                ) from None
            except StreamStop as stop:
                raise HandshakeError(f"{name}: unexpected {stop.event!r} after reset") from None
            self._stale_answers_ok = False
            s = self._fresh_status()
        except StreamStop as stop:
            raise HandshakeError(
                f"{name}: unexpected {stop.event!r} during the handshake"
            ) from None
        finally:
            self._stale_answers_ok = False
        if s.state == "Alarm":
            if not unlock:
                raise HandshakeError(
                    f"{name}: the controller is in Alarm after reset (locked): home it ($H) "
                    "or unlock it ($X, --unlock) before sending"
                )
            self._command("$X")
            s = self._fresh_status()
        self._feedback.clear()
        rejected = self._command("$I", tolerate=True)
        planner = None
        rx = self.stream.rx_buffer_bytes
        for fb in self._feedback:
            if fb.kind == "OPT" and not rejected:
                parts = fb.text.split(",")
                try:
                    planner = int(parts[1])
                    rx = min(rx, int(parts[2]))
                except (IndexError, ValueError):
                    pass
        self.stream.rx_buffer_bytes = rx
        self.stream.planner_blocks = planner
        self._feedback.clear()
        offsets: dict[int, tuple[float, ...]] = {}
        if not self._command("$#", tolerate=True):
            for fb in self._feedback:
                if fb.kind in ("G54", "G55", "G56", "G57", "G58", "G59"):
                    try:
                        offsets[int(fb.kind[1:]) - 53] = tuple(float(v) for v in fb.text.split(","))
                    except ValueError:
                        pass
        self._feedback.clear()
        self.info = ControllerInfo(self._banner_version, rx, planner, offsets, s.state)
        return self.info

    def _command(self, text: str, *, tolerate: bool = False) -> int:
        """Send one sync line and wait for its answer; returns its error code (0 = ok)."""
        collected: list[tuple[JobLine, int]] = []
        self._collect = collected
        try:
            self.stream.add_lines([JobLine(0, text, sync=True)])
            self.stream.resume_sending()
            self._pump(
                lambda: self.stream.finished,
                limit_s=self.timeouts.reset_s,
                what=f"answer to {text!r}",
            )
        except StreamStop as stop:
            raise HandshakeError(f"unexpected {stop.event!r} after {text!r}") from None
        finally:
            self._collect = None
        if collected and not tolerate:
            code = collected[0][1]
            raise HandshakeError(
                f"the controller rejected {text!r}: error:{code} ({error_text(code)})"
            )
        return collected[0][1] if collected else 0

    # ------------------------------------------------------------------ check mode
    def check(self, job: Job) -> CheckReport:
        """``$C`` dry run of ``job``: the controller parses every line, nothing moves.

        Returns
        -------
        CheckReport
            Every rejected line (``error:N``) with its source line.

        Raises
        ------
        AlarmError
            The controller raised an alarm while checking (soft limits are checked too);
            the controller is reset before raising.
        LineTooLongError
            A line can never fit the receive buffer (nothing is sent).
        LinkLostError, LinkTimeoutError
            The link failed or an answer never came.
        """
        self._check_fits(tuple(job.lines))
        self._command("$C")
        collected: list[tuple[JobLine, int]] = []
        self._collect = collected
        try:
            self.stream.add_lines(job.lines)
            self.stream.resume_sending()
            self._pump(lambda: self.stream.finished, what="check mode")
            self.stream.add_lines([JobLine(0, "$C", sync=True)])
            self.stream.expect_banner(self.clock())
            asked = self.clock()
            self._pump(
                lambda: self.stream.finished and self._banner_at >= asked, what="leaving check mode"
            )
        except StreamStop as stop:
            ev = stop.event
            self.stream.drop_pending()
            if isinstance(ev, AlarmRaised):
                self._reset()
                raise AlarmError(
                    ev.code,
                    line=ev.suspect.number if ev.suspect else None,
                    text=ev.suspect.text if ev.suspect else None,
                    note="raised in check mode; the controller was reset",
                ) from None
            raise self._generic_failure(ev) from None
        finally:
            self._collect = None
        errors = tuple(
            LineRejectedError(code, line=ln.number, text=ln.text) for ln, code in collected
        )
        return CheckReport(len(job.lines), errors)

    # ------------------------------------------------------------------ the job
    def run(
        self,
        job: Job,
        *,
        resume: ResumePlan | None = None,
        journal: JobJournal | None = None,
        on_hold: Callable[[Progress], HoldChoice | str] | None = None,
    ) -> JobResult:
        """Stream ``job`` (or resume it) to the end: every line answered, machine Idle.

        Parameters
        ----------
        job : Job
            The program (pre-flighted).
        resume : ResumePlan or None
            Send its preamble, then the program from ``resume.line``.
        journal : JobJournal or None
            Records every line sent and answered, and how the run ended.
        on_hold : callable or None
            ``on_hold(progress) -> "resume" | "cancel"`` after a requested feed hold has
            stopped the machine; None cancels.

        Returns
        -------
        JobResult
            Counts and the final status.

        Raises
        ------
        SenderError
            :class:`LineRejectedError`, :class:`AlarmError`, :class:`ControllerResetError`,
            :class:`LinkLostError`, :class:`LinkTimeoutError`, :class:`ProtocolError` or
            :class:`JobCancelledError`, each with the line and ``resume_line``.
        """
        lines: tuple[JobLine, ...] = tuple(job.lines)
        start = job.lines[0].number if job.lines else 0
        if resume is not None:
            lines = resume.preamble + tuple(job.from_line(resume.line))
            start = resume.line
        self._job = job
        self._journal = journal
        self._on_hold = on_hold if on_hold is not None else (lambda p: HoldChoice.CANCEL)
        self._done = 0
        self._total = sum(1 for ln in lines if ln.number > 0)
        self._last_line = 0
        self._last_acked = None
        self._hold_unconfirmed = False
        self._sent_lines = 0
        self._t0 = self.clock()
        self._start_line = start
        bytes0 = self.stream.bytes_sent
        stream = self.stream
        queries0, missed0 = stream.status_queries, stream.status_missed
        try:
            self._check_fits(lines)
        except LineTooLongError as err:
            self._end(err)
            raise
        stream.add_lines(lines)
        stream.resume_sending()
        stream.polling = True
        try:
            try:
                self._pump(self._job_done, what="job")
            except KeyboardInterrupt:
                self._cancel("interrupted (Ctrl-C)")
        except StreamStop as stop:
            err = self._failure(stop.event)
            self._end(err)
            raise err from None
        except SenderError as err:
            if isinstance(err, LinkLostError) and err.resume_line is None:
                err = self._link_lost(err)
            self._end(err)
            raise err from None
        finally:
            self._on_hold = None
        self._progress(self.clock(), force=True)
        if journal is not None:
            journal.end("done", resume_line=None)
        return JobResult(
            self._sent_lines,
            self._done,
            self.clock() - self._t0,
            stream.bytes_sent - bytes0,
            stream.end_status or self.status,
            start,
            max(self._last_ack_s - self._first_sent_s, 0.0),
            self._last_line,
            stream.status_queries - queries0,
            stream.status_missed - missed0,
        )

    def _check_fits(self, lines: tuple[JobLine, ...]) -> None:
        """Refuse, before sending anything, a line the receive buffer can never hold.

        A character-counting sender can never send a line longer than the controller's
        receive buffer (it would wait forever), and grbl drops the bytes of one that
        overflows it in send-response too.

        Raises
        ------
        LineTooLongError
            Naming the first such line and its size.
        """
        rx = self.stream.rx_buffer_bytes
        for ln in lines:
            if ln.size > rx:
                raise LineTooLongError(
                    f"line {ln.number or '(preamble)'} needs {ln.size} bytes with its "
                    f"newline after removing spaces and comments, more than the "
                    f"controller's {rx}-byte receive buffer: it can never be sent "
                    f"({ln.text[:40]!r}...); nothing was sent",
                    line=ln.number or None,
                )

    def _end(self, err: SenderError) -> None:
        if self._journal is not None:
            self._journal.end(err.outcome, resume_line=err.resume_line, message=str(err))

    def _job_done(self) -> bool:
        """Every line answered and a later report shows Idle/Check, planner empty.

        No M2/M30 needed; the stream polls (at most 5 Hz) and reports the controller's
        silence (``stall_s``) while it waits.
        """
        stream = self.stream
        if not stream.finished:
            return False
        if self._finish_asked < self._t0:
            self._finish_asked = self.clock()
            stream.expect_end(self._finish_asked)
            return False
        return stream.end_status is not None

    def close(self) -> None:
        """Close the link."""
        self.link.close()
