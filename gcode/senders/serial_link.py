"""The pyserial transport: the package's only pyserial importer (with nothing else in it).

:func:`open_serial_link` opens anything ``serial.serial_for_url`` opens: a device path
(``/dev/ttyUSB0``, ``COM3``), ``socket://host:port`` (a TCP serial bridge or the
simulator), or a pseudo-terminal path. The port is opened non-blocking and waited on with
``select`` where it has a file descriptor, so a read returns as soon as bytes arrive and
never later than its time-out; writes are bounded by ``write_timeout_s``. Every pyserial
or OS failure becomes :class:`~gcode.senders.errors.LinkLostError` naming the port.

Opening a real Arduino-based GRBL board toggles DTR, which resets it (about 2 s of
bootloader before the banner): the driver's handshake waits for the banner for that reason.
"""

from __future__ import annotations

import errno
import select
import time

import serial

from gcode.senders.errors import LinkLostError
from gcode.senders.stream_options import DEFAULT_BAUD

__all__ = ["DEFAULT_BAUD", "SerialLink", "open_serial_link", "port_problem"]

_CHUNK_BYTES = 65536
_POLL_S = 0.002  # fallback polling step for ports without a file descriptor


class SerialLink:
    """A :class:`~gcode.senders.link.Link` over a pyserial port.

    Parameters
    ----------
    port : serial.SerialBase
        An open pyserial port (its timeout is set to 0: non-blocking reads).
    name : str
        The URL or path, for messages.
    """

    def __init__(self, port: serial.SerialBase, name: str) -> None:
        self._port = port
        self.name = name
        port.timeout = 0
        try:
            self._fd: int | None = port.fileno()
        except (AttributeError, OSError, ValueError, NotImplementedError):
            self._fd = None
        self.closed = False

    def read(self, timeout_s: float) -> bytes:
        """Bytes received within ``timeout_s`` seconds (``b""`` if none).

        Raises
        ------
        LinkLostError
            When the port reports an error or end of file.
        """
        try:
            if self._fd is not None:
                ready, _, _ = select.select([self._fd], [], [], max(timeout_s, 0.0))
                if not ready:
                    return b""
                data = self._port.read(_CHUNK_BYTES)
                if not data:
                    raise LinkLostError(f"{self.name}: the link closed (end of file)")
                return data
            deadline = time.monotonic() + max(timeout_s, 0.0)
            while True:
                data = self._port.read(_CHUNK_BYTES)
                if data or time.monotonic() >= deadline:
                    return data
                time.sleep(_POLL_S)
        except (serial.SerialException, OSError) as exc:
            raise LinkLostError(f"{self.name}: the link failed while reading: {exc}") from exc

    def write(self, data: bytes) -> None:
        """Write all of ``data``.

        Raises
        ------
        LinkLostError
            When the port fails or the write times out.
        """
        try:
            n = self._port.write(data)
            if n is not None and n != len(data):
                raise LinkLostError(f"{self.name}: wrote {n} of {len(data)} bytes")
        except (serial.SerialException, serial.SerialTimeoutException, OSError) as exc:
            raise LinkLostError(f"{self.name}: the link failed while writing: {exc}") from exc

    def close(self) -> None:
        """Close the port (idempotent; errors while closing are ignored)."""
        if self.closed:
            return
        self.closed = True
        try:
            self._port.close()
        except (serial.SerialException, OSError):
            pass


_NET_SCHEMES = ("socket://", "rfc2217://")
_OPEN_REASONS = {
    errno.ECONNREFUSED: "connection refused: nothing listens on that port",
    errno.ENOENT: "no such device",
    errno.EACCES: "permission denied (is the user in the 'dialout' group?)",
    errno.EBUSY: "the device is busy (another program has it open)",
    errno.EHOSTUNREACH: "host unreachable",
    errno.ETIMEDOUT: "connection timed out",
}


def port_problem(url: str) -> str | None:
    """What is wrong with a port's text before trying to open it, or None.

    Checks that something is given and that a ``socket://`` / ``rfc2217://`` URL has a
    host and a TCP port number 1-65535 (pyserial itself fails on a missing port with a
    ``TypeError`` text, and on a bad one with an unrelated message).
    """
    text = url.strip()
    if not text:
        return (
            "no port given: use a serial device (/dev/ttyUSB0, COM3), a pty path or "
            "socket://HOST:PORT"
        )
    low = text.lower()
    for scheme in _NET_SCHEMES:
        if low.startswith(scheme):
            where = text[len(scheme) :].split("/", 1)[0].split("?", 1)[0]
            host, colon, port = where.rpartition(":")
            if not colon:
                host, port = where, ""
            if not host:
                return f"no host before the port (use {scheme}HOST:PORT)"
            if not port:
                return f"no TCP port number after the host (use {scheme}{host}:PORT, 1-65535)"
            if not port.isdigit() or not 1 <= int(port) <= 65535:
                return f"the TCP port {port!r} is not a number 1-65535"
    return None


def _open_reason(exc: BaseException) -> str:
    """One line saying why opening failed (the errno's meaning when known)."""
    code = getattr(exc, "errno", None)
    cause = exc.__cause__ or exc.__context__
    if code not in _OPEN_REASONS and cause is not None:
        code = getattr(cause, "errno", None)
    if code in _OPEN_REASONS:
        return _OPEN_REASONS[code]
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


def open_serial_link(
    url: str, *, baud: int = DEFAULT_BAUD, write_timeout_s: float = 5.0
) -> SerialLink:
    """Open a serial port, ``socket://`` URL or pseudo-terminal.

    Parameters
    ----------
    url : str
        What ``serial.serial_for_url`` accepts.
    baud : int
        Baud rate, 8N1 (ignored by ``socket://``).
    write_timeout_s : float
        Bound on one write, s.

    Returns
    -------
    SerialLink
        The open link.

    Raises
    ------
    LinkLostError
        When the port cannot be opened (the message names it and the reason).
    """
    if baud <= 0:
        raise ValueError(f"baud must be a positive integer, got {baud!r}")
    problem = port_problem(url)
    if problem is not None:
        raise LinkLostError(f"cannot open port {url!r}: {problem}")
    try:
        port = serial.serial_for_url(url, baudrate=baud, timeout=0, write_timeout=write_timeout_s)
    except (serial.SerialException, OSError, ValueError, TypeError) as exc:
        raise LinkLostError(f"cannot open port {url!r}: {_open_reason(exc)}") from exc
    return SerialLink(port, url)
