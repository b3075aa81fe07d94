"""Virtual time: an injectable clock and the mapping from wall time to virtual time.

The controller core never sleeps and never reads the wall clock: it is moved forward by
whoever owns a :class:`VirtualClock` (a test, a transport loop). :class:`Speed` says how
a transport maps wall time to virtual time: ``instant`` (virtual time jumps whenever the
controller would otherwise wait), ``realtime`` (1 virtual second per wall second) or
``xN`` (N virtual seconds per wall second).

Examples
--------
>>> clock = VirtualClock()
>>> clock.advance(0.25)
0.25
>>> Speed.parse("x10").factor, Speed.parse("instant").instant
(10.0, True)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Speed", "VirtualClock"]


class VirtualClock:
    """A monotonic virtual clock in seconds, moved only by :meth:`advance`.

    Parameters
    ----------
    start_s : float
        Initial time, s.
    """

    def __init__(self, start_s: float = 0.0) -> None:
        self._now_s = float(start_s)

    @property
    def now_s(self) -> float:
        """Current virtual time, s."""
        return self._now_s

    def advance(self, dt_s: float) -> float:
        """Move the clock forward by ``dt_s`` seconds (>= 0) and return the new time.

        Raises
        ------
        ValueError
            For a negative or non-finite step.
        """
        if not (math.isfinite(dt_s) and dt_s >= 0.0):
            raise ValueError(f"clock step must be a finite time >= 0 s, got {dt_s!r}")
        self._now_s += dt_s
        return self._now_s

    def advance_to(self, t_s: float) -> float:
        """Move the clock to ``t_s`` if that is later than now; return the new time."""
        if t_s > self._now_s:
            self._now_s = float(t_s)
        return self._now_s

    def __repr__(self) -> str:
        return f"VirtualClock(now_s={self._now_s!r})"


@dataclass(frozen=True, slots=True)
class Speed:
    """How virtual time relates to wall time.

    Attributes
    ----------
    factor : float
        Virtual seconds per wall second; ``inf`` for instant.
    """

    factor: float

    @property
    def instant(self) -> bool:
        """True when virtual time jumps instead of following the wall clock."""
        return math.isinf(self.factor)

    @property
    def name(self) -> str:
        """The text form: ``instant``, ``realtime`` or ``xN``."""
        if self.instant:
            return "instant"
        if self.factor == 1.0:
            return "realtime"
        return f"x{self.factor:g}"

    @classmethod
    def parse(cls, text: str | Speed) -> Speed:
        """Read ``instant``, ``realtime`` or ``xN`` (N > 0, e.g. ``x10``, ``x0.5``).

        Raises
        ------
        ValueError
            For anything else; the message lists the accepted forms.
        """
        if isinstance(text, Speed):
            return text
        t = str(text).strip().lower()
        if t == "instant":
            return cls(math.inf)
        if t == "realtime":
            return cls(1.0)
        if t.startswith("x"):
            try:
                factor = float(t[1:])
            except ValueError:
                factor = math.nan
            if math.isfinite(factor) and factor > 0.0:
                return cls(factor)
        raise ValueError(
            f"unknown speed {text!r}: use 'instant', 'realtime' or 'xN' with N > 0 (e.g. 'x10')"
        )
