"""The running simulator: a background event loop serving the controller on real links.

:func:`run_simulator` (a context manager) and :class:`Simulator` put one
:class:`~simulator.controller.Controller` behind a GRBL serial link (pseudo-terminal or
TCP on 127.0.0.1) and/or a Modbus server (TCP or RTU on a pseudo-terminal), run by an
asyncio loop in a daemon thread. Virtual time follows the speed: ``instant`` jumps
whenever the machine would make someone wait (planner full, a synchronizing line, a
hold) and runs the queue out once no line bytes (status polls do not count) have come
for ``drain_after_s``;
``realtime`` and ``xN`` move it with the wall clock.

Every access to the controller from another thread must hold :attr:`Simulator.lock`;
the helpers (:meth:`Simulator.journal`, :meth:`Simulator.snapshot`,
:meth:`Simulator.wait_for`, ...) do. Every wait is bounded.
"""

from __future__ import annotations

import asyncio
import math
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TypeVar

from machines import Machine, load_machine
from simulator.clock import Speed
from simulator.controller import Controller
from simulator.faults import FaultPlan
from simulator.grbl_protocol import GrblProtocol
from simulator.journal import JournalEntry
from simulator.modbus_device import ModbusDevice
from simulator.serial_session import SerialSession

__all__ = ["Endpoints", "Simulator", "run_simulator"]

T = TypeVar("T")
_ACTIVE_TICK_S = 0.001
_IDLE_TICK_S = 0.005
_START_TIMEOUT_S = 10.0


@dataclass(frozen=True, slots=True)
class Endpoints:
    """Where the simulator can be reached (None for what is not served).

    Attributes
    ----------
    serial_url : str or None
        What ``serial.serial_for_url`` opens: the pty path or ``socket://127.0.0.1:PORT``.
    pty_path : str or None
        The GRBL pseudo-terminal (changes after a link drop).
    tcp_port : int or None
        The GRBL TCP port.
    modbus_port : int or None
        The Modbus TCP port.
    modbus_rtu_path : str or None
        The Modbus RTU pseudo-terminal.
    """

    serial_url: str | None = None
    pty_path: str | None = None
    tcp_port: int | None = None
    modbus_port: int | None = None
    modbus_rtu_path: str | None = None

    def lines(self) -> list[str]:
        """One ``name: value`` line per endpoint served (what the CLI prints)."""
        out = []
        if self.pty_path:
            out.append(f"grbl pty: {self.pty_path}")
        if self.tcp_port is not None:
            out.append(f"grbl tcp: {self.serial_url}")
        if self.modbus_port is not None:
            out.append(f"modbus tcp: 127.0.0.1:{self.modbus_port}")
        if self.modbus_rtu_path:
            out.append(f"modbus rtu: {self.modbus_rtu_path}")
        return out


def _parse_serial(serial: str | None, serial_port: int) -> tuple[str | None, int]:
    if serial is None:
        return None, 0
    s = str(serial).strip().lower()
    if s == "pty":
        return "pty", 0
    if s == "tcp":
        return "tcp", int(serial_port)
    if s.startswith("tcp:"):
        try:
            return "tcp", int(s[4:])
        except ValueError:
            pass
    raise ValueError(f"serial must be 'pty', 'tcp' or 'tcp:PORT' (PORT 0 = any), got {serial!r}")


def _parse_modbus(modbus: str | None, modbus_port: int) -> tuple[str | None, int]:
    if modbus is None:
        return None, 0
    s = str(modbus).strip().lower()
    if s in ("rtu", "rtu:pty"):
        return "rtu", 0
    if s == "tcp":
        return "tcp", int(modbus_port)
    if s.startswith("tcp:"):
        try:
            return "tcp", int(s[4:])
        except ValueError:
            pass
    raise ValueError(
        f"modbus must be 'tcp', 'tcp:PORT' (PORT 0 = any) or 'rtu' (pty), got {modbus!r}"
    )


