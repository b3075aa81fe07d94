"""Errors of the senders: one base class, each naming the line and the problem.

Every error a job can end with is a :class:`SenderError`. Its message says what happened
and where (source line and text where there is one), and it carries what a user needs to
go on: :attr:`SenderError.resume_line`, the first source line not known to have run (None
when it cannot be known), so the report can say ``resume with --resume-from N``.

Examples
--------
>>> err = LineRejectedError(20, line=7, text="G1A5", resume_line=7)
>>> str(err)[:54]
"line 7: the controller rejected 'G1A5' with error:20 ("
>>> err.code, err.resume_line
(20, 7)
"""

from __future__ import annotations

from collections.abc import Sequence

from gcode.senders.grbl_messages import alarm_text, error_text

__all__ = [
    "AlarmError",
    "ControllerResetError",
    "HandshakeError",
    "JobCancelledError",
    "LinkLostError",
    "LinkTimeoutError",
    "LineRejectedError",
    "LineTooLongError",
    "PreflightError",
    "ProtocolError",
    "ResumeError",
    "SenderError",
]


class SenderError(RuntimeError):
    """A job stopped or could not start.

    Parameters
    ----------
    message : str
        What happened.
    line : int or None
        1-based source line concerned.
    text : str or None
        That line as sent.
    resume_line : int or None
        First source line not known to have run (the place to resume from), if known.
    """

    def __init__(
        self,
        message: str,
        *,
        line: int | None = None,
        text: str | None = None,
        resume_line: int | None = None,
    ) -> None:
        self.message = message
        self.line = line
        self.text = text
        self.resume_line = resume_line
        super().__init__(message)

    #: How a journal records a run that ended with this error.
    outcome = "failed"


class PreflightError(SenderError):
    """The program was refused before a byte was sent (soft limits, unsupported words).

    Parameters
    ----------
    issues : sequence
        The :class:`gcode.check.Issue` records (or strings) that refuse it.
    """

    outcome = "refused"

    def __init__(self, issues: Sequence[object], *, name: str = "program") -> None:
        self.issues = tuple(issues)
        first = self.issues[0] if self.issues else None
        line = getattr(first, "line", None)
        more = f" (and {len(self.issues) - 1} more)" if len(self.issues) > 1 else ""
        super().__init__(f"{name} refused before sending: {first}{more}", line=line)


class HandshakeError(SenderError):
    """The controller did not answer the start-up handshake as a GRBL 1.1 controller."""

    outcome = "handshake"


class LinkLostError(SenderError):
    """The link closed or failed (cable, socket, pty); never resumed automatically."""

    outcome = "link-lost"


class LineTooLongError(SenderError):
    """A line can never fit the controller's receive buffer: refused before sending."""

    outcome = "refused"


class LinkTimeoutError(SenderError):
    """A bounded wait ran out (no status report, a lost line, a stall, a hold, a reset)."""

    outcome = "timeout"


class ProtocolError(SenderError):
    """An answer that does not fit the count (an ``ok`` with nothing outstanding)."""

    outcome = "protocol"


class LineRejectedError(SenderError):
    """The controller answered ``error:N`` to a line.

    Parameters
    ----------
    code : int
        GRBL error number.
    """

    outcome = "error"

    def __init__(
        self,
        code: int,
        *,
        line: int | None,
        text: str | None,
        resume_line: int | None = None,
        note: str = "",
    ) -> None:
        self.code = code
        where = f"line {line}: " if line else ""
        what = f"the controller rejected {text!r} with error:{code} ({error_text(code)})"
        super().__init__(
            where + what + (f"; {note}" if note else ""),
            line=line,
            text=text,
            resume_line=resume_line,
        )


class AlarmError(SenderError):
    """The controller raised ``ALARM:N`` during the job.

    Parameters
    ----------
    code : int
        GRBL alarm number.
    """

    outcome = "alarm"

    def __init__(
        self,
        code: int,
        *,
        line: int | None,
        text: str | None,
        resume_line: int | None = None,
        note: str = "",
    ) -> None:
        self.code = code
        where = f"line {line} ({text!r}) was being processed" if line else "no line outstanding"
        super().__init__(
            f"ALARM:{code} ({alarm_text(code)}); {where}" + (f"; {note}" if note else ""),
            line=line,
            text=text,
            resume_line=resume_line,
        )


class ControllerResetError(SenderError):
    """The controller restarted mid-job (its banner arrived unasked); the job stopped."""

    outcome = "reset"


class JobCancelledError(SenderError):
    """The job was cancelled (feed hold, then reset) at the user's request."""

    outcome = "cancelled"


class ResumeError(SenderError):
    """A resume cannot be planned safely at the asked line (mid-arc, past the end, ...)."""

    outcome = "resume-refused"
