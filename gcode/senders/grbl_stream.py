r"""The GRBL 1.1 streaming protocol as a sans-IO state machine: bytes in, bytes out.

:class:`GrblStream` owns everything a sender must get right about the link and nothing
about the I/O: the caller writes what :meth:`GrblStream.outgoing` returns, hands every
received chunk to :meth:`GrblStream.receive`, calls :meth:`GrblStream.check` when
:meth:`GrblStream.deadline` comes, and acts on the :mod:`events <gcode.senders.grbl_stream>`
it pops. Time is a number the caller passes in (seconds, any monotonic origin), so tests
drive it without sleeping.

Streaming
    Character counting (default): a line is sent when the bytes of every unanswered line
    plus its own fit in the controller's 128-byte receive buffer; each ``ok`` or
    ``error:N`` answers the oldest unanswered line (FIFO) and frees its bytes.
    Send-response: one line at a time. Lines marked ``sync`` (EEPROM writes, ``$``
    commands) always go alone, as grbl requires.
Real-time bytes
    ``?`` ``!`` ``~`` and 0x18 go out ahead of any line and are never counted.
Status
    One ``?`` at most every ``status_interval_s`` (0.2 s = 5 Hz, grbl's advice), and never
    a second one while a report is outstanding (grbl ignores it). A report is not
    guaranteed (grbl's interface document: two ``?`` before a report get one, none comes
    during homing or after a critical alarm, and some builds skip ``?`` while the planner
    is full): a query unanswered after ``status_reply_s`` is counted
    (:attr:`GrblStream.status_missed`) and the next one goes out; progress never depends
    on reports, only on answers.
Pushes
    ``ALARM:N``: the controller dropped every unanswered line (none will be answered);
    sending stops, polling stops (a critical alarm silences status reports) and
    :class:`AlarmRaised` names the oldest unanswered line, the one that caused a
    soft-limit alarm. The banner: the controller was reset and lost every unanswered line
    (:class:`ControllerReset`, ``expected`` when we asked for it).

The end of a job
    :meth:`GrblStream.expect_end` once every line is answered: the stream polls (still at
    most every ``status_interval_s``) until a report received after the last answer shows
    ``Idle`` or ``Check`` with an empty planner (``Bf:`` when reported); then
    :attr:`GrblStream.end_status` holds it. No M2/M30 is needed.

Every wait is bounded (:class:`Timeouts`): a line still unanswered while the controller
reports Idle (it has nothing of ours left: the bytes were lost) for ``lost_line_s`` plus
the line's dwell is reported lost; with work outstanding (unanswered lines, or the end
awaited), nothing at all from the controller (no answer, report or message) for
``stall_s`` is ``silent``, and reports that show no motion and no answer for ``stall_s``
a ``stall``; a feed hold must complete within ``hold_s`` and a reset must bring the
banner within ``reset_s``. Each becomes a :class:`TimedOut` event: nothing waits
forever. A missing status report is not one of them (see Status).

Examples
--------
>>> from gcode.senders.job import Job
>>> s = GrblStream(Job.from_text("G1X1F100\nG1X2\n").lines)
>>> s.outgoing(now_s=0.0)
b'?G1X1F100\nG1X2\n'
>>> s.receive(b"<Run|MPos:0.5,0,0|FS:100,0>\r\nok\r\nok\r\n", now_s=0.01)
>>> [type(e).__name__ for e in s.pop_events()]
['LineSent', 'LineSent', 'StatusUpdate', 'LineAcked', 'LineAcked']
>>> s.finished
True
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass

from gcode.senders.grbl_events import (
    AlarmRaised,
    ControllerReset,
    Event,
    LineAcked,
    LineRejected,
    LineSent,
    Pushed,
    StatusUpdate,
    TimedOut,
    Unexpected,
)
from gcode.senders.grbl_messages import (
    AlarmPush,
    ErrorResponse,
    Feedback,
    Message,
    Ok,
    StatusReport,
    Welcome,
    parse_message,
)
from gcode.senders.job import JobLine
from gcode.senders.stream_options import StreamMode

__all__ = [
    "RX_BUFFER_BYTES",
    "STATUS_INTERVAL_S",
    "AlarmRaised",
    "ControllerReset",
    "Event",
    "GrblStream",
    "LineAcked",
    "LineRejected",
    "LineSent",
    "Pushed",
    "StatusUpdate",
    "StreamMode",
    "TimedOut",
    "Timeouts",
    "Unexpected",
]

#: grbl 1.1's usable receive buffer, bytes (``RX_BUFFER_SIZE``; ``$I`` shows it).
RX_BUFFER_BYTES = 128
#: Status query period, s (5 Hz: grbl's recommended maximum).
STATUS_INTERVAL_S = 0.2

RT_STATUS, RT_HOLD, RT_RESUME, RT_RESET = b"?", b"!", b"~", b"\x18"


@dataclass(frozen=True, slots=True)
class Timeouts:
    """Bounds on every wait, s (see the module docstring).

    ``status_reply_s`` is how long one ``?`` may stay unanswered before it counts as
    missing and the next query goes out (grbl answers within 5-20 ms; a report is not
    guaranteed); ``status_wait_s`` bounds a wait for a report the sender needs (after a
    hold or a reset, at the end of a job), over as many queries as fit in it.
    """

    status_reply_s: float = 0.5
    status_wait_s: float = 5.0
    lost_line_s: float = 1.0
    stall_s: float = 60.0
    hold_s: float = 30.0
    reset_s: float = 5.0


class GrblStream:
    """Sans-IO streaming state for one GRBL 1.1 link.

    Parameters
    ----------
    lines : iterable of JobLine
        Lines to send first (more can be queued with :meth:`add_lines`).
    mode : StreamMode
        Character counting or send-response.
    rx_buffer_bytes : int
        The controller's receive buffer, bytes (128 for grbl 1.1).
    status_interval_s : float
        Status query period, s; 0 disables polling.
    timeouts : Timeouts
        Bounds on every wait.

    Attributes
    ----------
    last_status : StatusReport or None
        The latest report.
    bytes_sent : int
        Line bytes written (real-time bytes excluded).
    sending : bool
        Lines are sent (False after an error, alarm, hold or reset request until
        :meth:`resume_sending`).
    polling : bool
        Status queries are sent.
    status_queries, status_missed : int
        ``?`` sent, and of those left unanswered for ``status_reply_s``.
    planner_blocks : int or None
        The controller's planner size (``$I``), to tell an empty planner from ``Bf:``.
    end_status : StatusReport or None
        The report that ended the job (after :meth:`expect_end`).
    """

    def __init__(
        self,
        lines: Iterable[JobLine] = (),
        *,
        mode: StreamMode = StreamMode.CHAR_COUNT,
        rx_buffer_bytes: int = RX_BUFFER_BYTES,
        status_interval_s: float = STATUS_INTERVAL_S,
        timeouts: Timeouts | None = None,
    ) -> None:
        if rx_buffer_bytes < 2:
            raise ValueError(f"rx_buffer_bytes must be >= 2, got {rx_buffer_bytes!r}")
        if status_interval_s < 0.0:
            raise ValueError(f"status_interval_s must be >= 0 s, got {status_interval_s!r}")
        self.mode = StreamMode(mode)
        self.rx_buffer_bytes = rx_buffer_bytes
        self.status_interval_s = status_interval_s
        self.timeouts = timeouts if timeouts is not None else Timeouts()
        self._pending: deque[JobLine] = deque(lines)
        self._inflight: deque[tuple[JobLine, float]] = deque()
        self._inflight_bytes = 0
        self._rt = bytearray()
        self._rx = bytearray()
        self._events: list[Event] = []
        self.sending = True
        self.polling = status_interval_s > 0.0
        self.last_status: StatusReport | None = None
        self.bytes_sent = 0
        self._status_sent_at: float | None = None
        self._next_status_at = -math.inf
        self._progress_at: float | None = None
        self._idle_since: float | None = None
        self._hold_asked_at: float | None = None
        self._reset_asked_at: float | None = None
        self._banner_expected_at: float | None = None
        self._last_sent_at = -math.inf
        self.status_queries = 0
        self.status_missed = 0
        self.planner_blocks: int | None = None
        self.end_status: StatusReport | None = None
        self._end_asked_at: float | None = None
        self._heard_at: float | None = None
        self._last_query_at = -math.inf

    # ------------------------------------------------------------------ queries
    @property
    def inflight(self) -> tuple[JobLine, ...]:
        """Lines sent and not yet answered, oldest first."""
        return tuple(ln for ln, _ in self._inflight)

    @property
    def inflight_bytes(self) -> int:
        """Receive-buffer bytes the unanswered lines occupy."""
        return self._inflight_bytes

    @property
    def pending(self) -> tuple[JobLine, ...]:
        """Lines not sent yet."""
        return tuple(self._pending)

    @property
    def finished(self) -> bool:
        """Every queued line was sent and answered."""
        return not self._pending and not self._inflight

    @property
    def ended(self) -> bool:
        """Every line answered and a later report showed the controller done."""
        return self.finished and self.end_status is not None

    @property
    def awaiting_reset(self) -> bool:
        """A reset was asked for and its banner has not come yet."""
        return self._reset_asked_at is not None

    # ------------------------------------------------------------------ commands
    def add_lines(self, lines: Iterable[JobLine]) -> None:
        """Queue more lines after the pending ones."""
        self._pending.extend(lines)

    def drop_pending(self) -> tuple[JobLine, ...]:
        """Forget the lines not sent yet and return them."""
        out = tuple(self._pending)
        self._pending.clear()
        return out

    def stop_sending(self) -> None:
        """Send no further line (real-time bytes still go)."""
        self.sending = False

    def resume_sending(self) -> None:
        """Send lines again."""
        self.sending = True

    def feed_hold(self, now_s: float) -> None:
        """Queue ``!`` and stop sending lines.

        A :class:`TimedOut` ``hold`` follows if no ``Hold:0`` comes within ``hold_s``.
        """
        self._rt += RT_HOLD
        self.sending = False
        self._hold_asked_at = now_s
        self._next_status_at = now_s  # ask at once how the hold is going

    def cycle_start(self) -> None:
        """Queue ``~`` (resume after a completed hold) and send lines again."""
        self._rt += RT_RESUME
        self._hold_asked_at = None
        self.sending = True

    def soft_reset(self, now_s: float) -> None:
        """Queue 0x18; the banner is then expected within ``reset_s``."""
        self._rt += RT_RESET
        self.sending = False
        self._reset_asked_at = now_s
        self._hold_asked_at = None
        self._status_sent_at = None

    def expect_banner(self, now_s: float) -> None:
        """A queued line resets the controller (``$C`` off): its banner is expected.

        Unlike :meth:`soft_reset` this does not stop sending; the banner must come within
        ``reset_s``.
        """
        self._banner_expected_at = now_s

    @property
    def last_progress_s(self) -> float | None:
        """Time of the last answer, line sent after a quiet spell, or change in status."""
        return self._progress_at

    def rebase(self, now_s: float) -> None:
        """Restart the clocks after the caller stopped pumping (a user prompt in a hold).

        An outstanding status query is forgotten (its answer, if it comes, is still used)
        and the stall clock starts again; a new query goes out at once.
        """
        self._status_sent_at = None
        self._idle_since = None
        if self._progress_at is not None:
            self._progress_at = now_s
        if self._heard_at is not None:
            self._heard_at = now_s
        self._next_status_at = now_s

    def query_status(self, now_s: float) -> None:
        """Ask for a status report at the next :meth:`outgoing` (if none is outstanding)."""
        self._next_status_at = now_s

    def expect_end(self, now_s: float) -> None:
        """Wait for the end of the job: every line answered and a report that shows it.

        The end is a report received after the last answer with state ``Idle`` or
        ``Check`` and, when it carries ``Bf:`` and :attr:`planner_blocks` is known, an
        empty planner (:attr:`end_status`). Polling goes on at most every
        ``status_interval_s``; while it is awaited, the controller's silence for
        ``stall_s`` is reported (:class:`TimedOut` ``silent``).
        """
        self.end_status = None
        self._end_asked_at = now_s
        self.polling = True  # a report is what ends the job
        self._next_status_at = min(self._next_status_at, now_s)

    # ------------------------------------------------------------------ I/O
    def outgoing(self, now_s: float) -> bytes:
        """Bytes to write now: real-time bytes first, then every line that fits.

        Parameters
        ----------
        now_s : float
            Current time, s.

        Returns
        -------
        bytes
            Possibly empty.
        """
        out = bytearray(self._rt)
        self._rt.clear()
        if (
            self.polling
            and self._status_sent_at is None
            and self._reset_asked_at is None
            and now_s >= self._next_query_s()
        ):
            out += RT_STATUS
            self.status_queries += 1
            self._status_sent_at = now_s
            self._last_query_at = now_s
            self._next_status_at = now_s + self.status_interval_s
        if self.sending and self._pending and self._reset_asked_at is None:
            self._fill(out, now_s)
        return bytes(out)

    def _next_query_s(self) -> float:
        """When the next ``?`` may go: as scheduled or asked, never within 0.2 s (5 Hz)."""
        return max(self._next_status_at, self._last_query_at + STATUS_INTERVAL_S)

    def _fill(self, out: bytearray, now_s: float) -> None:
        pending = self._pending
        inflight = self._inflight
        budget = self.rx_buffer_bytes
        one_at_a_time = self.mode is StreamMode.SEND_RESPONSE
        events = self._events
        while pending:
            line = pending[0]
            size = line.size
            if inflight:
                if one_at_a_time or line.sync or inflight[-1][0].sync:
                    break
                if self._inflight_bytes + size > budget:
                    break
            elif size > budget:
                raise ValueError(
                    f"line {line.number} needs {size} bytes, more than the controller's "
                    f"{budget}-byte receive buffer: {line.text!r}"
                )
            pending.popleft()
            inflight.append((line, now_s))
            self._inflight_bytes += size
            self.bytes_sent += size
            out += line.data
            events.append(LineSent(line))
            self._last_sent_at = now_s
            if len(inflight) == 1:  # the controller had nothing of ours: start the clock
                self._progress_at = now_s
                if self._heard_at is None or self._heard_at < now_s:
                    self._heard_at = now_s

    def receive(self, data: bytes, now_s: float) -> None:
        """Take bytes from the controller (any chunking) and turn them into events.

        Parameters
        ----------
        data : bytes
            Received bytes.
        now_s : float
            Current time, s.
        """
        rx = self._rx
        rx += data
        while True:
            i = rx.find(b"\n")
            if i < 0:
                break
            raw = bytes(rx[:i]).rstrip(b"\r")
            del rx[: i + 1]
            if raw:
                self._heard_at = now_s
                self._message(parse_message(raw.decode("ascii", "replace")), now_s)

    def _answer(self) -> JobLine | None:
        if not self._inflight:
            return None
        line, _ = self._inflight.popleft()
        self._inflight_bytes -= line.size
        return line

    def _lose_inflight(self) -> tuple[JobLine, ...]:
        lost = tuple(ln for ln, _ in self._inflight)
        self._inflight.clear()
        self._inflight_bytes = 0
        return lost

    def _message(self, msg: Message, now_s: float) -> None:
        events = self._events
        if type(msg) is Ok:
            line = self._answer()
            if line is None:
                events.append(Unexpected("ok"))
                self.sending = False
            else:
                events.append(LineAcked(line))
                self._progress_at = now_s
                self._idle_since = None
            return
        if type(msg) is StatusReport:
            self._status(msg, now_s)
            return
        if type(msg) is ErrorResponse:
            line = self._answer()
            if line is None:
                events.append(Unexpected(f"error:{msg.code}"))
                self.sending = False
            else:
                events.append(LineRejected(line, msg.code))
                self._progress_at = now_s
                self._idle_since = None
            return
        if type(msg) is AlarmPush:
            lost = self._lose_inflight()
            self.sending = False
            self.polling = False  # a critical alarm silences status reports
            self._status_sent_at = None
            self._hold_asked_at = None
            events.append(AlarmRaised(msg.code, lost[0] if lost else None, lost))
            return
        if type(msg) is Welcome:
            lost = self._lose_inflight()
            expected = self._reset_asked_at is not None or self._banner_expected_at is not None
            self._reset_asked_at = None
            self._banner_expected_at = None
            self._hold_asked_at = None
            self._status_sent_at = None
            self._idle_since = None
            self._next_status_at = now_s
            self.polling = self.status_interval_s > 0.0
            if not expected:
                self.sending = False
            events.append(ControllerReset(msg.version, lost, expected))
            return
        if type(msg) is Feedback and msg.kind == "MSG" and msg.text == "Reset to continue":
            self.polling = False
        events.append(Pushed(msg))

    def _status(self, report: StatusReport, now_s: float) -> None:
        prev = self.last_status
        self.last_status = report
        self._status_sent_at = None
        if prev is None or (
            report.state != prev.state
            or report.machine_position != prev.machine_position
            or report.work_position != prev.work_position
        ):
            self._progress_at = now_s
        if report.state == "Hold" and report.sub_state == 0:
            self._hold_asked_at = None
        # Idle with our lines unanswered: the controller has nothing of ours left.
        if (
            self._inflight
            and report.state == "Idle"
            and (report.rx_free is None or report.rx_free >= self.rx_buffer_bytes)
        ):
            if self._idle_since is None:
                self._idle_since = now_s
        else:
            self._idle_since = None
        if (
            self._end_asked_at is not None
            and not self._inflight
            and not self._pending
            and report.state in ("Idle", "Check")
            and (
                report.planner_free is None
                or self.planner_blocks is None
                or report.planner_free >= self.planner_blocks
            )
        ):
            self.end_status = report
            self._end_asked_at = None
        self._events.append(StatusUpdate(report))

    # ------------------------------------------------------------------ time
    def check(self, now_s: float) -> None:
        """Turn expired waits into :class:`TimedOut` events (each reported once)."""
        t = self.timeouts
        events = self._events
        if self._status_sent_at is not None and now_s - self._status_sent_at > t.status_reply_s:
            # not an error: grbl does not promise a report; count it and ask again
            self.status_missed += 1
            self._status_sent_at = None
        for name in ("_reset_asked_at", "_banner_expected_at"):
            asked = getattr(self, name)
            if asked is not None and now_s - asked > t.reset_s:
                events.append(TimedOut("reset", f"no banner {t.reset_s:g} s after the reset"))
                setattr(self, name, None)
        if self._hold_asked_at is not None and now_s - self._hold_asked_at > t.hold_s:
            events.append(TimedOut("hold", f"feed hold not complete after {t.hold_s:g} s"))
            self._hold_asked_at = None
        if not self._inflight and self._end_asked_at is not None and self.end_status is None:
            heard = max(self._heard_at or -math.inf, self._end_asked_at)
            moved = max(self._progress_at or -math.inf, self._end_asked_at)
            last = self.last_status
            holding = last is not None and last.state == "Hold"
            if now_s - heard > t.stall_s:
                events.append(TimedOut("silent", self._silence(t.stall_s, None)))
                self._end_asked_at = now_s
            elif not holding and now_s - moved > t.stall_s:
                state = last.state if last is not None else "?"
                events.append(
                    TimedOut(
                        "stall",
                        f"every line was answered but the controller reports {state} and "
                        f"has not moved for {t.stall_s:g} s: the job did not end",
                    )
                )
                self._end_asked_at = now_s
        if self._inflight:
            oldest, sent_at = self._inflight[0]
            if (
                self._idle_since is not None
                and now_s - max(self._idle_since, sent_at) > t.lost_line_s + oldest.dwell_s
            ):
                events.append(
                    TimedOut(
                        "lost-line",
                        f"line {oldest.number} ({oldest.text!r}) unanswered while the "
                        f"controller is idle with an empty buffer: its bytes were lost",
                    )
                )
                self._idle_since = None
                self.sending = False
            holding = self.last_status is not None and self.last_status.state == "Hold"
            if (
                not holding
                and self._progress_at is not None
                and now_s - self._progress_at > t.stall_s + oldest.dwell_s
            ):
                heard = self._heard_at
                if heard is None or now_s - heard > t.stall_s + oldest.dwell_s:
                    events.append(TimedOut("silent", self._silence(t.stall_s, oldest)))
                else:
                    events.append(
                        TimedOut(
                            "stall",
                            f"no answer to line {oldest.number} ({oldest.text!r}) and no "
                            f"motion for {t.stall_s:g} s (status reports show the machine "
                            "standing still)",
                        )
                    )
                self._progress_at = now_s
                self.sending = False

    def _silence(self, seconds: float, oldest: JobLine | None) -> str:
        what = (
            f"while line {oldest.number} ({oldest.text!r}) is unanswered"
            if oldest is not None
            else "while waiting for the end of the job (every line was answered)"
        )
        missed = (
            f"; {self.status_missed} of {self.status_queries} status queries went unanswered"
            if self.status_missed
            else ""
        )
        return (
            f"the controller is silent: no answer, report or message for {seconds:g} s "
            f"{what}{missed}"
        )

    def deadline(self, now_s: float) -> float:
        """The next time :meth:`outgoing` or :meth:`check` has something to do, s."""
        t = self.timeouts
        times = [now_s + 1.0]
        if self.polling and self._reset_asked_at is None:
            if self._status_sent_at is None:
                times.append(self._next_query_s())
            else:
                times.append(self._status_sent_at + t.status_reply_s)
        for asked in (self._reset_asked_at, self._banner_expected_at):
            if asked is not None:
                times.append(asked + t.reset_s)
        if self._hold_asked_at is not None:
            times.append(self._hold_asked_at + t.hold_s)
        if self._inflight and self._idle_since is not None:
            times.append(self._idle_since + t.lost_line_s + self._inflight[0][0].dwell_s)
        if self._inflight and self._progress_at is not None:
            times.append(self._progress_at + t.stall_s + self._inflight[0][0].dwell_s)
        if not self._inflight and self._end_asked_at is not None and self.end_status is None:
            times.append(max(self._heard_at or -math.inf, self._end_asked_at) + t.stall_s)
            times.append(max(self._progress_at or -math.inf, self._end_asked_at) + t.stall_s)
        if self._rt:
            times.append(now_s)
        return max(min(times), now_s)

    def pop_events(self) -> list[Event]:
        """Return and clear the events since the last call, in order."""
        out = self._events
        self._events = []
        return out