class Simulator:
    """A controller served on real links by a background loop (see :func:`run_simulator`).

    Attributes
    ----------
    controller : Controller
        The core (hold :attr:`lock` to touch it from another thread).
    protocol : GrblProtocol
        The GRBL front end (also used with no serial link, e.g. from the API).
    modbus : ModbusDevice or None
        The Modbus front end.
    faults : FaultPlan
        Faults and which have fired.
    lock : threading.RLock
        Held by the loop while it works.
    """

    def __init__(
        self,
        machine: str | Machine = "grbl-router",
        *,
        serial: str | None = "tcp",
        serial_port: int = 0,
        modbus: str | None = None,
        modbus_port: int = 0,
        speed: str | Speed = "instant",
        baud: int = 115200,
        latency_s: float = 0.0,
        mode: str | None = None,
        faults: Sequence[str] | FaultPlan | None = None,
        reset_on_connect: bool = True,
        boot_delay_s: float = 0.05,
        drain_after_s: float = 0.05,
        planner_blocks: int = 15,
        work_offsets: Mapping[int, Sequence[float]] | None = None,
    ) -> None:
        self.machine = load_machine(machine) if isinstance(machine, str) else machine
        self.speed = Speed.parse(speed)
        self._serial_kind, self._serial_port = _parse_serial(serial, serial_port)
        self._modbus_kind, self._modbus_port = _parse_modbus(modbus, modbus_port)
        if self._serial_kind is None and self._modbus_kind is None:
            raise ValueError("nothing to serve: give serial='pty'|'tcp' and/or modbus='tcp'|'rtu'")
        self.faults = faults if isinstance(faults, FaultPlan) else FaultPlan.parse(faults)
        self.controller = Controller(
            self.machine, mode=mode, planner_blocks=planner_blocks, work_offsets=work_offsets
        )
        instant = self.speed.instant
        self.protocol = GrblProtocol(self.controller, instant=instant, faults=self.faults)
        self.modbus = (
            ModbusDevice(self.controller, instant=instant, faults=self.faults)
            if self._modbus_kind
            else None
        )
        self._baud = baud
        self._latency_s = latency_s
        self._reset_on_connect = reset_on_connect
        self._boot_delay_s = boot_delay_s
        self.drain_after_s = drain_after_s
        self.lock = threading.RLock()
        self.session: SerialSession | None = None
        self._modbus_endpoint = None
        self._thread: threading.Thread | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._ready = threading.Event()
        self._stopping = False
        self._error: BaseException | None = None
        self._wall0 = 0.0
        self._virtual0 = 0.0
        self._last_activity = -math.inf
        self._last_line_activity = -math.inf

    # ------------------------------------------------------------------ life cycle
    def start(self, timeout_s: float = _START_TIMEOUT_S) -> Simulator:
        """Start the loop thread and bind the endpoints.

        Raises
        ------
        RuntimeError
            If the endpoints are not up within ``timeout_s`` (or failed to bind).
        """
        self._thread = threading.Thread(target=self._thread_main, name="simulator", daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout_s):
            self.stop()
            raise RuntimeError(f"simulator did not start within {timeout_s} s")
        if self._error is not None:
            self.stop()
            raise RuntimeError(f"simulator failed to start: {self._error}") from self._error
        return self

    def stop(self, timeout_s: float = 5.0) -> None:
        """Stop serving and join the thread (bounded)."""
        self._stopping = True
        if self._thread is not None:
            self._thread.join(timeout_s)
            self._thread = None

    def __enter__(self) -> Simulator:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ------------------------------------------------------------------ API
    @property
    def endpoints(self) -> Endpoints:
        """Current endpoints (a pty path changes after a link drop)."""
        s = self.session
        mb = self._modbus_endpoint
        return Endpoints(
            serial_url=s.url if s is not None else None,
            pty_path=s.url if s is not None and s.kind == "pty" else None,
            tcp_port=s.endpoint.port if s is not None and s.kind == "tcp" else None,  # type: ignore[union-attr]
            modbus_port=mb.port if mb is not None else None,
            modbus_rtu_path=mb.path if mb is not None else None,
        )

    @property
    def serial_url(self) -> str:
        """The GRBL link for ``serial.serial_for_url``.

        Raises
        ------
        RuntimeError
            When no serial link is served.
        """
        url = self.endpoints.serial_url
        if url is None:
            raise RuntimeError("this simulator serves no serial link (serial=None)")
        return url

    def call(self, fn: Callable[[], T]) -> T:
        """Run ``fn()`` with the lock held and return its result."""
        with self.lock:
            return fn()

    def journal(self) -> list[JournalEntry]:
        """A copy of the journal entries."""
        return self.call(self.controller.journal.entries)

    def snapshot(self) -> dict[str, object]:
        """State, position, buffers, time and counters at one instant."""
        with self.lock:
            c = self.controller
            p = self.protocol
            s = self.session
            state = c.state.value
            if c.hold:
                state = "Hold:0" if c.hold_complete else "Hold:1"
            return {
                "state": state,
                "alarm": int(c.alarm) if c.alarm is not None else None,
                "position": c.position(),
                "feed_mm_per_min": c.feed_mm_per_min(),
                "virtual_time_s": c.now_s,
                "planner_free": c.planner_free,
                "rx_free": p.rx_free,
                "journal": len(c.journal),
                "lines_received": p.lines_received,
                "rx_dropped_bytes": p.rx_dropped_bytes,
                "ok": p.counters["ok"],
                "error": p.counters["error"],
                "alarms": p.counters["alarm"],
                "status_queries": p.status_queries,
                "status_reports": p.counters["status"],
                "status_ignored": p.counters["status_ignored"],
                "status_merged": p.counters["status_merged"],
                "resets": c.resets,
                "restarts": c.restarts,
                "bytes_in": s.bytes_in if s else 0,
                "bytes_out": s.bytes_out if s else 0,
                "connects": s.connects if s else 0,
                "drops": s.drops if s else 0,
                "faults_fired": list(self.faults.fired),
            }

    def counters(self) -> dict[str, object]:
        """Alias of :meth:`snapshot` (counters and state together)."""
        return self.snapshot()

    def wait_for(self, predicate: Callable[[Simulator], bool], timeout_s: float = 5.0) -> bool:
        """Poll ``predicate(self)`` (lock held) until true or ``timeout_s``; return it."""
        deadline = time.monotonic() + timeout_s
        while True:
            with self.lock:
                if predicate(self):
                    return True
            if time.monotonic() >= deadline:
                return False
            time.sleep(0.002)

    def wait_idle(self, timeout_s: float = 5.0) -> bool:
        """Wait until nothing is queued, waiting or in flight on the links."""

        def idle(sim: Simulator) -> bool:
            c = sim.controller
            busy_link = sim.session is not None and sim.session.busy
            return not c.planner and not c.line_pending and not busy_link and not c.critical

        return self.wait_for(idle, timeout_s)

    def drop_link(self) -> None:
        """Cut the serial link now (as a fault would)."""
        with self.lock:
            if self.session is not None:
                self.session.drop()

    # ------------------------------------------------------------------ loop
    def _thread_main(self) -> None:
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._main())
        except BaseException as exc:  # startup failures are reported by start()
            self._error = exc
            self._ready.set()
        finally:
            loop.close()

    def _virtual_now(self, wall: float) -> float:
        return self._virtual0 + (wall - self._wall0) * self.speed.factor

    async def _main(self) -> None:
        with self.lock:
            if self._serial_kind is not None:
                self.session = SerialSession(
                    self.protocol,
                    self._serial_kind,
                    port=self._serial_port,
                    baud=self._baud,
                    latency_s=self._latency_s,
                    faults=self.faults,
                    reset_on_connect=self._reset_on_connect,
                    boot_delay_s=self._boot_delay_s,
                )
        if self.modbus is not None:
            from simulator.modbus_server import start_modbus_server

            self._modbus_endpoint = await start_modbus_server(
                self.modbus,
                self.lock,
                kind=self._modbus_kind or "tcp",
                port=self._modbus_port,
                baud=self._baud or 115200,
                latency_s=self.faults.latency_s,
            )
        self._wall0 = time.monotonic()
        self._virtual0 = self.controller.now_s
        self._ready.set()
        try:
            while not self._stopping:
                with self.lock:
                    active = self._tick(time.monotonic())
                await asyncio.sleep(_ACTIVE_TICK_S if active else _IDLE_TICK_S)
        finally:
            with self.lock:
                if self.session is not None:
                    self.session.close()
            if self._modbus_endpoint is not None:
                await self._modbus_endpoint.close()

    def _tick(self, wall: float) -> bool:
        c = self.controller
        s = self.session
        if not self.speed.instant:
            c.advance_to(self._virtual_now(wall))
        if s is not None:
            s.service(wall)
            if s.last_input_s > self._last_activity:
                self._last_activity = s.last_input_s
            self._last_line_activity = max(self._last_line_activity, s.last_line_input_s)
        if self.modbus is not None:
            self.modbus.service(wall)
            self._last_activity = max(self._last_activity, self.modbus.last_write_s)
            self._last_line_activity = max(self._last_line_activity, self.modbus.last_write_s)
            if self._modbus_endpoint is not None:
                self._modbus_endpoint.bridge()
        # status polls are no line traffic: a sender polling at 5 Hz must not keep the
        # queue from running out
        if self.speed.instant and wall - self._last_line_activity > self.drain_after_s:
            if (c.planner or c.line_pending) and not c.hold:
                c.run_until_idle()
                if self.modbus is not None:
                    self.modbus.service(wall)
        if s is not None:
            out = self.protocol.poll(wall)
            if out:
                s.send_output(out, wall)
        busy = bool(c.planner or c.line_pending) or (s is not None and s.busy)
        return busy or wall - self._last_activity < 0.25


