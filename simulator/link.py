"""A paced byte pipe: baud-rate pacing and latency of one direction of a serial link.

The host's bytes do not reach a real controller at once: a USB-serial bridge adds a
latency and the UART sends 10 bits per byte (8N1), so 115200 baud carries 11,520 bytes/s
each way. :class:`PacedPipe` models one direction in wall-clock seconds, sans-IO: the
owner pushes bytes with the time they were written and pops the bytes that have arrived
by a given time.

Examples
--------
>>> p = PacedPipe(bytes_per_s=1000.0, latency_s=0.010)
>>> p.push(b"abcdef", now_s=0.0)
>>> p.pop(0.012), p.pop(0.1)
(b'ab', b'cdef')
"""

from __future__ import annotations

import math
from collections import deque

__all__ = ["PacedPipe", "bytes_per_s_for_baud"]

#: Bytes due by ``elapsed * rate`` are counted with this much added: a byte due exactly now
#: (the clock advanced by ``1 / rate``) is delivered despite round-off of the product.
_DUE_SLACK_BYTES = 1e-9


def bytes_per_s_for_baud(baud: int | None, bits_per_byte: int = 10) -> float:
    """Bytes per second of a UART link (8N1: 10 bits a byte); ``inf`` for 0/None.

    Raises
    ------
    ValueError
        For a negative baud rate.
    """
    if baud is None or baud == 0:
        return math.inf
    if baud < 0:
        raise ValueError(f"baud rate must be > 0 (or 0 for no pacing), got {baud!r}")
    return baud / bits_per_byte


class PacedPipe:
    """One direction of a link: latency, then bytes at a fixed rate.

    Parameters
    ----------
    bytes_per_s : float
        Rate, bytes/s (``inf``: no pacing).
    latency_s : float
        Delay before a pushed chunk starts to arrive, s.
    """

    def __init__(self, bytes_per_s: float = math.inf, latency_s: float = 0.0) -> None:
        if not bytes_per_s > 0.0:
            raise ValueError(f"bytes_per_s must be > 0, got {bytes_per_s!r}")
        if not (math.isfinite(latency_s) and latency_s >= 0.0):
            raise ValueError(f"latency must be a finite time >= 0 s, got {latency_s!r}")
        self.bytes_per_s = bytes_per_s
        self.latency_s = latency_s
        self._q: deque[tuple[float, bytearray]] = deque()
        self._busy_until = -math.inf
        self.pending = 0

    def push(self, data: bytes, now_s: float, *, not_before_s: float = -math.inf) -> None:
        """Queue ``data`` written at ``now_s`` (arrival starts after the latency)."""
        if data:
            self._q.append((max(now_s + self.latency_s, not_before_s), bytearray(data)))
            self.pending += len(data)

    def pop(self, now_s: float) -> bytes:
        """Bytes that have arrived by ``now_s``."""
        out = bytearray()
        q = self._q
        rate = self.bytes_per_s
        while q:
            ready, buf = q[0]
            start = max(ready, self._busy_until)
            if start > now_s:
                break
            if math.isinf(rate):
                take = len(buf)
                self._busy_until = start
            else:
                take = min(int((now_s - start) * rate + _DUE_SLACK_BYTES), len(buf))
                if take == 0:
                    break
                self._busy_until = start + take / rate
            out += buf[:take]
            del buf[:take]
            if buf:
                break
            q.popleft()
        self.pending -= len(out)
        return bytes(out)

    def next_due_s(self) -> float | None:
        """Wall time at which the next byte arrives (None when empty)."""
        if not self._q:
            return None
        ready = self._q[0][0]
        start = max(ready, self._busy_until)
        return start if math.isinf(self.bytes_per_s) else start + 1.0 / self.bytes_per_s

    def clear(self) -> None:
        """Drop everything in flight (link cut)."""
        self._q.clear()
        self.pending = 0
        self._busy_until = -math.inf
