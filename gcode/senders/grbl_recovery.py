r"""Recovery for the GRBL sender: safe stops, where to resume, feed hold and cancel.

The part of :class:`~gcode.senders.grbl_sender.GrblSender` that runs when a job does
not simply end: after ``error:N``, ``ALARM:N``, an unasked banner, a time-out or a
protocol break it brings the machine to a stop without losing its position (feed hold,
wait for ``Hold:0``, soft reset), reads where it stopped and names the first line not
known to have run (:func:`~gcode.senders.resume.locate_resume_line` over the lines that
may still have been queued); and it serves a requested feed hold (resume or cancel) and
the user's resume requests (a line, or the journal of an interrupted run). A mixin: the
state and the bounded waits (``_pump``, ``_reset``, ``_wait_stopped``, ``_fresh_status``)
are the sender's.
"""

from __future__ import annotations

from enum import StrEnum

from gcode.senders.errors import (
    AlarmError,
    ControllerResetError,
    JobCancelledError,
    LineRejectedError,
    LinkLostError,
    LinkTimeoutError,
    ProtocolError,
    ResumeError,
    SenderError,
)
from gcode.senders.grbl_messages import StatusReport
from gcode.senders.grbl_stream import (
    AlarmRaised,
    ControllerReset,
    Event,
    LineRejected,
    StreamMode,
    TimedOut,
    Unexpected,
)
from gcode.senders.job import Job
from gcode.senders.journal import JournalInfo
from gcode.senders.resume import (
    ResumePlan,
    locate_resume_line,
    modal_state_before,
    plan_resume,
    safe_resume_line,
)

__all__ = ["GrblRecovery", "HoldChoice", "StreamStop"]


class HoldChoice(StrEnum):
    """What to do after a feed hold."""

    RESUME = "resume"
    CANCEL = "cancel"


class StreamStop(Exception):
    """A fatal stream event, handled by the operation that was running.

    Raised by the sender's event handling (a rejected line, an unexpected reset) and
    caught by the recovery operations; ``event`` is the event that stopped the stream.
    """

    def __init__(self, event: Event) -> None:
        self.event = event
        super().__init__(repr(event))


