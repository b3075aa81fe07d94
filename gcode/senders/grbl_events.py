"""The events of a GRBL stream: what :class:`~gcode.senders.grbl_stream.GrblStream` reports.

Frozen records popped with :meth:`GrblStream.pop_events
<gcode.senders.grbl_stream.GrblStream.pop_events>` (re-exported by
:mod:`gcode.senders.grbl_stream`), one per line sent, answer, push or expired wait.
"""

from __future__ import annotations

from dataclasses import dataclass

from gcode.senders.grbl_messages import Message, StatusReport
from gcode.senders.job import JobLine

__all__ = [
    "AlarmRaised",
    "ControllerReset",
    "Event",
    "LineAcked",
    "LineRejected",
    "LineSent",
    "Pushed",
    "StatusUpdate",
    "TimedOut",
    "Unexpected",
]


@dataclass(frozen=True, slots=True)
class LineSent:
    """``line`` was handed to the link (its bytes are in :meth:`GrblStream.outgoing`)."""

    line: JobLine


@dataclass(frozen=True, slots=True)
class LineAcked:
    """``ok`` for ``line``."""

    line: JobLine


@dataclass(frozen=True, slots=True)
class LineRejected:
    """``error:code`` for ``line``."""

    line: JobLine
    code: int


@dataclass(frozen=True, slots=True)
class AlarmRaised:
    """``ALARM:code``; ``suspect`` is the oldest unanswered line, ``lost`` all of them."""

    code: int
    suspect: JobLine | None
    lost: tuple[JobLine, ...]


@dataclass(frozen=True, slots=True)
class ControllerReset:
    """The welcome banner: the controller restarted and dropped the ``lost`` lines."""

    version: str
    lost: tuple[JobLine, ...]
    expected: bool


@dataclass(frozen=True, slots=True)
class StatusUpdate:
    """A status report arrived."""

    report: StatusReport


@dataclass(frozen=True, slots=True)
class Pushed:
    """Any other push (``[MSG:...]``, ``$n=v``, ...)."""

    message: Message


@dataclass(frozen=True, slots=True)
class Unexpected:
    """An answer with no line outstanding: the count is broken, stop at once."""

    text: str


@dataclass(frozen=True, slots=True)
class TimedOut:
    """A bounded wait ran out.

    ``what`` is ``lost-line``, ``silent``, ``stall``, ``hold`` or ``reset``.
    """

    what: str
    detail: str


Event = (
    LineSent
    | LineAcked
    | LineRejected
    | AlarmRaised
    | ControllerReset
    | StatusUpdate
    | Pushed
    | Unexpected
    | TimedOut
)
