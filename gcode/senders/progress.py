r"""Progress of a job: a record for programs and the service, a text bar for the CLI.

The senders call a ``on_progress(Progress)`` callback (at most every
:data:`PROGRESS_INTERVAL_S` and once at the end); :class:`ProgressBar` is such a callback
that draws ``[#####.....]  52%  1040/2000 blocks  512 blocks/s  ETA 0:02  line 1187``
on a terminal (one line redrawn with ``\r``) or prints a plain line every few seconds
when the output is not a terminal. No third-party package is needed.

Examples
--------
>>> p = Progress(done=50, total=200, elapsed_s=2.0, line=61, state="Run")
>>> p.percent, p.rate_per_s, p.eta_s
(25.0, 25.0, 6.0)
>>> format_progress(p, width=10)
'[##........]  25%  50/200 blocks  25 blocks/s  ETA 0:06  line 61  Run'
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from typing import TextIO

__all__ = ["PROGRESS_INTERVAL_S", "Progress", "ProgressBar", "format_progress"]

#: Shortest time between two progress callbacks, s.
PROGRESS_INTERVAL_S = 0.1


@dataclass(frozen=True, slots=True)
class Progress:
    """How far a job is.

    Attributes
    ----------
    done : int
        Program blocks (lines) acknowledged by the controller.
    total : int
        Program blocks to send in this run.
    elapsed_s : float
        Time since the run started, s.
    line : int
        Source line of the last acknowledged block (0 before the first).
    state : str
        Controller state from the last status report (``Run``, ``Hold``, ...).
    position : tuple of float or None
        Work position, X Y Z mm: the latest status report's when it is recent, otherwise
        (a controller that answers few ``?``) the planned end of the last acknowledged
        line (the machine is at most a planner's worth of blocks behind it).
    position_source : str
        ``"report"``, ``"planned"`` or ``""`` (no position).
    """

    done: int
    total: int
    elapsed_s: float
    line: int = 0
    state: str = ""
    position: tuple[float, ...] | None = None
    position_source: str = ""

    @property
    def percent(self) -> float:
        """Share done, %."""
        return 100.0 * self.done / self.total if self.total else 100.0

    @property
    def rate_per_s(self) -> float:
        """Blocks acknowledged per second so far."""
        return self.done / self.elapsed_s if self.elapsed_s > 0.0 else 0.0

    @property
    def eta_s(self) -> float | None:
        """Estimated time left, s (None before any rate is known)."""
        rate = self.rate_per_s
        if rate <= 0.0:
            return None
        return (self.total - self.done) / rate


def _clock(seconds: float | None) -> str:
    if seconds is None:
        return "--:--"
    s = round(seconds)
    h, rem = divmod(s, 3600)
    m, sec = divmod(rem, 60)
    return f"{h}:{m:02d}:{sec:02d}" if h else f"{m}:{sec:02d}"


def format_progress(p: Progress, width: int = 30) -> str:
    """One line: bar, percent, blocks, rate, ETA, line and state."""
    filled = int(width * p.done / p.total) if p.total else width
    bar = "#" * filled + "." * (width - filled)
    text = (
        f"[{bar}] {p.percent:3.0f}%  {p.done}/{p.total} blocks  {p.rate_per_s:.0f} blocks/s"
        f"  ETA {_clock(p.eta_s)}  line {p.line}"
    )
    text += f"  {p.state}" if p.state else ""
    if p.position is not None:
        xyz = " ".join(f"{a}{v:.3f}" for a, v in zip("XYZ", p.position, strict=False))
        text += f"  {xyz}" + (" (planned)" if p.position_source == "planned" else "")
    return text


class ProgressBar:
    """A progress callback drawing on a text stream.

    Parameters
    ----------
    stream : TextIO or None
        Where to draw (``sys.stderr`` when None).
    width : int
        Bar width, characters.
    plain_interval_s : float
        When the stream is not a terminal, print a line at most this often, s.
    """

    def __init__(
        self, stream: TextIO | None = None, *, width: int = 30, plain_interval_s: float = 5.0
    ) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.plain_interval_s = plain_interval_s
        self._tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._last_plain = -float("inf")
        self._drawn = False

    def __call__(self, p: Progress) -> None:
        """Draw ``p``."""
        text = format_progress(p, self.width)
        if self._tty:
            self.stream.write("\r" + text + "\x1b[K")
            self._drawn = True
        else:
            now = time.monotonic()
            if now - self._last_plain < self.plain_interval_s and p.done < p.total:
                return
            self._last_plain = now
            self.stream.write(text + "\n")
        self.stream.flush()

    def close(self) -> None:
        """End the bar's line (terminal)."""
        if self._tty and self._drawn:
            self.stream.write("\n")
            self.stream.flush()
            self._drawn = False
