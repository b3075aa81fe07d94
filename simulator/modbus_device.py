"""The Modbus front end as a sans-IO register bank over the controller core.

:class:`ModbusDevice` serves the register map of :mod:`gcode.senders.modbus_map`: reads
return the controller's live status, writes of whole block slots are validated (slot
index, credit window, length, ASCII, CRC-16) and accepted in SEQ order, commands act once
per new ``CMD_SEQ``, and a host heartbeat watchdog feed-holds when the host goes quiet.
:meth:`ModbusDevice.service` feeds accepted blocks to the controller as the planner has
room. The pymodbus adapter (:mod:`simulator.modbus_server`) only forwards requests here.

Seq registers: ``ACCEPTED_SEQ`` (stored, contiguous) >= ``QUEUED_SEQ`` (parsed into the
planner) >= ``DONE_SEQ`` (executed). A rejected block sets STATE=ERROR with
``ERROR_SEQ``/``ERROR_CODE``; blocks accepted after it are discarded and
``ACCEPTED_SEQ = QUEUED_SEQ = ERROR_SEQ``, so the host continues at ``ERROR_SEQ + 1``
after ``CLEAR``. Each SEQ is executed at most once, whatever the retries.

Examples
--------
>>> from machines import load_machine
>>> from simulator.controller import Controller
>>> from gcode.senders import modbus_map as mm
>>> dev = ModbusDevice(Controller(load_machine("grbl-router")))
>>> dev.write(mm.slot_address(1), mm.encode_slot(1, "G1X-5F600")) is None
True
>>> dev.service(0.0); mm.decode_status(dev.read(20, 38))["ACCEPTED_SEQ"]
1
"""

from __future__ import annotations

import math

from gcode.senders import modbus_map as mm
from simulator.controller import Controller, State
from simulator.faults import FaultPlan
from simulator.grbl_protocol import clean_line

__all__ = ["ILLEGAL_ADDRESS", "ILLEGAL_VALUE", "ModbusDevice"]

#: Modbus exception codes returned by :meth:`ModbusDevice.write` / ``read``.
ILLEGAL_ADDRESS, ILLEGAL_VALUE = 2, 3
_R = {r.address + k for r in mm.REGISTERS if r.access is mm.Access.R for k in range(r.count)}
_W = {r.address + k for r in mm.REGISTERS if r.access is mm.Access.W for k in range(r.count)}
_DEFAULT_TIMEOUT_MS = 1000


