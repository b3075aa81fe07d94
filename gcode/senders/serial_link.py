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

import select
import time

import serial

from gcode.senders.errors import LinkLostError

__all__ = ["DEFAULT_BAUD", "SerialLink", "open_serial_link"]

#: GRBL 1.1's default baud rate (8N1).
DEFAULT_BAUD = 115200
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
    try:
        port = serial.serial_for_url(url, baudrate=baud, timeout=0, write_timeout=write_timeout_s)
    except (serial.SerialException, OSError, ValueError) as exc:
        raise LinkLostError(f"cannot open {url!r}: {exc}") from exc
    return SerialLink(port, url)
