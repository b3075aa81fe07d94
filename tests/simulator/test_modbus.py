"""The register map as data, the Modbus device handshake, and a real pymodbus client."""

import asyncio

import pytest
from pymodbus.client import AsyncModbusSerialClient, AsyncModbusTcpClient
from pymodbus.framer import FramerType

from gcode.senders import modbus_map as mm
from simulator import Controller, ModbusDevice, run_simulator

TIMEOUT_S = 3.0


def test_map_encodings_round_trip():
    for v in (0, 1, 65535, 65536, 2**32 - 1):
        assert mm.decode_u32(*mm.encode_u32(v)) == v
    for v in (0, -1, 123456, -(2**31), 2**31 - 1):
        assert mm.decode_i32(*mm.encode_i32(v)) == v
    assert mm.encode_u32(0x12345678) == [0x1234, 0x5678]  # high word first
    slot = mm.decode_slot(mm.encode_slot(70000, "G1 X1.5 (c)"))
    assert (slot.seq, slot.text, slot.crc_ok) == (70000, "G1 X1.5 (c)", True)
    assert mm.crc16_modbus(b"123456789") == 0x4B37  # the CRC-16/MODBUS check value
    with pytest.raises(ValueError, match="80"):
        mm.encode_slot(1, "X" * 81)
    with pytest.raises(ValueError, match="printable"):
        mm.encode_slot(1, "G1\nX1")


def test_map_table_is_consistent():
    used = {}
    for r in mm.REGISTERS:
        for a in range(r.address, r.address + r.count):
            assert a not in used, f"{r.name} overlaps {used[a]}"
            used[a] = r.name
        assert r.address + r.count <= mm.SLOT_BASE
    lo, n = mm.STATUS_BLOCK
    assert all(r.address + r.count <= lo + n for r in mm.REGISTERS if r.address >= lo)
    assert mm.slot_address(8) == mm.SLOT_BASE and mm.slot_address(9) == mm.SLOT_BASE + 48
    assert "| 26-27 | ACCEPTED_SEQ | u32 | R |" in mm.register_table_markdown()


def _status(dev):
    return mm.decode_status(dev.read(*mm.STATUS_BLOCK))


def test_slots_are_validated_and_idempotent(router):
    dev = ModbusDevice(Controller(router), instant=False)
    regs = mm.encode_slot(1, "G1X-1F600")
    assert dev.write(mm.slot_address(1), regs) is None
    assert dev.write(mm.slot_address(1), regs) is None  # retry: ignored
    bad = list(mm.encode_slot(2, "G1X-2"))
    bad[mm.SLOT_CRC] ^= 1
    dev.write(mm.slot_address(2), bad)
    dev.write(mm.slot_address(3), mm.encode_slot(2, "G1X-2"))  # wrong slot
    dev.write(mm.slot_address(20), mm.encode_slot(20, "G1X-2"))  # beyond the credits
    st = _status(dev)
    assert (st["ACCEPTED_SEQ"], st["DUPLICATE_WRITES"], st["BAD_WRITES"]) == (1, 1, 3)
    assert st["LAST_BAD_REASON"] == mm.BadWrite.OUT_OF_WINDOW
    assert dev.write(mm.slot_address(2) + 1, regs) == 3  # not slot-aligned
    assert dev.write(mm.slot_address(2), regs[:10]) == 3  # half a slot
    assert dev.write(20, [1]) == 2  # read-only
    # out-of-order blocks wait for the gap to be filled
    dev.write(mm.slot_address(3), mm.encode_slot(3, "G1X-3"))
    assert _status(dev)["ACCEPTED_SEQ"] == 1
    dev.write(mm.slot_address(2), mm.encode_slot(2, "G1X-2"))
    dev.service(0.0)
    st = _status(dev)
    assert (st["ACCEPTED_SEQ"], st["QUEUED_SEQ"], st["FREE_SLOTS"]) == (3, 3, 8)


def test_rejected_block_stops_everything_after_it(router):
    dev = ModbusDevice(Controller(router), instant=False)
    for seq, text in enumerate(["G1X-1F600", "G1X-2", "G1Q9", "G1X-4"], start=1):
        dev.write(mm.slot_address(seq), mm.encode_slot(seq, text))
    dev.service(0.0)
    st = _status(dev)
    assert (st["STATE"], st["ERROR_SEQ"], st["ERROR_CODE"]) == (mm.MachineState.ERROR, 3, 20)
    assert (st["ACCEPTED_SEQ"], st["QUEUED_SEQ"], st["FREE_SLOTS"]) == (3, 3, 0)
    dev.controller.run_until_idle()
    assert _status(dev)["DONE_SEQ"] == 2
    assert [e.line for e in dev.controller.journal.entries()] == [1, 2]
    dev.write(10, [mm.Command.CLEAR, 1])
    dev.write(mm.slot_address(4), mm.encode_slot(4, "G1X-4"))
    dev.service(0.0)
    dev.controller.run_until_idle()
    st = _status(dev)
    assert (st["STATE"], st["CMD_ACK"], st["DONE_SEQ"], st["POS_X"]) == (0, 1, 4, -4.0)


