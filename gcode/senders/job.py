r"""A job: the lines of a G-code program exactly as a sender puts them on the wire.

The sender sends each source line compacted the way grbl itself compacts it: comments
(``( )`` and ``;``) and whitespace removed, letters upper-cased, ``%`` delimiter lines and
lines left empty dropped. That keeps every byte of the 128-byte receive buffer for
G-code (a comment-heavy CAM file would otherwise spend half the link on comments) and makes
the byte count exact: the count is taken on the very bytes written, ``text + "\n"``
(Universal G-code Sender's overrun, PR #1678, came from counting a trimmed copy).

Each :class:`JobLine` keeps its 1-based source line number, so every acknowledgement,
error and journal record names the line of the user's file.

Lines that must go with send-response even in a character-counting stream (``sync``):
``$`` system commands (``$x=v`` writes EEPROM, during which the AVR drops received
bytes; ``$`` commands need Idle), ``G10 L2/L20``, ``G28.1``, ``G30.1`` (EEPROM writes).

Examples
--------
>>> job = Job.from_text("G21 (mm)\n\n%\ng0 x1 y2 ; rapid\n$110=500\n")
>>> [(j.number, j.text, j.sync) for j in job.lines]
[(1, 'G21', False), (4, 'G0X1Y2', False), (5, '$110=500', True)]
>>> job.lines[1].data
b'G0X1Y2\n'
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["MAX_LINE_CHARS", "Job", "JobLine", "compact_line"]

#: Longest line grbl 1.1 takes (its line buffer holds 80 bytes with the terminating NUL).
MAX_LINE_CHARS = 79

_COMMENTS = re.compile(r"\([^)]*\)|;.*")
_SPACE = re.compile(r"\s+")
_EEPROM = re.compile(r"G10L(?:2|20)(?!\d)|G28\.1|G30\.1")
_DWELL = re.compile(r"G0*4(?![\d.]).*?P(\d+\.?\d*|\.\d+)")


def compact_line(text: str) -> str:
    """Return ``text`` as grbl keeps it: no comments, no whitespace, upper case.

    Parameters
    ----------
    text : str
        One source line (its line end optional).

    Returns
    -------
    str
        The compacted line; empty for a comment-only or blank line.
    """
    if "(" in text or ";" in text:
        text = _COMMENTS.sub("", text)
    return _SPACE.sub("", text).upper()


@dataclass(frozen=True, slots=True)
class JobLine:
    """One line to send.

    Attributes
    ----------
    number : int
        1-based line of the source file (0 for lines the sender adds, e.g. a resume
        preamble or ``$C``).
    text : str
        The compacted line, without line end.
    sync : bool
        Send with send-response: wait for every earlier line's answer first and send
        nothing after it until it is answered.
    dwell_s : float
        Dwell time the line asks for (``G4 P``), s; the controller answers it only after.
    """

    number: int
    text: str
    sync: bool = False
    dwell_s: float = 0.0

    @property
    def data(self) -> bytes:
        """The bytes written to the link: ``text`` and a line feed."""
        return (self.text + "\n").encode("ascii")

    @property
    def size(self) -> int:
        """Bytes the line occupies in the controller's receive buffer."""
        return len(self.text) + 1

    @classmethod
    def of(cls, number: int, text: str) -> JobLine:
        """A line from source text (compacted; ``sync`` and ``dwell_s`` derived)."""
        t = compact_line(text)
        sync = t.startswith("$") or _EEPROM.search(t) is not None
        m = _DWELL.search(t)
        return cls(number, t, sync, float(m.group(1)) if m else 0.0)


@dataclass(frozen=True)
class Job:
    """The lines of one program, ready to stream.

    Attributes
    ----------
    lines : tuple of JobLine
        Non-empty compacted lines in file order.
    source : str
        The full program text (for the pre-flight, resume planning and the journal hash).
    name : str
        File name or a label.
    """

    lines: tuple[JobLine, ...]
    source: str
    name: str = "<text>"
    _by_number: dict[int, int] = field(default_factory=dict, repr=False, compare=False)

    def __post_init__(self) -> None:
        self._by_number.update((ln.number, i) for i, ln in enumerate(self.lines))

    @classmethod
    def from_text(cls, text: str, name: str = "<text>") -> Job:
        """Compact every line of ``text`` (see the module docstring)."""
        out = []
        for n, raw in enumerate(text.splitlines(), start=1):
            line = JobLine.of(n, raw)
            if line.text and line.text != "%":
                out.append(line)
        return cls(tuple(out), text, name)

    @classmethod
    def from_file(cls, path: str | Path) -> Job:
        """Read a G-code file (UTF-8/ASCII) into a job."""
        p = Path(path)
        return cls.from_text(p.read_text(encoding="utf-8", errors="replace"), str(p))

    @property
    def sha256(self) -> str:
        """Hash of the program text, so a journal is only used with its own program."""
        return hashlib.sha256(self.source.encode("utf-8")).hexdigest()

    @property
    def last_line_number(self) -> int:
        """Source line of the last line sent (0 for an empty job)."""
        return self.lines[-1].number if self.lines else 0

    def index_of(self, number: int) -> int:
        """Index in :attr:`lines` of the first line at or after source line ``number``.

        Returns ``len(lines)`` when no line is left at or after ``number``.
        """
        if number in self._by_number:
            return self._by_number[number]
        for i, ln in enumerate(self.lines):
            if ln.number >= number:
                return i
        return len(self.lines)

    def too_long(self) -> list[JobLine]:
        """Lines longer than grbl's line buffer (:data:`MAX_LINE_CHARS`)."""
        return [ln for ln in self.lines if len(ln.text) > MAX_LINE_CHARS]

    def from_line(self, number: int) -> Sequence[JobLine]:
        """The lines from source line ``number`` on."""
        return self.lines[self.index_of(number) :]