class ModbusDevice:
    """Register bank + block handshake of one simulated Modbus controller.

    Parameters
    ----------
    controller : Controller
        The core.
    instant : bool
        Jump virtual time when the planner is full and blocks wait.
    faults : FaultPlan or None
        Line faults apply to block SEQ numbers.
    """

    def __init__(
        self, controller: Controller, *, instant: bool = True, faults: FaultPlan | None = None
    ) -> None:
        self.controller = controller
        self.instant = instant
        self.faults = faults if faults is not None else FaultPlan()
        self.regs = [0] * mm.TOTAL_REGISTERS
        self._stored: dict[int, str] = {}  # seq -> text, accepted but not queued
        self.accepted_seq = 0
        self.queued_seq = 0
        self._host_of: dict[int, int] = {}  # controller seq -> host SEQ
        self._done_host = 0
        self.error = False
        self.error_seq = 0
        self.error_code = 0
        self.cmd_ack = 0
        self.cmd_result = 0
        self.bad_writes = 0
        self.last_bad = 0
        self.duplicates = 0
        self._abort_pending = False
        self._ctrl_heartbeat = 0
        self._host_heartbeat_at: float | None = None
        self.last_service_s = 0.0
        self.last_write_s = -math.inf  # wall time of the last host write (set by the adapter)
        self.regs[mm.BY_NAME["HEARTBEAT_TIMEOUT_MS"].address] = _DEFAULT_TIMEOUT_MS
        self._constants()

    # ------------------------------------------------------------------ registers
    def _constants(self) -> None:
        c = self.controller
        mask = 0
        for letter in c.report_axes:
            mask |= 1 << mm.AXIS_NAMES.index(letter)
        values = {
            "PROTO_VERSION": mm.MAP_VERSION, "SLOT_COUNT": mm.SLOT_COUNT,
            "SLOT_CHARS": mm.SLOT_CHARS, "SLOT_STRIDE": mm.SLOT_STRIDE,
            "SLOT_BASE": mm.SLOT_BASE, "AXIS_MASK": mask,
            "PLANNER_BLOCKS": c.planner.capacity, "POS_SCALE": mm.POS_SCALE,
        }  # fmt: skip
        for name, v in values.items():
            self.regs[mm.BY_NAME[name].address] = v

    def _put(self, name: str, value: int) -> None:
        r = mm.BY_NAME[name]
        if r.dtype is mm.DType.U16:
            self.regs[r.address] = int(value) & 0xFFFF
        else:
            enc = mm.encode_u32(value) if r.dtype is mm.DType.U32 else mm.encode_i32(value)
            self.regs[r.address : r.address + 2] = enc

    @property
    def done_seq(self) -> int:
        """Last block executed (blocks are executed in SEQ order; rejected ones never)."""
        host = self._host_of.get(self.controller.done_seq)
        if host is not None:
            self._done_host = host
        return self._done_host

    @property
    def state_code(self) -> mm.MachineState:
        """STATE register value."""
        c = self.controller
        if self.error:
            return mm.MachineState.ERROR
        st = c.state
        if st is State.ALARM or c.critical:
            return mm.MachineState.ALARM
        if st is State.CHECK:
            return mm.MachineState.CHECK
        if st is State.HOLD:
            return mm.MachineState.HOLD if c.hold_complete else mm.MachineState.HOLD_PENDING
        return mm.MachineState.RUN if st is State.RUN or c.line_pending else mm.MachineState.IDLE

    def refresh(self) -> None:
        """Copy the controller's live status into the status registers."""
        c = self.controller
        done = self.done_seq
        ex = c.executing_seq
        put = self._put
        put("STATE", self.state_code)
        put("CMD_ACK", self.cmd_ack)
        put("ALARM_CODE", int(c.alarm) if c.alarm is not None else 0)
        put("ERROR_CODE", self.error_code)
        put("ERROR_SEQ", self.error_seq)
        put("ACCEPTED_SEQ", self.accepted_seq)
        put("EXEC_SEQ", self._host_of.get(ex, done) if ex else done)
        put("DONE_SEQ", done)
        put("FREE_SLOTS", self.free_slots)
        put("CTRL_HEARTBEAT", self._ctrl_heartbeat)
        put("QUEUED_SEQ", self.queued_seq)
        put("PLANNER_FREE", c.planner_free)
        put("RESET_COUNT", c.resets + c.restarts)
        put("TIME_MS", int(c.now_s * 1000.0))
        pos = c.position6()
        for i, name in enumerate(mm.AXIS_NAMES):
            put(f"POS_{name}", round(pos[i] * mm.POS_SCALE))
        put("FEED", round(c.feed_mm_per_min() * mm.POS_SCALE))
        put("CMD_RESULT", self.cmd_result)
        put("BAD_WRITES", self.bad_writes)
        put("LAST_BAD_REASON", self.last_bad)
        put("DUPLICATE_WRITES", self.duplicates)

    @property
    def free_slots(self) -> int:
        """Credits: slots the host may write beyond ACCEPTED_SEQ."""
        if self.error or self.controller.alarm is not None:
            return 0
        return max(mm.SLOT_COUNT - (self.accepted_seq - self.queued_seq), 0)

    # ------------------------------------------------------------------ requests
    def read(self, address: int, count: int) -> list[int] | int:
        """Registers ``address .. address + count - 1``, or a Modbus exception code."""
        if address < 0 or count < 1 or address + count > mm.TOTAL_REGISTERS:
            return ILLEGAL_ADDRESS
        self.refresh()
        return self.regs[address : address + count]

    def write(self, address: int, values: list[int]) -> int | None:
        """Write registers; returns None or a Modbus exception code.

        Host registers (CMD .. HEARTBEAT_TIMEOUT_MS) may be written in any grouping;
        slots must be written whole (from the slot start through its CRC) in one request.
        """
        n = len(values)
        if address < 0 or n < 1 or address + n > mm.TOTAL_REGISTERS:
            return ILLEGAL_ADDRESS
        if address >= mm.SLOT_BASE:
            return self._write_slots(address, values)
        span = range(address, address + n)
        if any(a not in _W for a in span):
            return ILLEGAL_ADDRESS
        old_cmd_seq = self.regs[mm.BY_NAME["CMD_SEQ"].address]
        self.regs[address : address + n] = [v & 0xFFFF for v in values]
        hb = mm.BY_NAME["HOST_HEARTBEAT"].address
        if hb in span:
            self._host_heartbeat_at = self.last_service_s
        seq_addr = mm.BY_NAME["CMD_SEQ"].address
        if seq_addr in span and self.regs[seq_addr] != old_cmd_seq:
            self._command(self.regs[mm.BY_NAME["CMD"].address], self.regs[seq_addr])
        return None

    def _write_slots(self, address: int, values: list[int]) -> int | None:
        off = (address - mm.SLOT_BASE) % mm.SLOT_STRIDE
        if off != 0:
            return ILLEGAL_VALUE
        for k in range(0, len(values), mm.SLOT_STRIDE):
            chunk = values[k : k + mm.SLOT_STRIDE]
            if len(chunk) < mm.SLOT_CRC + 1:
                return ILLEGAL_VALUE
            slot_index = (address + k - mm.SLOT_BASE) // mm.SLOT_STRIDE
            self._slot(slot_index, chunk)
        return None

    def _bad(self, reason: mm.BadWrite) -> None:
        self.bad_writes += 1
        self.last_bad = int(reason)

    def _slot(self, index: int, regs: list[int]) -> None:
        slot = mm.decode_slot(regs)
        seq = slot.seq
        if self.error or self.controller.alarm is not None:
            self._bad(mm.BadWrite.NOT_ACCEPTING)
        elif seq != 0 and seq <= self.accepted_seq:
            self.duplicates += 1  # a retry of an accepted block: ignore (idempotent)
        elif seq == 0 or seq > self.queued_seq + mm.SLOT_COUNT:
            self._bad(mm.BadWrite.OUT_OF_WINDOW)
        elif index != seq % mm.SLOT_COUNT:
            self._bad(mm.BadWrite.SLOT_INDEX)
        elif slot.length > mm.SLOT_CHARS:
            self._bad(mm.BadWrite.LENGTH)
        elif any(b < 0x20 or b > 0x7E for b in slot.text_bytes):
            self._bad(mm.BadWrite.TEXT)
        elif not slot.crc_ok:
            self._bad(mm.BadWrite.CRC)
        else:
            self._stored[seq] = slot.text
            while self.accepted_seq + 1 in self._stored:
                self.accepted_seq += 1

    # ------------------------------------------------------------------ commands
    def _command(self, cmd: int, seq: int) -> None:
        c = self.controller
        self.cmd_ack = seq
        self.cmd_result = mm.CommandResult.OK
        try:
            command = mm.Command(cmd)
        except ValueError:
            self.cmd_result = mm.CommandResult.UNKNOWN
            return
        if command in (mm.Command.START, mm.Command.RESUME):
            c.cycle_start()
        elif command is mm.Command.HOLD:
            c.feed_hold()
        elif command is mm.Command.ABORT:
            c.feed_hold()
            self._abort_pending = True
        elif command is mm.Command.CLEAR:
            if c.alarm_critical:
                c.soft_reset()
                self._discard(self.done_seq)
            c.unlock()
            self.error = False
        elif command is mm.Command.CHECK_ON:
            if c.set_check_mode(True):
                self.cmd_result = mm.CommandResult.REFUSED
        elif command is mm.Command.CHECK_OFF:
            c.set_check_mode(False)
            self._discard(self.done_seq)
        elif command is mm.Command.FLUSH:
            self._discard(self.queued_seq)
        else:  # RESET
            done = self.done_seq
            c.soft_reset()
            self._discard(done)

    def _discard(self, upto: int) -> None:
        """Forget every block after ``upto``: accepted = queued = ``upto``."""
        self._stored.clear()
        self.accepted_seq = self.queued_seq = max(upto, 0)

    # ------------------------------------------------------------------ service
    def service(self, now_s: float) -> None:
        """Feed accepted blocks to the controller; run the watchdog (wall time ``now_s``)."""
        self.last_service_s = now_s
        self._ctrl_heartbeat = (self._ctrl_heartbeat + 1) & 0xFFFF
        c = self.controller
        timeout_ms = self.regs[mm.BY_NAME["HEARTBEAT_TIMEOUT_MS"].address]
        if (
            self._host_heartbeat_at is not None
            and timeout_ms
            and now_s - self._host_heartbeat_at > timeout_ms / 1000.0
            and not c.hold
        ):
            c.feed_hold()  # the host went quiet: stop safely, keep the queue
            self._host_heartbeat_at = None  # re-armed by the next heartbeat
        if self._abort_pending:
            if self.instant:
                c.run_until_stopped()
            if c.hold_complete or (not c.planner and not c.line_pending):
                done = self.done_seq
                c.soft_reset()
                self._discard(done)
                self._abort_pending = False
        while not self.error and self.queued_seq < self.accepted_seq:
            if not c.accepting:
                if not self.instant or c.hold_complete or c.critical:
                    break
                c.run_until_accepting()
                if not c.accepting:
                    break
            seq = self.queued_seq + 1
            text = self._stored.pop(seq)
            self._submit(seq, text)
        if self.instant and c.critical and not c.alarm_critical:
            c.run_until_stopped()

    def _submit(self, seq: int, text: str) -> None:
        c = self.controller
        fault = self.faults.line_fault(seq) if self.faults.line_faults else None
        if fault is not None:
            kind, code = fault
            if kind == "error":
                self._reject(seq, code)
            elif kind == "alarm":
                c.raise_alarm(code)
                self._discard(seq)
            else:
                c.restart()
                self._discard(self.done_seq)  # unexecuted blocks are lost with the restart
            return
        line, overflow = clean_line(text.encode("ascii", errors="replace"))
        if overflow:
            self._reject(seq, 11)
            return
        self.queued_seq = seq
        if c.alarm is not None:
            self._reject(seq, 9)
            return
        res = c.submit(line.decode("ascii"), line=seq)
        if res.status == "accepted":
            self._host_of[res.seq] = seq
            if len(self._host_of) > 4 * (c.planner.capacity + mm.SLOT_COUNT):
                self.done_seq  # noqa: B018 - latch the current DONE before pruning
                for k in [k for k in self._host_of if k < c.done_seq]:
                    del self._host_of[k]
        elif res.status == "error":
            self._reject(seq, res.code)
        else:
            self._discard(seq)  # soft limit: ALARM follows, nothing after it runs

    def _reject(self, seq: int, code: int) -> None:
        self.error = True
        self.error_seq = seq
        self.error_code = code
        self._discard(seq)
