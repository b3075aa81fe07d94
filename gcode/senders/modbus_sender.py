"""The Modbus sender: streams blocks through the register map with a pymodbus client.

One of the package's two pymodbus importers (with nothing else of pymodbus elsewhere):
:class:`ModbusLink` wraps the synchronous pymodbus client (TCP, or RTU over a serial
port or pseudo-terminal) and :class:`ModbusSender` executes the requests
:class:`~gcode.senders.modbus_stream.ModbusStream` plans.

Time-outs and lost connections are expected, not fatal: the request is forgotten, the
connection is closed and reopened (bounded by ``reconnect_window_s``) and the next status
read says what the controller has; writing continues at ``ACCEPTED_SEQ + 1``. Closing
after every time-out matters: a late answer to a timed-out request would otherwise be
taken for the answer to the next one (pymodbus #538; RTU frames carry no transaction id,
pymodbus PR #2636). Block writes are idempotent (the controller ignores a SEQ it has), so
nothing is lost and nothing runs twice.

Addresses and encodings come from :mod:`gcode.senders.modbus_map` (pure data shared with
the simulator); pymodbus >= 3.13 API: ``device_id=`` keyword, ``read_holding_registers(
address, count=n)``, ``write_registers(address, values)``.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from urllib.parse import parse_qs, urlsplit

from pymodbus.client import ModbusSerialClient, ModbusTcpClient
from pymodbus.exceptions import ConnectionException, ModbusException, ModbusIOException
from pymodbus.framer import FramerType

from gcode.senders import modbus_map as mm
from gcode.senders.errors import (
    AlarmError,
    ControllerResetError,
    HandshakeError,
    JobCancelledError,
    LineRejectedError,
    LinkLostError,
    LinkTimeoutError,
    ProtocolError,
    SenderError,
)
from gcode.senders.grbl_sender import CheckReport, HoldChoice, JobResult
from gcode.senders.job import Job, JobLine
from gcode.senders.journal import JobJournal
from gcode.senders.modbus_stream import (
    BlockRejected,
    BlocksDone,
    ControllerAlarm,
    ControllerRestarted,
    ModbusEvent,
    ModbusStream,
    ReadStatus,
    Request,
    Stalled,
    WriteSlot,
)
from gcode.senders.progress import PROGRESS_INTERVAL_S, Progress
from gcode.senders.resume import ResumePlan

__all__ = ["ModbusInfo", "ModbusLink", "ModbusSender", "parse_modbus_url"]

_STATE_NAMES = {s.value: s.name.title().replace("_", " ") for s in mm.MachineState}


class _Transient(Exception):
    """A time-out or a lost connection: reconnect and read the status again."""


def parse_modbus_url(url: str) -> tuple[str, str, int]:
    """Split ``tcp://HOST:PORT`` or ``rtu:PATH[?baud=N]`` into (kind, where, number).

    Returns
    -------
    (str, str, int)
        ``("tcp", host, port)`` or ``("rtu", device path, baud)``.

    Raises
    ------
    ValueError
        For another form (naming the accepted ones).
    """
    parts = urlsplit(url)
    if parts.scheme == "tcp" and parts.hostname and parts.port:
        return "tcp", parts.hostname, parts.port
    if parts.scheme == "rtu":
        path = (parts.netloc + parts.path) if parts.netloc else parts.path
        baud = int(parse_qs(parts.query).get("baud", ["115200"])[0])
        if path:
            return "rtu", path, baud
    raise ValueError(f"Modbus URL must be tcp://HOST:PORT or rtu:/dev/PATH[?baud=N], got {url!r}")


class ModbusLink:
    """A pymodbus client with bounded, reconnecting requests.

    Parameters
    ----------
    url : str
        ``tcp://127.0.0.1:5020`` or ``rtu:/dev/ttyUSB0?baud=115200``.
    timeout_s : float
        Per-request time-out, s.
    device_id : int
        Modbus unit id.
    """

    def __init__(self, url: str, *, timeout_s: float = 1.0, device_id: int = 1) -> None:
        self.name = url
        self.kind, self._where, self._number = parse_modbus_url(url)
        self.timeout_s = timeout_s
        self.device_id = device_id
        self.reconnects = 0
        self.timeouts = 0
        self._client: ModbusTcpClient | ModbusSerialClient | None = None

    def _make(self) -> ModbusTcpClient | ModbusSerialClient:
        if self.kind == "tcp":
            return ModbusTcpClient(
                self._where, port=self._number, timeout=self.timeout_s, retries=0, reconnect_delay=0
            )
        return ModbusSerialClient(
            self._where,
            framer=FramerType.RTU,
            baudrate=self._number,
            parity="N",
            timeout=self.timeout_s,
            retries=0,
            reconnect_delay=0,
        )

    @property
    def client(self) -> ModbusTcpClient | ModbusSerialClient | None:
        """The pymodbus client (None when closed)."""
        return self._client

    def connect(self) -> None:
        """Open the connection.

        Raises
        ------
        LinkLostError
            When it cannot be opened.
        """
        self.close()
        client = self._make()
        try:
            ok = client.connect()
        except (ModbusException, OSError) as exc:
            raise LinkLostError(f"cannot connect to Modbus {self.name}: {exc}") from exc
        if not ok:
            client.close()
            raise LinkLostError(f"cannot connect to Modbus {self.name}")
        self._client = client

    def close(self) -> None:
        """Close the connection (idempotent)."""
        if self._client is not None:
            try:
                self._client.close()
            except (ModbusException, OSError):
                pass
            self._client = None

    def _call(self, fn: Callable[[], object], what: str) -> object:
        if self._client is None:
            raise _Transient(f"{what}: not connected")
        try:
            rr = fn()
        except ModbusIOException as exc:
            self.timeouts += 1
            raise _Transient(f"{what}: no answer within {self.timeout_s:g} s ({exc})") from exc
        except (ConnectionException, OSError) as exc:
            raise _Transient(f"{what}: connection lost ({exc})") from exc
        except ModbusException as exc:
            raise _Transient(f"{what}: {exc}") from exc
        if rr.isError():  # type: ignore[attr-defined]
            code = getattr(rr, "exception_code", None)
            raise ProtocolError(f"Modbus {self.name}: {what} refused with exception {code}")
        return rr

    def read(self, address: int, count: int) -> list[int]:
        """FC3 read of ``count`` holding registers at ``address``."""
        client = self._client
        rr = self._call(
            lambda: client.read_holding_registers(  # type: ignore[union-attr]
                address, count=count, device_id=self.device_id
            ),
            f"read {address}+{count}",
        )
        return list(rr.registers)  # type: ignore[attr-defined]

    def write(self, address: int, values: Sequence[int]) -> None:
        """FC16 write of ``values`` at ``address``."""
        client = self._client
        self._call(
            lambda: client.write_registers(  # type: ignore[union-attr]
                address, list(values), device_id=self.device_id
            ),
            f"write {address}+{len(values)}",
        )


@dataclass(frozen=True)
class ModbusInfo:
    """What the handshake read.

    Attributes
    ----------
    version : int
        Map version.
    slot_count : int
        Ring slots (credits).
    planner_blocks : int
        Controller planner size.
    accepted_seq : int
        ``ACCEPTED_SEQ`` when connected.
    state : str
        State name.
    """

    version: int
    slot_count: int
    planner_blocks: int
    accepted_seq: int
    state: str


class ModbusSender:
    """Stream G-code blocks to a Modbus controller (register map version 1).

    Parameters
    ----------
    link : ModbusLink
        Not yet connected (:meth:`connect` opens it).
    send_response : bool
        One block at a time.
    heartbeat_interval_s : float
        HOST_HEARTBEAT period, s (0 = none).
    stall_s : float
        Bound on no progress with blocks outstanding, s.
    reconnect_window_s : float
        How long reconnecting may take before the link counts as lost, s.
    hold_s : float
        Bound on a feed hold coming to a stop, s.
    clock, sleep : callable
        Time source and sleep (injectable).
    on_progress : callable or None
        ``on_progress(Progress)``.
    """

    def __init__(
        self,
        link: ModbusLink,
        *,
        send_response: bool = False,
        heartbeat_interval_s: float = 0.25,
        stall_s: float = 60.0,
        reconnect_window_s: float = 10.0,
        hold_s: float = 30.0,
        clock: Callable[[], float] = time.monotonic,
        sleep: Callable[[float], None] = time.sleep,
        on_progress: Callable[[Progress], None] | None = None,
    ) -> None:
        self.link = link
        self.send_response = send_response
        self.heartbeat_interval_s = heartbeat_interval_s
        self.stall_s = stall_s
        self.reconnect_window_s = reconnect_window_s
        self.hold_s = hold_s
        self.clock = clock
        self.sleep = sleep
        self.on_progress = on_progress
        self.info: ModbusInfo | None = None
        self.status: dict[str, float] = {}
        self._hold_request = threading.Event()
        self._cmd_seq = 0
        self._journal: JobJournal | None = None
        self._done = 0
        self._total = 0
        self._last_line = 0
        self._t0 = 0.0
        self._last_progress = -1.0
        self._on_hold: Callable[[Progress], HoldChoice | str] | None = None
        self.retries = 0

    # ------------------------------------------------------------------ basics
    def request_hold(self) -> None:
        """Ask for a feed hold (safe from a signal handler or another thread)."""
        self._hold_request.set()

    def _reconnect(self, why: str) -> None:
        deadline = self.clock() + self.reconnect_window_s
        delay = 0.02
        while True:
            self.link.close()
            self.sleep(delay)
            try:
                self.link.connect()
                self.link.reconnects += 1
                return
            except LinkLostError as exc:
                if self.clock() + delay > deadline:
                    raise LinkLostError(
                        f"{why}; reconnecting to {self.link.name} failed for "
                        f"{self.reconnect_window_s:g} s: {exc.message}",
                        line=self._last_line or None,
                    ) from None
            delay = min(delay * 2.0, 0.5)

    def _read_status(self) -> dict[str, float]:
        base, count = mm.STATUS_BLOCK
        deadline = self.clock() + self.reconnect_window_s
        while True:
            try:
                self.status = mm.decode_status(self.link.read(base, count), base)
                return self.status
            except _Transient as exc:
                self.retries += 1
                if self.clock() > deadline:
                    raise LinkLostError(f"status read: {exc}") from None
                self._reconnect(str(exc))

    def _write(self, address: int, values: Sequence[int]) -> None:
        deadline = self.clock() + self.reconnect_window_s
        while True:
            try:
                self.link.write(address, values)
                return
            except _Transient as exc:
                self.retries += 1
                if self.clock() > deadline:
                    raise LinkLostError(f"write: {exc}") from None
                self._reconnect(str(exc))

    def _command(self, command: mm.Command, *, limit_s: float = 5.0) -> int:
        """Write ``[CMD, CMD_SEQ]`` (idempotent retries), wait for CMD_ACK; return CMD_RESULT."""
        self._cmd_seq = (self._cmd_seq + 1) & 0xFFFF or 1
        self._write(mm.BY_NAME["CMD"].address, [int(command), self._cmd_seq])
        deadline = self.clock() + limit_s
        while True:
            st = self._read_status()
            if int(st["CMD_ACK"]) == self._cmd_seq:
                return int(st.get("CMD_RESULT", 0))
            if self.clock() > deadline:
                raise LinkTimeoutError(f"command {command.name} not acknowledged in {limit_s:g} s")
            self.sleep(0.005)

    def _wait_state(
        self, ok: Callable[[dict[str, float]], bool], limit_s: float, what: str
    ) -> dict[str, float]:
        deadline = self.clock() + limit_s
        while True:
            st = self._read_status()
            if ok(st):
                return st
            if self.clock() > deadline:
                raise LinkTimeoutError(
                    f"{what}: not done after {limit_s:g} s (state "
                    f"{_STATE_NAMES.get(int(st['STATE']), st['STATE'])})"
                )
            self.sleep(0.005)

    # ------------------------------------------------------------------ handshake
    def connect(self, *, unlock: bool = False) -> ModbusInfo:
        """Connect, check the map constants and the state.

        Parameters
        ----------
        unlock : bool
            Clear an Alarm (otherwise refuse).

        Raises
        ------
        HandshakeError
            A different register map, a busy controller, or an Alarm without ``unlock``.
        """
        self.link.connect()
        head = self.link_read(0, 8)
        version, slots, chars, stride, base = head[:5]
        if (version, slots, chars, stride, base) != (
            mm.MAP_VERSION,
            mm.SLOT_COUNT,
            mm.SLOT_CHARS,
            mm.SLOT_STRIDE,
            mm.SLOT_BASE,
        ):
            raise HandshakeError(
                f"{self.link.name}: register map {version} with {slots} slots of {chars} "
                f"characters at {base} (stride {stride}); this sender speaks map "
                f"{mm.MAP_VERSION} ({mm.SLOT_COUNT} x {mm.SLOT_CHARS} at {mm.SLOT_BASE})"
            )
        st = self._read_status()
        self._cmd_seq = int(st["CMD_ACK"])
        state = int(st["STATE"])
        if state == mm.MachineState.ALARM:
            if not unlock:
                raise HandshakeError(
                    f"{self.link.name}: the controller is in ALARM:"
                    f"{int(st['ALARM_CODE'])}: clear it (--unlock) first"
                )
            self._command(mm.Command.CLEAR)
        elif state == mm.MachineState.ERROR:
            self._command(mm.Command.CLEAR)  # a rejected block of an earlier job
        elif state == mm.MachineState.CHECK:
            self._command(mm.Command.CHECK_OFF)
        st = self._read_status()
        state = int(st["STATE"])
        if state not in (mm.MachineState.IDLE,) or st["DONE_SEQ"] != st["ACCEPTED_SEQ"]:
            raise HandshakeError(
                f"{self.link.name}: the controller is busy ({_STATE_NAMES.get(state)}, blocks "
                f"{int(st['DONE_SEQ']) + 1}-{int(st['ACCEPTED_SEQ'])} not run): wait or abort"
            )
        self.info = ModbusInfo(
            version, slots, head[6], int(st["ACCEPTED_SEQ"]), _STATE_NAMES.get(state, str(state))
        )
        return self.info

    def link_read(self, address: int, count: int) -> list[int]:
        """Read registers with reconnecting retries."""
        deadline = self.clock() + self.reconnect_window_s
        while True:
            try:
                return self.link.read(address, count)
            except _Transient as exc:
                if self.clock() > deadline:
                    raise LinkLostError(f"read: {exc}") from None
                self._reconnect(str(exc))

    # ------------------------------------------------------------------ streaming
    def progress(self) -> Progress:
        """The current job's progress."""
        state = _STATE_NAMES.get(int(self.status.get("STATE", 0)), "") if self.status else ""
        return Progress(
            self._done, self._total, max(self.clock() - self._t0, 0.0), self._last_line, state
        )

    def _progress(self, force: bool = False) -> None:
        now = self.clock()
        if self.on_progress is not None and (
            force or now - self._last_progress >= PROGRESS_INTERVAL_S
        ):
            self._last_progress = now
            self.on_progress(self.progress())

    def _stream(
        self,
        stream: ModbusStream,
        until: Callable[[], bool],
        on_event: Callable[[ModbusEvent], None],
    ) -> None:
        while not until():
            if self._hold_request.is_set() and self._on_hold is not None:
                self._hold_request.clear()
                self._interactive_hold(stream)
            now = self.clock()
            req: Request = stream.next_request(now)
            wait = stream.wait_until(req) - now
            if wait > 0.0:
                self.sleep(min(wait, 0.05))
                continue
            try:
                if isinstance(req, ReadStatus):
                    base, count = mm.STATUS_BLOCK
                    self.status = mm.decode_status(self.link.read(base, count), base)
                    for ev in stream.on_status(self.status, self.clock()):
                        on_event(ev)
                else:
                    self.link.write(req.address, req.registers)
                    stream.written(req, self.clock())
                    if isinstance(req, WriteSlot) and self._journal is not None:
                        self._journal.sent(req.line)
            except _Transient as exc:
                self.retries += 1
                stream.failed(req, self.clock())
                self._reconnect(str(exc))

    def _on_job_event(self, stream: ModbusStream, ev: ModbusEvent) -> None:
        if isinstance(ev, BlocksDone):
            for line in ev.lines:
                if self._journal is not None:
                    self._journal.acked(line)
                if line.number > 0:
                    self._done += 1
                    self._last_line = line.number
            self._progress()
            return
        if isinstance(ev, BlockRejected):
            if self._journal is not None and ev.line is not None:
                self._journal.rejected(ev.line, ev.code)
            # the blocks before it still run; nothing after it will
            target = ev.seq - 1
            self._wait_state(
                lambda st: int(st["DONE_SEQ"]) >= target,
                self.stall_s,
                "waiting for the blocks before the rejected one",
            )
            line = ev.line
            raise LineRejectedError(
                ev.code,
                line=line.number if line and line.number else None,
                text=line.text if line else None,
                resume_line=line.number if line and line.number else None,
                note="the blocks before it ran; nothing after it was executed",
            )
        if isinstance(ev, ControllerAlarm):
            nxt = stream.line_of(ev.done_seq + 1)
            raise AlarmError(
                ev.code,
                line=nxt.number if nxt else None,
                text=nxt.text if nxt else None,
                resume_line=nxt.number if nxt and nxt.number else None,
                note=f"every block up to SEQ {ev.done_seq} ran; clear the alarm "
                f"(--unlock) before resuming",
            )
        if isinstance(ev, ControllerRestarted):
            st = self.status
            nxt = stream.line_of(int(st.get("DONE_SEQ", 0)) + 1) if st else None
            raise ControllerResetError(
                f"the controller restarted during the job (RESET_COUNT {ev.reset_count}); "
                f"the blocks it had not run are lost; the job stopped; last line run: "
                f"{self._last_line or 'none'}",
                line=self._last_line or None,
                resume_line=nxt.number if nxt and nxt.number else None,
            )
        if isinstance(ev, Stalled):
            raise LinkTimeoutError(
                f"no progress for {ev.seconds:g} s with blocks outstanding; "
                f"last line run: {self._last_line or 'none'}",
                line=self._last_line or None,
            )

    def run(
        self,
        job: Job,
        *,
        resume: ResumePlan | None = None,
        journal: JobJournal | None = None,
        on_hold: Callable[[Progress], HoldChoice | str] | None = None,
    ) -> JobResult:
        """Stream ``job`` (or resume it) until every block ran and the controller is Idle.

        Raises
        ------
        SenderError
            :class:`LineRejectedError`, :class:`AlarmError`, :class:`ControllerResetError`,
            :class:`LinkLostError`, :class:`LinkTimeoutError`, :class:`JobCancelledError`,
            with the exact line to resume from (``DONE_SEQ`` says what ran).
        """
        if self.info is None:
            raise HandshakeError("connect() first")
        lines: tuple[JobLine, ...] = tuple(job.lines)
        start = job.lines[0].number if job.lines else 0
        if resume is not None:
            lines = resume.preamble + tuple(job.from_line(resume.line))
            start = resume.line
        st = self._read_status()
        stream = ModbusStream(
            lines,
            base_seq=int(st["ACCEPTED_SEQ"]),
            reset_count=int(st["RESET_COUNT"]),
            send_response=self.send_response,
            heartbeat_interval_s=self.heartbeat_interval_s,
            stall_s=self.stall_s,
        )
        self._journal = journal
        self._on_hold = on_hold if on_hold is not None else (lambda p: HoldChoice.CANCEL)
        self._done = 0
        self._total = sum(1 for ln in lines if ln.number > 0)
        self._last_line = 0
        self._t0 = self.clock()
        self._stream_ref = stream
        try:
            try:
                self._stream(
                    stream, lambda: stream.finished, lambda ev: self._on_job_event(stream, ev)
                )
            except KeyboardInterrupt:
                self._cancel(stream, "interrupted (Ctrl-C)")
        except SenderError as err:
            if journal is not None:
                journal.end(err.outcome, resume_line=err.resume_line, message=str(err))
            raise
        finally:
            self._on_hold = None
        self._progress(force=True)
        if journal is not None:
            journal.end("done", resume_line=None)
        nbytes = sum(ln.size for ln in lines)
        elapsed = self.clock() - self._t0
        return JobResult(len(lines), self._done, elapsed, nbytes, None, start, elapsed)

    def _interactive_hold(self, stream: ModbusStream) -> None:
        self._command(mm.Command.HOLD)
        self._wait_state(
            lambda st: (
                int(st["STATE"])
                in (mm.MachineState.HOLD, mm.MachineState.IDLE, mm.MachineState.ALARM)
            ),
            self.hold_s,
            "feed hold",
        )
        assert self._on_hold is not None
        choice = HoldChoice(self._on_hold(self.progress()))
        if choice is HoldChoice.RESUME:
            self._command(mm.Command.RESUME)
            return
        self._cancel(stream, "cancelled after a feed hold")

    def _cancel(self, stream: ModbusStream, why: str) -> None:
        stream.stop_sending()
        self._command(mm.Command.ABORT)
        st = self._wait_state(
            lambda s: (
                int(s["STATE"]) == mm.MachineState.IDLE and s["ACCEPTED_SEQ"] == s["DONE_SEQ"]
            ),
            self.hold_s,
            "abort",
        )
        nxt = stream.line_of(int(st["DONE_SEQ"]) + 1)
        resume_line = nxt.number if nxt and nxt.number else None
        raise JobCancelledError(
            f"job {why}; every block up to line {self._last_line or 'none'} ran"
            + (f"; resume with --resume-from {resume_line}" if resume_line else ""),
            line=self._last_line or None,
            resume_line=resume_line,
        )

    # ------------------------------------------------------------------ check mode
    def check(self, job: Job) -> CheckReport:
        """Check mode dry run: every block parsed by the controller, errors collected."""
        if self._command(mm.Command.CHECK_ON) != mm.CommandResult.OK:
            raise HandshakeError(f"{self.link.name}: the controller refused check mode")
        st = self._read_status()
        stream = ModbusStream(
            job.lines,
            base_seq=int(st["ACCEPTED_SEQ"]),
            reset_count=int(st["RESET_COUNT"]),
            heartbeat_interval_s=0.0,
            stall_s=self.stall_s,
        )
        errors: list[LineRejectedError] = []
        self._on_hold = None

        def on_event(ev: ModbusEvent) -> None:
            if isinstance(ev, BlockRejected):
                line = ev.line
                errors.append(
                    LineRejectedError(
                        ev.code,
                        line=line.number if line else None,
                        text=line.text if line else None,
                    )
                )
                self._command(mm.Command.CLEAR)
                stream.reported_error = False
                stream.sending = True
                stream.status = None  # read again before writing
            elif isinstance(ev, ControllerAlarm):
                raise AlarmError(ev.code, line=None, text=None, note="raised in check mode")
            elif isinstance(ev, ControllerRestarted | Stalled):
                self._on_job_event(stream, ev)

        def checked() -> bool:
            s = stream.status
            return (
                s is not None
                and int(s.get("QUEUED_SEQ", 0)) >= stream.last_seq
                and int(s["STATE"]) in (mm.MachineState.CHECK, mm.MachineState.IDLE)
            )

        try:
            self._stream(stream, checked, on_event)
        finally:
            self._command(mm.Command.CHECK_OFF)
        return CheckReport(len(job.lines), tuple(errors))

    def close(self) -> None:
        """Close the link."""
        self.link.close()