class GrblRecovery:
    """Safe stops, resume location and hold handling (mixed into ``GrblSender``)."""

    # ------------------------------------------------------------------ resume
    def _work_position(
        self, status: StatusReport, job: Job, first_line: int
    ) -> tuple[float, ...] | None:
        if status.work_position is not None:
            return status.work_position
        if status.machine_position is None:
            return None
        wcs = modal_state_before(job, first_line, self.dialect).wcs
        offsets = self.info.work_offsets if self.info is not None else {}
        off = offsets.get(wcs) or self._wco
        if off is None:
            return None
        return tuple(m - o for m, o in zip(status.machine_position, off, strict=False))

    def locate(self, job: Job, first_line: int, last_line: int) -> int | None:
        """Where to resume, from the controller's position (read now, after a stop).

        Parameters
        ----------
        job : Job
            The program.
        first_line, last_line : int
            Source lines that may not have run.

        Returns
        -------
        int or None
            The first line not known to have run (arc lines stepped back to the nearest
            earlier non-arc line), ``job.last_line_number + 1`` when all ran, or None
            when the position is on none of their paths.
        """
        status = self._fresh_status()
        pos = self._work_position(status, job, first_line)
        if pos is None:
            return None
        line = locate_resume_line(
            job, pos, first_line=first_line, last_line=last_line, dialect=self.dialect
        )
        if line is None or line > job.last_line_number:
            return line
        return safe_resume_line(job, line, self.dialect)

    def plan_resume(
        self, job: Job, line: int, *, clearance_z_mm: float | None = None
    ) -> ResumePlan:
        """Plan a resume at ``line`` using the controller's current height (after connect).

        Raises
        ------
        ResumeError
            See :func:`~gcode.senders.resume.plan_resume`.
        """
        status = self._fresh_status()
        pos = self._work_position(status, job, line)
        z = pos[2] if pos is not None and len(pos) > 2 else None
        return plan_resume(
            job, line, dialect=self.dialect, clearance_z_mm=clearance_z_mm, current_z_mm=z
        )

    def resume_line_from_journal(self, job: Job, info: JournalInfo) -> int:
        """The line to resume at after the run ``info`` describes (the user asked for it).

        The lines the journal shows answered before the last
        ``2 * planner blocks`` may still have been in the controller's queue when it
        stopped; the controller's position decides among them and the unanswered ones.

        Raises
        ------
        ResumeError
            When the journal is for another program, says the job completed, or the
            position is on none of the candidate lines' paths.
        """
        if info.sha256 != job.sha256:
            raise ResumeError(
                f"the journal is for another program ({info.name}, different "
                f"text): refusing to resume {job.name} from it"
            )
        if info.outcome == "done":
            raise ResumeError("the journal says the job completed: nothing to resume")
        first = self._window_start(job, info.last_acked, info.start_line)
        last = info.last_sent or first
        line = self.locate(job, first, last)
        if line is None:
            raise ResumeError(
                f"the controller's position is on no path of lines {first}-{last} (the "
                f"candidates from the journal): give the line with --resume-from N"
            )
        if line > job.last_line_number:
            raise ResumeError("the controller's position shows every line ran: nothing to resume")
        return line

    def _window_start(self, job: Job, last_acked: int | None, start_line: int) -> int:
        margin = 2 * ((self.info.planner_blocks if self.info else None) or 15)
        if last_acked is None:
            return start_line
        i = max(job.index_of(last_acked) - margin, job.index_of(start_line), 0)
        return job.lines[i].number if i < len(job.lines) else start_line

    # ------------------------------------------------------------------ stops
    def _hold_stopped(self) -> bool:
        """Feed hold and wait for a report that the axes stopped (bounded by ``hold_s``).

        Returns False when no report at all came in that time (firmware that does not
        answer ``?`` while its planner is full, as it is in a hold): the hold could not
        be confirmed, and the caller goes on as if it were (a reset then keeps the
        position if the axes had stopped, and raises ALARM:3 if they had not). A report
        that shows the axes still moving after ``hold_s`` is a time-out.
        """
        asked = self.clock()
        self.stream.feed_hold(asked)
        try:
            self._wait_stopped(self.timeouts.hold_s + 0.5)
        except StreamStop as stop:
            ev = stop.event
            if not (isinstance(ev, TimedOut) and ev.what == "hold" and self._status_at < asked):
                raise
        except LinkTimeoutError:
            if self._status_at >= asked:
                raise
        else:
            return True
        self._hold_unconfirmed = True
        return False

    def _hold_note(self) -> str:
        if not self._hold_unconfirmed:
            return ""
        return (
            f"; the feed hold could not be confirmed (no status report within "
            f"{self.timeouts.hold_s:g} s): the controller was reset anyway"
        )

    def _interactive_hold(self) -> None:
        """Feed hold, wait for Hold:0, ask ``on_hold``, then resume or cancel."""
        stream = self.stream
        confirmed = self._hold_stopped()
        if self._journal is not None:
            self._journal.message(
                "feed hold (requested)" + ("" if confirmed else ", not confirmed by a report")
            )
            self._journal.flush()
        assert self._on_hold is not None
        choice = HoldChoice(self._on_hold(self.progress()))
        stream.rebase(self.clock())  # the time spent deciding is neither a stall nor silence
        if choice is HoldChoice.RESUME:
            if self._journal is not None:
                self._journal.message("resumed after hold")
            stream.cycle_start()
            return
        self._cancel("cancelled after a feed hold")

    def _cancel(self, why: str) -> None:
        """Hold, wait for the stop, reset (position kept), locate; raise JobCancelledError."""
        self._hold_and_reset()
        resume_line = self._suggest_after_reset()
        raise JobCancelledError(
            f"job {why}; last line answered: {self._last_line or 'none'}"
            + (f"; resume with --resume-from {resume_line}" if resume_line else "")
            + self._hold_note(),
            line=self._last_line or None,
            resume_line=resume_line,
        )

    def _suggest_after_reset(self) -> int | None:
        """Locate the stop over the lines that may not have run (after a reset)."""
        job = self._job
        if job is None or not job.lines:
            return None
        last_acked = (
            self._last_acked.number if self._last_acked and self._last_acked.number else None
        )
        first = self._window_start(job, last_acked, self._start_line)
        last = self._last_sent.number if self._last_sent and self._last_sent.number else first
        try:
            line = self.locate(job, first, max(first, last))
        except (SenderError, StreamStop):
            return None
        if line is not None and line > job.last_line_number:
            return None
        return line

    def _hold_and_reset(self) -> None:
        """Stop the machine without losing position: hold, wait, reset (bounded)."""
        stream = self.stream
        stream.stop_sending()
        stream.drop_pending()
        try:
            self._hold_stopped()
        except StreamStop as stop:  # an alarm while stopping: reset anyway
            if not isinstance(stop.event, AlarmRaised):
                raise
        finally:
            self._reset()

    def _failure(self, ev: Event) -> SenderError:
        """Bring the controller to a safe stop after a fatal event; return the error."""
        stream = self.stream
        stream.stop_sending()
        try:
            if isinstance(ev, LineRejected):
                return self._rejected(ev)
            if isinstance(ev, AlarmRaised):
                return self._alarm(ev)
            if isinstance(ev, ControllerReset):
                stream.drop_pending()
                stream.feed_hold(self.clock())
                # lines already on the wire reach the restarted controller: their answers
                # come with nothing outstanding; count them, stop the machine anyway
                self._stale_answers = 0
                self._stale_answers_ok = True
                try:
                    self._hold_and_reset()
                finally:
                    self._stale_answers_ok = False
                line = self._suggest_after_reset()
                last = self._last_line or "none"
                stale = (
                    f"; {self._stale_answers} line(s) already on the wire reached the restarted "
                    "controller before the hold"
                    if self._stale_answers
                    else ""
                )
                return ControllerResetError(
                    f"the controller restarted during the job (banner 'Grbl {ev.version}'): "
                    f"{len(ev.lost)} line(s) it had not answered were lost; last line answered: "
                    f"{last}; the job stopped (the machine was held and reset){stale}"
                    f"{self._hold_note()}",
                    line=self._last_line or None,
                    resume_line=line,
                )
            return self._generic_failure(ev, stop_machine=True)
        except StreamStop as again:
            return self._generic_failure(again.event)
        except SenderError as err:
            return err

    def _rejected(self, ev: LineRejected) -> SenderError:
        line = ev.line
        stream = self.stream
        later = stream.inflight
        stream.drop_pending()
        what = "resume preamble line" if line.number == 0 else None
        if later and self.mode is StreamMode.CHAR_COUNT:
            self._hold_and_reset()
            resume_line = self._suggest_after_reset() if line.number else None
            if resume_line is not None and line.number:
                resume_line = min(resume_line, line.number)
            note = (
                f"{len(later)} line(s) sent after it were stopped by a feed hold and "
                f"discarded by a reset"
            )
        else:
            self._wait_stopped(self.timeouts.stall_s)
            resume_line = line.number or None
            note = "the lines before it ran"
        if what:
            note = f"{what}; {note}"
        note += self._hold_note()
        return LineRejectedError(
            ev.code, line=line.number or None, text=line.text, resume_line=resume_line, note=note
        )

    def _alarm(self, ev: AlarmRaised) -> SenderError:
        stream = self.stream
        stream.drop_pending()
        suspect = ev.suspect
        try:
            self._reset()
            line = self._suggest_after_reset()
        except (SenderError, StreamStop):
            line = None
        note = "the controller was reset and is locked: home ($H) or unlock ($X) first"
        if ev.code in (1, 3):
            note += "; the position may be lost: re-home before resuming"
        return AlarmError(
            ev.code,
            line=suspect.number if suspect else None,
            text=suspect.text if suspect else None,
            resume_line=line,
            note=note,
        )

    def _generic_failure(self, ev: Event, *, stop_machine: bool = False) -> SenderError:
        if stop_machine:
            try:
                self.stream.drop_pending()
                self._hold_and_reset()
            except (SenderError, StreamStop):
                pass
        last = self._last_line or None
        if isinstance(ev, TimedOut):
            return LinkTimeoutError(f"{ev.detail}; last line answered: {last or 'none'}", line=last)
        if isinstance(ev, Unexpected):
            return ProtocolError(
                f"unexpected {ev.text!r} with no line outstanding: the "
                f"count is broken, the job stopped",
                line=last,
            )
        return SenderError(f"unexpected {ev!r}", line=last)

    def _link_lost(self, err: LinkLostError) -> LinkLostError:
        unanswered = [ln.number for ln in self.stream.inflight if ln.number]
        last = self._last_line or None
        tail = (
            f"; lines {unanswered[0]}-{unanswered[-1]} were sent without an answer"
            if unanswered
            else ""
        )
        return LinkLostError(
            f"{err.message}; last line answered: {last or 'none'}{tail}; not resumed "
            "automatically: reconnect and resume with --resume-from journal (the position "
            "decides) or --resume-from N",
            line=last,
        )
