"""One serial link: an endpoint (pty or TCP), pacing both ways, faults, and the protocol.

:class:`SerialSession` moves bytes between a :class:`~simulator.transports.PtyEndpoint`
or :class:`~simulator.transports.TcpEndpoint` and a
:class:`~simulator.grbl_protocol.GrblProtocol` through two
:class:`~simulator.link.PacedPipe` (baud rate and latency each way), applies the link
faults (drop after N bytes or lines, extra answer latency) and reacts to a client
connecting: after ``boot_delay_s`` the controller greets it with the banner, and with
``reset_on_connect`` it restarts first, as an Arduino does when the port is opened.
Everything is driven by :meth:`SerialSession.service` with the wall time; no threads.
"""

from __future__ import annotations

import math

from simulator.faults import FaultPlan
from simulator.grbl_protocol import GrblProtocol
from simulator.link import PacedPipe, bytes_per_s_for_baud
from simulator.transports import PtyEndpoint, TcpEndpoint

__all__ = ["SerialSession"]

#: Bytes grbl acts on at once, never buffered: a status poll is no line traffic.
_REALTIME_BYTES = b"?!~\x18" + bytes(range(0x80, 0x100))


class SerialSession:
    """A GRBL serial link served on a pty or a TCP port.

    Parameters
    ----------
    protocol : GrblProtocol
        The front end to feed.
    kind : str
        ``"pty"`` or ``"tcp"``.
    port : int
        TCP port (0 = any free port); ignored for a pty.
    baud : int
        Link speed, 8N1 (0 = unpaced).
    latency_s : float
        Link latency each way, s.
    faults : FaultPlan
        Link faults (drops, answer latency).
    reset_on_connect : bool
        Restart the controller when a client connects (USB DTR reset).
    boot_delay_s : float
        Time from a connection to the banner, s (pyserial flushes its input on open).
    """

    def __init__(
        self,
        protocol: GrblProtocol,
        kind: str,
        *,
        port: int = 0,
        baud: int = 115200,
        latency_s: float = 0.0,
        faults: FaultPlan | None = None,
        reset_on_connect: bool = True,
        boot_delay_s: float = 0.05,
    ) -> None:
        if kind not in ("pty", "tcp"):
            raise ValueError(f"serial transport must be 'pty' or 'tcp', got {kind!r}")
        self.protocol = protocol
        self.kind = kind
        self.faults = faults if faults is not None else protocol.faults
        rate = bytes_per_s_for_baud(baud)
        self.baud = baud
        self.inbound = PacedPipe(rate, latency_s)
        self.outbound = PacedPipe(rate, latency_s + self.faults.latency_s)
        self.reset_on_connect = reset_on_connect
        self.boot_delay_s = boot_delay_s
        self.endpoint: PtyEndpoint | TcpEndpoint = (
            PtyEndpoint() if kind == "pty" else TcpEndpoint(port)
        )
        self._wbuf = bytearray()
        self._boot_at = -math.inf
        self.bytes_in = 0
        self.bytes_out = 0
        self.line_ends_in = 0
        self.connects = 0
        self.drops = 0
        self.last_input_s = -math.inf
        self.last_line_input_s = -math.inf

    @property
    def url(self) -> str:
        """What pyserial opens: the pty path or ``socket://127.0.0.1:PORT``."""
        return self.endpoint.url

    @property
    def busy(self) -> bool:
        """Bytes in flight either way."""
        return bool(self.inbound.pending or self.outbound.pending or self._wbuf)

    def service(self, now_s: float) -> None:
        """Accept clients, move bytes both ways, feed the protocol (wall time ``now_s``)."""
        ep = self.endpoint
        opened, closed = ep.check_client()
        if closed:
            self._link_lost()
        if opened:
            self._on_connect(now_s)
        for _ in range(64):
            data = ep.read()
            if not data:
                break
            self._received(data, now_s)
            if not ep.connected:
                break
        arrived = self.inbound.pop(now_s)
        if arrived:
            self._send(self.protocol.feed(arrived, now_s), now_s)
        self.flush(now_s)

    def send_output(self, data: bytes, now_s: float) -> None:
        """Queue protocol output produced outside :meth:`service` (after time moved)."""
        self._send(data, now_s)
        self.flush(now_s)

    def flush(self, now_s: float) -> None:
        """Write what has arrived at the host end of the outbound pipe."""
        ready = self.outbound.pop(now_s)
        ep = self.endpoint
        if ready:
            if ep.connected:
                self._wbuf += ready
            # bytes for no client are lost, as on an unplugged cable
        while self._wbuf and ep.connected:
            n = ep.write(bytes(self._wbuf))
            if n <= 0:
                break
            self.bytes_out += n
            del self._wbuf[:n]
        if not ep.connected:
            self._wbuf.clear()

    def next_due_s(self) -> float | None:
        """Wall time of the next byte due either way (None when nothing is in flight)."""
        times = [
            t for t in (self.inbound.next_due_s(), self.outbound.next_due_s()) if t is not None
        ]
        return min(times) if times else None

    def drop(self) -> None:
        """Cut the link now (fault injection or API): the client sees a disconnect."""
        self.drops += 1
        if isinstance(self.endpoint, TcpEndpoint):
            self.endpoint.drop_client()
        else:
            self.endpoint.close()
            self.endpoint = PtyEndpoint()  # a new device path, as after a USB re-plug
        self._link_lost()

    def close(self) -> None:
        """Release the endpoint."""
        self.endpoint.close()

    # ------------------------------------------------------------------ internals
    def _send(self, data: bytes, now_s: float) -> None:
        if data:
            self.outbound.push(data, now_s, not_before_s=self._boot_at)

    def _received(self, data: bytes, now_s: float) -> None:
        self.last_input_s = now_s
        if data.translate(None, _REALTIME_BYTES):  # not only '?', '!', '~', 0x18, 0x80-0xFF
            self.last_line_input_s = now_s
        cut = self.faults.drop_cut(data, self.bytes_in, self.line_ends_in)
        if cut is not None:
            data = data[:cut]
        self.bytes_in += len(data)
        self.line_ends_in += data.count(b"\n") + data.count(b"\r")
        self.inbound.push(data, now_s, not_before_s=self._boot_at)
        if cut is not None:
            self.drop()

    def _on_connect(self, now_s: float) -> None:
        self.connects += 1
        self._boot_at = now_s + self.boot_delay_s
        self.outbound.clear()
        self._wbuf.clear()
        if self.reset_on_connect:
            self.inbound.clear()  # bytes of the dropped connection die with the DTR reset
            self._send(self.protocol.restart(), now_s)
        else:
            self._send(self.protocol.banner(), now_s)

    def _link_lost(self) -> None:
        self.outbound.clear()
        self._wbuf.clear()
