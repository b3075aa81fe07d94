"""Byte transports for the serial front end: a pseudo-terminal and a TCP listener.

Both are non-blocking endpoints that the simulator's event loop polls; neither knows the
protocol. :class:`PtyEndpoint` opens a pseudo-terminal pair and publishes the device path
(pyserial opens it like a USB port); it notices a client opening and closing the device
(the master side reports a hang-up while no client has it open), as a USB-serial
Arduino notices DTR. :class:`TcpEndpoint` listens on 127.0.0.1 (port 0 picks a free port)
for ``socket://127.0.0.1:PORT`` clients, one at a time: a new connection replaces the old.

Examples
--------
>>> ep = TcpEndpoint(0)
>>> ep.port > 0, ep.url.startswith("socket://127.0.0.1:")
(True, True)
>>> ep.close()
"""

from __future__ import annotations

import errno
import os
import select
import socket
import tty

__all__ = ["LOCALHOST", "PtyEndpoint", "TcpEndpoint"]

#: The only address the simulator binds.
LOCALHOST = "127.0.0.1"
_READ_CHUNK = 65536


class PtyEndpoint:
    """A pseudo-terminal whose slave side is the simulated serial device.

    Attributes
    ----------
    path : str
        Device path to open with pyserial (``/dev/pts/N``).
    """

    def __init__(self) -> None:
        master, slave = os.openpty()
        tty.setraw(slave)
        self.path = os.ttyname(slave)
        os.close(slave)  # a hang-up on the master now means "no client"
        os.set_blocking(master, False)
        self.fd = master
        self._poll = select.poll()
        self._poll.register(master, select.POLLIN | select.POLLHUP)
        self.connected = False

    @property
    def url(self) -> str:
        """What to give pyserial: the device path."""
        return self.path

    def check_client(self) -> tuple[bool, bool]:
        """Poll for a client opening or closing the device.

        Returns
        -------
        (opened, closed) : tuple of bool
            Whether a client appeared or went away since the last call.
        """
        if self.fd < 0:
            return False, False
        events = self._poll.poll(0)
        hup = any(ev & select.POLLHUP for _, ev in events)
        was = self.connected
        self.connected = not hup
        return (not was and self.connected), (was and not self.connected)

    def read(self) -> bytes:
        """Bytes the client wrote (empty when none or no client)."""
        if self.fd < 0 or not self.connected:
            return b""
        try:
            return os.read(self.fd, _READ_CHUNK)
        except BlockingIOError:
            return b""
        except OSError as exc:
            if exc.errno == errno.EIO:
                self.connected = False
                return b""
            raise

    def write(self, data: bytes) -> int:
        """Write to the client; returns bytes taken (0 when it would block or no client)."""
        if self.fd < 0 or not self.connected or not data:
            return 0
        try:
            return os.write(self.fd, data)
        except (BlockingIOError, InterruptedError):
            return 0
        except OSError as exc:
            if exc.errno == errno.EIO:
                self.connected = False
                return 0
            raise

    def close(self) -> None:
        """Close the device: a client sees it disappear."""
        if self.fd >= 0:
            self._poll.unregister(self.fd)
            os.close(self.fd)
            self.fd = -1
            self.connected = False


class TcpEndpoint:
    """A TCP listener on 127.0.0.1 serving one client at a time.

    Parameters
    ----------
    port : int
        Port to bind; 0 picks a free one (read :attr:`port`).

    Raises
    ------
    OSError
        If the port cannot be bound (the message names the port).
    """

    def __init__(self, port: int = 0) -> None:
        if not 0 <= int(port) <= 65535:
            raise ValueError(f"TCP port must be 0..65535 (0 = any free port), got {port!r}")
        self._listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            self._listener.bind((LOCALHOST, int(port)))
        except OSError as exc:
            self._listener.close()
            raise OSError(
                exc.errno, f"cannot listen on {LOCALHOST}:{port}: {exc.strerror}"
            ) from None
        self._listener.listen(4)
        self._listener.setblocking(False)
        self.port = self._listener.getsockname()[1]
        self.fd = self._listener.fileno()
        self._client: socket.socket | None = None

    @property
    def url(self) -> str:
        """Pyserial URL of the endpoint."""
        return f"socket://{LOCALHOST}:{self.port}"

    @property
    def connected(self) -> bool:
        """A client is connected."""
        return self._client is not None

    @property
    def client_fd(self) -> int:
        """File descriptor of the client socket (-1 without one)."""
        return self._client.fileno() if self._client is not None else -1

    def check_client(self) -> tuple[bool, bool]:
        """Accept a pending connection (replacing the current client).

        Returns
        -------
        (opened, closed) : tuple of bool
            A new client was accepted; the previous one was dropped for it.
        """
        try:
            sock, _ = self._listener.accept()
        except (BlockingIOError, InterruptedError):
            return False, False
        closed = self.drop_client()
        sock.setblocking(False)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._client = sock
        return True, closed

    def read(self) -> bytes:
        """Bytes from the client (empty when none; a closed peer drops the client)."""
        c = self._client
        if c is None:
            return b""
        try:
            data = c.recv(_READ_CHUNK)
        except (BlockingIOError, InterruptedError):
            return b""
        except OSError:
            self.drop_client()
            return b""
        if not data:
            self.drop_client()
        return data

    def write(self, data: bytes) -> int:
        """Send to the client; returns bytes taken."""
        c = self._client
        if c is None or not data:
            return 0
        try:
            return c.send(data)
        except (BlockingIOError, InterruptedError):
            return 0
        except OSError:
            self.drop_client()
            return 0

    def drop_client(self) -> bool:
        """Close the client connection (the link is cut); True if there was one."""
        c = self._client
        if c is None:
            return False
        self._client = None
        try:
            c.shutdown(socket.SHUT_RDWR)
        except OSError:
            pass
        c.close()
        return True

    def close(self) -> None:
        """Stop listening and drop the client."""
        self.drop_client()
        self._listener.close()
