r"""The Modbus block handshake as a sans-IO planner: status in, next request out.

:class:`ModbusStream` decides, from the controller's status registers (decoded with
:func:`gcode.senders.modbus_map.decode_status`), which request the host sends next; the
driver (:mod:`gcode.senders.modbus_sender`) only executes requests with pymodbus. The
rules, from the register map (``docs/modbus.md``):

* Block ``SEQ`` (``base + 1``, ``base + 2``, ... where ``base`` is ``ACCEPTED_SEQ`` when the
  job starts) goes whole in one FC16 write to slot ``SEQ % SLOT_COUNT``.
* Credits: blocks are written while ``SEQ <= ACCEPTED_SEQ + FREE_SLOTS`` of the last status
  read (send-response: one block, then wait for ``ACCEPTED_SEQ == SEQ``).
* Idempotent retries: after a time-out or a lost connection nothing is assumed; the next
  status says what the controller accepted and writing resumes at ``ACCEPTED_SEQ + 1``
  (a block written twice is ignored by the controller, so nothing runs twice). A block
  that is not accepted after a successful write (bad CRC, lost) is rewritten, at most
  ``max_rewrites`` times.
* Progress is exact: ``DONE_SEQ`` says which blocks ran; ``ERROR_SEQ``/``ERROR_CODE`` which
  was rejected (nothing after it runs); ``ALARM_CODE`` an alarm; a changed ``RESET_COUNT`` a
  controller restart.
* ``HOST_HEARTBEAT`` is written every ``heartbeat_interval_s`` so the controller's
  watchdog feed-holds when the host goes away.

Examples
--------
>>> from gcode.senders.job import Job
>>> s = ModbusStream(Job.from_text("G1X1F100\nG1X2\n").lines, base_seq=0, reset_count=0,
...                  heartbeat_interval_s=0.0)
>>> s.next_request(0.0)
ReadStatus()
>>> _ = s.on_status({"STATE": 0, "ACCEPTED_SEQ": 0, "DONE_SEQ": 0, "FREE_SLOTS": 8,
...                  "RESET_COUNT": 0, "ERROR_SEQ": 0, "ERROR_CODE": 0, "ALARM_CODE": 0,
...                  "CMD_ACK": 0}, 0.0)
>>> r = s.next_request(0.0); (type(r).__name__, r.seq, r.address)
('WriteSlot', 1, 148)
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from gcode.senders import modbus_map as mm
from gcode.senders.errors import ProtocolError
from gcode.senders.job import JobLine

__all__ = [
    "BlockRejected",
    "BlocksDone",
    "ControllerAlarm",
    "ControllerRestarted",
    "ModbusEvent",
    "ModbusStream",
    "ReadStatus",
    "Request",
    "Stalled",
    "WriteCommand",
    "WriteHeartbeat",
    "WriteSlot",
]


# ---------------------------------------------------------------------------- requests
@dataclass(frozen=True, slots=True)
class ReadStatus:
    """FC3 read of the status block (:data:`~gcode.senders.modbus_map.STATUS_BLOCK`)."""


@dataclass(frozen=True, slots=True)
class WriteSlot:
    """FC16 write of one whole slot."""

    seq: int
    line: JobLine
    address: int
    registers: tuple[int, ...]


@dataclass(frozen=True, slots=True)
class WriteCommand:
    """FC16 write of ``[CMD, CMD_SEQ]``."""

    command: mm.Command
    cmd_seq: int

    @property
    def address(self) -> int:
        """Address of CMD."""
        return mm.BY_NAME["CMD"].address

    @property
    def registers(self) -> tuple[int, int]:
        """``(CMD, CMD_SEQ)``."""
        return int(self.command), self.cmd_seq


@dataclass(frozen=True, slots=True)
class WriteHeartbeat:
    """Write of HOST_HEARTBEAT."""

    value: int

    @property
    def address(self) -> int:
        """Address of HOST_HEARTBEAT."""
        return mm.BY_NAME["HOST_HEARTBEAT"].address

    @property
    def registers(self) -> tuple[int]:
        """``(value,)``."""
        return (self.value,)


Request = ReadStatus | WriteSlot | WriteCommand | WriteHeartbeat


# ---------------------------------------------------------------------------- events
@dataclass(frozen=True, slots=True)
class BlocksDone:
    """Blocks executed since the last status (``DONE_SEQ`` moved)."""

    lines: tuple[JobLine, ...]


@dataclass(frozen=True, slots=True)
class BlockRejected:
    """The controller rejected a block (``ERROR_SEQ``/``ERROR_CODE``)."""

    seq: int
    line: JobLine | None
    code: int


@dataclass(frozen=True, slots=True)
class ControllerAlarm:
    """STATE is ALARM."""

    code: int
    done_seq: int


@dataclass(frozen=True, slots=True)
class ControllerRestarted:
    """RESET_COUNT changed without the host asking."""

    reset_count: int


@dataclass(frozen=True, slots=True)
class Stalled:
    """Blocks outstanding and nothing moved for ``stall_s``."""

    seconds: float


ModbusEvent = BlocksDone | BlockRejected | ControllerAlarm | ControllerRestarted | Stalled

_STATUS_KEYS = ("STATE", "ACCEPTED_SEQ", "DONE_SEQ", "FREE_SLOTS", "RESET_COUNT")


class ModbusStream:
    """Sans-IO planner of one Modbus job.

    Parameters
    ----------
    lines : iterable of JobLine
        The blocks, in order.
    base_seq : int
        ``ACCEPTED_SEQ`` before the job (the first block is ``base_seq + 1``).
    reset_count : int
        ``RESET_COUNT`` before the job.
    send_response : bool
        One block at a time (wait for ``ACCEPTED_SEQ == SEQ``).
    heartbeat_interval_s : float
        HOST_HEARTBEAT period, s (0 = none).
    poll_interval_s : float
        Wait between status reads that show no change, s.
    stall_s : float
        Bound on no progress with blocks outstanding, s.
    max_rewrites : int
        Rewrites of one block (not accepted after a good write) before giving up.
    """

    def __init__(
        self,
        lines: Iterable[JobLine],
        *,
        base_seq: int,
        reset_count: int,
        send_response: bool = False,
        heartbeat_interval_s: float = 0.25,
        poll_interval_s: float = 0.005,
        stall_s: float = 60.0,
        max_rewrites: int = 5,
    ) -> None:
        self.lines = tuple(lines)
        self.base_seq = base_seq
        self.last_seq = base_seq + len(self.lines)
        self.reset_count = reset_count
        self.send_response = send_response
        self.heartbeat_interval_s = heartbeat_interval_s
        self.poll_interval_s = poll_interval_s
        self.stall_s = stall_s
        self.max_rewrites = max_rewrites
        self.status: dict[str, float] | None = None
        self.next_seq = base_seq + 1
        self.done_seq = base_seq
        self.accepted_seq = base_seq
        self.sending = True
        self.rewrites = 0
        self._writes: dict[int, int] = {}
        self._credit_max = base_seq
        self._need_status = True
        self._next_poll_at = -math.inf
        self._next_heartbeat_at = -math.inf
        self._heartbeat = 0
        self._commands: list[WriteCommand] = []
        self._progress_at: float | None = None
        self.cmd_seq = 0
        self.reported_error = False

    # ------------------------------------------------------------------ queries
    def line_of(self, seq: int) -> JobLine | None:
        """The job line of block ``seq`` (None outside this job)."""
        i = seq - self.base_seq - 1
        return self.lines[i] if 0 <= i < len(self.lines) else None

    @property
    def finished(self) -> bool:
        """Every block executed and the controller Idle."""
        s = self.status
        return (
            s is not None
            and self.done_seq >= self.last_seq
            and int(s["STATE"]) == mm.MachineState.IDLE
        )

    @property
    def outstanding(self) -> bool:
        """Blocks written or to write that have not run yet."""
        return self.done_seq < self.last_seq

    # ------------------------------------------------------------------ commands
    def command(self, command: mm.Command) -> WriteCommand:
        """Queue a command (sent before any slot); returns the request."""
        self.cmd_seq = (self.cmd_seq + 1) & 0xFFFF or 1
        req = WriteCommand(command, self.cmd_seq)
        self._commands.append(req)
        return req

    def stop_sending(self) -> None:
        """Write no further block."""
        self.sending = False

    # ------------------------------------------------------------------ planning
    def next_request(self, now_s: float) -> Request:
        """The request to send now (the caller may wait until :meth:`wait_until`)."""
        if self._commands:
            return self._commands[0]
        if self.heartbeat_interval_s > 0.0 and now_s >= self._next_heartbeat_at:
            return WriteHeartbeat((self._heartbeat + 1) & 0xFFFF)
        if self._need_status or self.status is None:
            return ReadStatus()
        if self.sending and self.next_seq <= min(self.last_seq, self._credit_max):
            if not self.send_response or self.accepted_seq >= self.next_seq - 1:
                seq = self.next_seq
                line = self.lines[seq - self.base_seq - 1]
                return WriteSlot(
                    seq, line, mm.slot_address(seq), tuple(mm.encode_slot(seq, line.text))
                )
        return ReadStatus()

    def wait_until(self, request: Request) -> float:
        """Earliest time to send ``request`` (status reads that would show nothing new wait)."""
        if isinstance(request, ReadStatus) and not self._need_status:
            return self._next_poll_at
        return -math.inf

    def written(self, request: Request, now_s: float) -> None:
        """The server confirmed ``request``."""
        if isinstance(request, WriteSlot):
            self._writes[request.seq] = self._writes.get(request.seq, 0) + 1
            self.next_seq = request.seq + 1
            if self.send_response or self.next_seq > self._credit_max:
                self._need_status = True
        elif isinstance(request, WriteCommand):
            if self._commands and self._commands[0] == request:
                self._commands.pop(0)
            self._need_status = True
        elif isinstance(request, WriteHeartbeat):
            self._heartbeat = request.value
            self._next_heartbeat_at = now_s + self.heartbeat_interval_s

    def failed(self, request: Request, now_s: float) -> None:
        """``request`` timed out or the connection failed: assume nothing, read again."""
        self._need_status = True
        self._next_poll_at = now_s
        if isinstance(request, WriteHeartbeat):
            self._next_heartbeat_at = now_s  # try again at once after reconnecting

    def on_status(self, status: Mapping[str, float], now_s: float) -> list[ModbusEvent]:
        """Take a decoded status read; return what happened.

        Parameters
        ----------
        status : mapping of str to float
            At least STATE, ACCEPTED_SEQ, DONE_SEQ, FREE_SLOTS, RESET_COUNT, ERROR_SEQ,
            ERROR_CODE, ALARM_CODE.
        now_s : float
            Current time, s.

        Returns
        -------
        list of ModbusEvent
            In order.
        """
        for key in _STATUS_KEYS:
            if key not in status:
                raise ValueError(f"status lacks {key}: read the whole STATUS_BLOCK")
        prev = self.status
        self.status = dict(status)
        self._need_status = False
        events: list[ModbusEvent] = []
        if int(status["RESET_COUNT"]) != self.reset_count:
            self.reset_count = int(status["RESET_COUNT"])
            self.sending = False
            events.append(ControllerRestarted(self.reset_count))
        accepted = int(status["ACCEPTED_SEQ"])
        done = int(status["DONE_SEQ"])
        state = int(status["STATE"])
        if state in (mm.MachineState.ERROR, mm.MachineState.ALARM):
            self.sending = False
        self._credit_max = accepted + int(status["FREE_SLOTS"])
        if accepted < self.next_seq - 1:
            # written but not accepted (lost write, bad CRC, a discard): write again from
            # the first block the controller lacks; it ignores what it already has.
            seq = accepted + 1
            if self.sending and self.base_seq < seq <= self.last_seq:
                self._writes_check(seq)
                self.rewrites += 1
            self.next_seq = max(accepted + 1, self.base_seq + 1)
        elif accepted >= self.next_seq:
            self.next_seq = accepted + 1  # a reconnect: the controller has more than we knew
        self.accepted_seq = accepted
        moved = prev is None or any(
            prev.get(k) != status.get(k)
            for k in ("DONE_SEQ", "ACCEPTED_SEQ", "STATE", "POS_X", "POS_Y", "POS_Z", "EXEC_SEQ")
        )
        if done > self.done_seq:
            lo, hi = max(self.done_seq, self.base_seq), min(done, self.last_seq)
            newly = tuple(self.lines[s - self.base_seq - 1] for s in range(lo + 1, hi + 1))
            self.done_seq = done
            if newly:
                events.append(BlocksDone(newly))
        if state == mm.MachineState.ERROR and not self.reported_error:
            self.reported_error = True
            self.sending = False
            seq = int(status["ERROR_SEQ"])
            events.append(BlockRejected(seq, self.line_of(seq), int(status["ERROR_CODE"])))
        elif state == mm.MachineState.ALARM:
            self.sending = False
            events.append(ControllerAlarm(int(status["ALARM_CODE"]), done))
        if moved or self._progress_at is None:
            self._progress_at = now_s
            self._next_poll_at = now_s
        else:
            self._next_poll_at = now_s + self.poll_interval_s
            hold = state in (mm.MachineState.HOLD, mm.MachineState.HOLD_PENDING)
            if self.outstanding and not hold and now_s - self._progress_at > self.stall_s:
                self._progress_at = now_s
                events.append(Stalled(self.stall_s))
        return events

    def _writes_check(self, seq: int) -> None:
        if self._writes.get(seq, 0) > self.max_rewrites:
            bad = self.status.get("LAST_BAD_REASON", 0) if self.status else 0
            try:
                reason = mm.BadWrite(int(bad)).name
            except ValueError:
                reason = str(bad)
            line = self.line_of(seq)
            where = f"line {line.number} ({line.text!r})" if line else f"SEQ {seq}"
            raise ProtocolError(
                f"block {seq} ({where}) was written {self._writes[seq]} times and never "
                f"accepted (last bad write reason: {reason})",
                line=line.number if line else None,
                text=line.text if line else None,
            )