@contextmanager
def run_simulator(
    machine: str | Machine = "grbl-router",
    *,
    serial: str | None = "tcp",
    modbus: str | None = None,
    speed: str | Speed = "instant",
    faults: Sequence[str] | FaultPlan | None = None,
    **options: object,
) -> Iterator[Simulator]:
    """Run a simulated controller in a background thread for the ``with`` block.

    Parameters
    ----------
    machine : str or Machine
        ``"grbl-router"``, ``"trunnion-ac"``, ``"head-table-bc"`` or a definition.
    serial : str or None
        ``"pty"``, ``"tcp"`` / ``"tcp:PORT"`` (0 = any free port) or None.
    modbus : str or None
        ``"tcp"`` / ``"tcp:PORT"``, ``"rtu"`` (pty) or None.
    speed : str or Speed
        ``"instant"``, ``"realtime"`` or ``"xN"``.
    faults : sequence of str or FaultPlan
        E.g. ``["drop-after-lines=500", "error-at-line=7:20"]``.
    **options
        Keyword options of :class:`Simulator` (``baud``, ``latency_s``, ``mode``,
        ``reset_on_connect``, ``boot_delay_s``, ``drain_after_s``, ``planner_blocks``,
        ``work_offsets``, ``serial_port``, ``modbus_port``).

    Yields
    ------
    Simulator
        Running; stopped (threads joined, ports closed) when the block exits.
    """
    sim = Simulator(machine, serial=serial, modbus=modbus, speed=speed, faults=faults, **options)  # type: ignore[arg-type]
    sim.start()
    try:
        yield sim
    finally:
        sim.stop()
