r"""The job journal: every line sent and answered, so an interrupted job can be resumed.

One JSON object per line, appended and flushed as the job runs (a crash loses at most the
last fraction of a second). A file can hold several runs of one program (the first run,
then resumes); each run starts with a ``job`` record::

    {"e": "job", "name": "part.nc", "sha256": "...", "mode": "char-count", "port": "...",
     "start_line": 1, "time": "2024-05-05T10:00:00"}
    {"e": "sent", "line": 12}           (source line; 0 for preamble lines the sender adds)
    {"e": "ok", "line": 12}
    {"e": "error", "line": 13, "code": 20}
    {"e": "alarm", "code": 2, "line": 14}
    {"e": "msg", "text": "[MSG:Reset to continue]"}
    {"e": "end", "outcome": "done" | "error" | "alarm" | "cancelled" | "link-lost" | ...,
     "resume_line": 13, "message": "..."}

:func:`read_journal` summarizes the last run: which lines were answered, which were sent
without an answer, how it ended and where it suggested resuming. The journal never
resumes anything by itself: the user asks (``--resume-from``), and the sender checks the
program's hash first.

Examples
--------
>>> import tempfile, pathlib
>>> from gcode.senders.job import Job
>>> path = pathlib.Path(tempfile.mkdtemp()) / "job.log"
>>> job = Job.from_text("G0X1\nG0X2\nG0X3\n")
>>> with JobJournal(path, job, mode="char-count", port="test") as j:
...     j.sent(job.lines[0]); j.sent(job.lines[1]); j.acked(job.lines[0])
...     j.end("link-lost", resume_line=None)
>>> info = read_journal(path)
>>> info.last_acked, info.last_sent, info.outcome, info.sha256 == job.sha256
(1, 2, 'link-lost', True)
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

from gcode.senders.job import Job, JobLine

__all__ = ["JobJournal", "JournalInfo", "read_journal"]


class JobJournal:
    """Append-only journal of one run.

    Parameters
    ----------
    path : str or Path
        Journal file (created, or appended to).
    job : Job
        The program being sent.
    mode : str
        Streaming mode (recorded).
    port : str
        Link name (recorded).
    start_line : int or None
        First source line of this run (a resume), None for the whole program.
    flush_interval_s : float
        Longest time records stay in memory before being written, s.
    """

    def __init__(
        self,
        path: str | Path,
        job: Job,
        *,
        mode: str,
        port: str,
        start_line: int | None = None,
        flush_interval_s: float = 0.1,
    ) -> None:
        self.path = Path(path)
        self._file = self.path.open("a", encoding="utf-8")
        self._buf: list[str] = []
        self._flush_interval_s = flush_interval_s
        self._last_flush = time.monotonic()
        self._write(
            {
                "e": "job",
                "name": job.name,
                "sha256": job.sha256,
                "mode": mode,
                "port": port,
                "lines": len(job.lines),
                "start_line": start_line
                if start_line is not None
                else (job.lines[0].number if job.lines else 0),
                "time": time.strftime("%Y-%m-%dT%H:%M:%S"),
            }
        )
        self.flush()

    def __enter__(self) -> JobJournal:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()

    def _write(self, record: dict[str, Any]) -> None:
        self._buf.append(json.dumps(record, separators=(",", ":")))
        if time.monotonic() - self._last_flush >= self._flush_interval_s:
            self.flush()

    def sent(self, line: JobLine) -> None:
        """Record that ``line`` was written to the link."""
        self._buf.append(f'{{"e":"sent","line":{line.number}}}')

    def acked(self, line: JobLine) -> None:
        """Record the ``ok`` of ``line``."""
        self._buf.append(f'{{"e":"ok","line":{line.number}}}')
        if time.monotonic() - self._last_flush >= self._flush_interval_s:
            self.flush()

    def rejected(self, line: JobLine, code: int) -> None:
        """Record ``error:code`` for ``line``."""
        self._write({"e": "error", "line": line.number, "code": code, "text": line.text})
        self.flush()

    def alarm(self, code: int, line: JobLine | None) -> None:
        """Record ``ALARM:code`` (with the oldest unanswered line)."""
        self._write({"e": "alarm", "code": code, "line": line.number if line else None})
        self.flush()

    def message(self, text: str) -> None:
        """Record a push message or a note."""
        self._write({"e": "msg", "text": text})

    def end(self, outcome: str, *, resume_line: int | None, message: str = "") -> None:
        """Record how the run ended and where to resume."""
        self._write(
            {"e": "end", "outcome": outcome, "resume_line": resume_line, "message": message}
        )
        self.flush()

    def flush(self) -> None:
        """Write buffered records to the file and flush it."""
        if self._buf:
            self._file.write("\n".join(self._buf) + "\n")
            self._buf.clear()
        self._file.flush()
        self._last_flush = time.monotonic()

    def close(self) -> None:
        """Flush and close (idempotent)."""
        if self._file.closed:
            return
        self.flush()
        self._file.close()


@dataclass(frozen=True)
class JournalInfo:
    """Summary of the last run in a journal.

    Attributes
    ----------
    name, sha256, mode, port : str
        From the run's ``job`` record.
    start_line : int
        First source line of the run.
    acked : frozenset of int
        Source lines answered ``ok`` in the run.
    sent_unanswered : tuple of int
        Source lines sent and never answered, in order.
    last_acked, last_sent : int or None
        Highest source line answered ``ok`` / written.
    outcome : str or None
        How the run ended (None: it did not record an end, e.g. a crash).
    resume_line : int or None
        Where the run suggested resuming.
    message : str
        The end record's message.
    """

    name: str
    sha256: str
    mode: str
    port: str
    start_line: int
    acked: frozenset[int]
    sent_unanswered: tuple[int, ...]
    last_acked: int | None
    last_sent: int | None
    outcome: str | None
    resume_line: int | None
    message: str


def read_journal(path: str | Path) -> JournalInfo:
    """Summarize the last run recorded in a journal file.

    Parameters
    ----------
    path : str or Path
        The journal.

    Returns
    -------
    JournalInfo
        The last run.

    Raises
    ------
    ValueError
        When the file holds no run (naming the file and the first bad line if any).
    """
    p = Path(path)
    run: dict[str, Any] | None = None
    sent: list[int] = []
    answered: set[int] = set()
    acked: set[int] = set()
    end: dict[str, Any] = {}
    with p.open(encoding="utf-8") as f:
        for n, raw in enumerate(f, start=1):
            raw = raw.strip()
            if not raw:
                continue
            try:
                rec = json.loads(raw)
            except json.JSONDecodeError:
                # a crash can leave a torn last line: ignore it, but nothing before it
                if f.readline() == "":
                    break
                raise ValueError(f"{p}:{n}: not a journal record: {raw[:60]!r}") from None
            e = rec.get("e")
            if e == "job":
                run, sent, answered, acked, end = rec, [], set(), set(), {}
            elif run is None:
                continue
            elif e == "sent":
                if rec["line"]:
                    sent.append(rec["line"])
            elif e == "ok":
                if rec["line"]:
                    acked.add(rec["line"])
                    answered.add(rec["line"])
            elif e == "error":
                if rec["line"]:
                    answered.add(rec["line"])
            elif e == "end":
                end = rec
    if run is None:
        raise ValueError(f"{p}: no job record: not a sender journal")
    unanswered = tuple(n for n in sent if n not in answered)
    return JournalInfo(
        name=run.get("name", ""),
        sha256=run.get("sha256", ""),
        mode=run.get("mode", ""),
        port=run.get("port", ""),
        start_line=int(run.get("start_line", 0)),
        acked=frozenset(acked),
        sent_unanswered=unanswered,
        last_acked=max(acked) if acked else None,
        last_sent=max(sent) if sent else None,
        outcome=end.get("outcome"),
        resume_line=end.get("resume_line"),
        message=end.get("message", ""),
    )
