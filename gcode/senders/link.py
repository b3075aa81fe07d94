"""The byte link a sender talks through, as a small protocol (no I/O library here).

:class:`Link` is what the GRBL driver needs from a transport: write bytes, read what has
arrived within a time-out, close. :mod:`gcode.senders.serial_link` implements it with
pyserial (a device, ``socket://host:port`` or a pseudo-terminal); tests may pass any
object with these methods.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

__all__ = ["Link"]


@runtime_checkable
class Link(Protocol):
    """A bidirectional byte link.

    ``read`` returns the bytes that arrived within ``timeout_s`` (``b""`` when none did)
    and raises :class:`~gcode.senders.errors.LinkLostError` when the link is gone;
    ``write`` writes every byte (bounded by the link's own write time-out) or raises
    :class:`~gcode.senders.errors.LinkLostError`.
    """

    name: str

    def read(self, timeout_s: float) -> bytes:
        """Bytes received within ``timeout_s`` seconds (possibly empty)."""
        ...

    def write(self, data: bytes) -> None:
        """Write all of ``data``."""
        ...

    def close(self) -> None:
        """Close the link (idempotent)."""
        ...