def test_commands_hold_resume_abort_and_watchdog(router):
    dev = ModbusDevice(Controller(router), instant=False)
    c = dev.controller
    for seq in (1, 2):
        dev.write(mm.slot_address(seq), mm.encode_slot(seq, f"G1X-{50 * seq}F3000"))
    dev.service(0.0)
    c.step(0.5)
    dev.write(10, [mm.Command.HOLD, 1])
    assert _status(dev)["STATE"] == mm.MachineState.HOLD_PENDING
    c.step(0.5)
    assert _status(dev)["STATE"] == mm.MachineState.HOLD
    dev.write(10, [mm.Command.RESUME, 2])
    c.step(0.1)
    assert _status(dev)["STATE"] == mm.MachineState.RUN
    dev.write(10, [mm.Command.ABORT, 3])
    c.step(1.0)
    dev.service(0.0)
    st = _status(dev)
    assert (st["STATE"], st["ALARM_CODE"], st["CMD_ACK"]) == (mm.MachineState.IDLE, 0, 3)
    assert st["ACCEPTED_SEQ"] == st["DONE_SEQ"] < 2  # the aborted block is gone
    dev.write(10, [77, 4])
    assert _status(dev)["CMD_RESULT"] == mm.CommandResult.UNKNOWN
    # watchdog: armed by a heartbeat, holds when the host goes quiet
    n = int(_status(dev)["DONE_SEQ"])
    dev.write(mm.slot_address(n + 1), mm.encode_slot(n + 1, "G1X-300F3000"))
    dev.write(12, [1])
    dev.service(0.0)
    c.step(0.3)
    dev.service(2.0)
    assert c.hold


async def _stream(client, lines):
    assert await client.connect()
    ident = await client.read_holding_registers(0, count=8, device_id=1)
    assert ident.registers[:3] == [mm.MAP_VERSION, mm.SLOT_COUNT, mm.SLOT_CHARS]
    seq = 0
    loop = asyncio.get_running_loop()
    deadline = loop.time() + 10.0
    while loop.time() < deadline:
        rr = await client.read_holding_registers(
            mm.STATUS_BLOCK[0], count=mm.STATUS_BLOCK[1], device_id=1
        )
        st = mm.decode_status(rr.registers)
        if seq == len(lines) and st["DONE_SEQ"] == len(lines):
            break
        for _ in range(int(st["FREE_SLOTS"])):
            if seq == len(lines):
                break
            seq += 1
            w = await client.write_registers(
                mm.slot_address(seq), mm.encode_slot(seq, lines[seq - 1]), device_id=1
            )
            assert not w.isError()
        await asyncio.sleep(0.005)
    bad = await client.write_registers(30, [1], device_id=1)
    client.close()
    return st, bad


def test_pymodbus_client_over_tcp():
    lines = [f"G1X-{i + 1}Y-{i % 4}F3000" for i in range(40)]
    with run_simulator(serial=None, modbus="tcp") as sim:
        port = sim.endpoints.modbus_port

        async def go():
            return await _stream(
                AsyncModbusTcpClient("127.0.0.1", port=port, timeout=TIMEOUT_S), lines
            )

        st, bad = asyncio.run(go())
        journal = sim.journal()
    assert st["DONE_SEQ"] == 40 and st["POS_X"] == -40.0
    assert bad.isError() and bad.exception_code == 2
    assert [e.line for e in journal] == list(range(1, 41))


def test_pymodbus_client_over_rtu_pty():
    lines = [f"G1X-{i + 1}F3000" for i in range(10)]
    with run_simulator(serial=None, modbus="rtu") as sim:
        path = sim.endpoints.modbus_rtu_path

        async def go():
            client = AsyncModbusSerialClient(
                path, framer=FramerType.RTU, baudrate=115200, parity="N", timeout=TIMEOUT_S
            )
            return await _stream(client, lines)

        st, _ = asyncio.run(go())
    assert st["DONE_SEQ"] == 10 and st["POS_X"] == -10.0
