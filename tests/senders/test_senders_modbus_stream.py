"""The sans-IO Modbus planner fed with recorded status reads (no server)."""

from __future__ import annotations

import pytest

from gcode.senders import modbus_map as mm
from gcode.senders.errors import ProtocolError
from gcode.senders.job import Job
from gcode.senders.modbus_stream import (
    BlockRejected,
    BlocksDone,
    ControllerAlarm,
    ControllerRestarted,
    ModbusStream,
    ReadStatus,
    Stalled,
    WriteCommand,
    WriteHeartbeat,
    WriteSlot,
)

JOB = Job.from_text("".join(f"G1X{i}F100\n" for i in range(1, 21)))


def status(accepted=0, done=0, free=8, state=mm.MachineState.IDLE, resets=0, **kw):
    st = {
        "STATE": int(state),
        "ACCEPTED_SEQ": accepted,
        "DONE_SEQ": done,
        "FREE_SLOTS": free,
        "RESET_COUNT": resets,
        "ERROR_SEQ": 0,
        "ERROR_CODE": 0,
        "ALARM_CODE": 0,
        "CMD_ACK": 0,
        "POS_X": 0.0,
    }
    st.update(kw)
    return st


def drain(s: ModbusStream, now: float = 0.0) -> list:
    """Requests until the next status read (each write confirmed)."""
    out = []
    while True:
        r = s.next_request(now)
        if isinstance(r, ReadStatus):
            return out
        out.append(r)
        s.written(r, now)


def test_writes_only_within_the_credits_one_slot_per_request():
    s = ModbusStream(JOB.lines, base_seq=100, reset_count=0, heartbeat_interval_s=0.0)
    assert isinstance(s.next_request(0.0), ReadStatus)
    s.on_status(status(accepted=100, done=100, free=3), 0.0)
    writes = drain(s)
    assert [w.seq for w in writes] == [101, 102, 103]  # three credits
    assert all(isinstance(w, WriteSlot) and len(w.registers) == mm.SLOT_STRIDE for w in writes)
    assert writes[0].address == mm.slot_address(101)
    assert mm.decode_slot(list(writes[0].registers)).text == "G1X1F100"


def test_lost_write_is_rewritten_and_a_reconnect_continues_at_accepted_plus_one():
    s = ModbusStream(JOB.lines, base_seq=0, reset_count=0, heartbeat_interval_s=0.0)
    s.on_status(status(free=8), 0.0)
    assert [w.seq for w in drain(s)] == list(range(1, 9))
    # the controller took only 1-5 (6 failed its CRC): write from 6 again
    s.on_status(status(accepted=5, done=2, free=5), 0.1)
    assert [w.seq for w in drain(s)] == [6, 7, 8, 9, 10]
    assert s.rewrites == 1
    # a time-out on a write: nothing assumed; the next status decides
    req = s.next_request(0.2)
    assert isinstance(req, ReadStatus)
    s.failed(WriteSlot(11, JOB.lines[10], 0, ()), 0.2)
    s.on_status(status(accepted=11, done=9, free=6), 0.3)  # it had arrived after all
    assert next(w.seq for w in drain(s)) == 12  # not 11 again


def test_done_blocks_are_reported_once_each_in_order():
    s = ModbusStream(JOB.lines[:4], base_seq=10, reset_count=0, heartbeat_interval_s=0.0)
    ev1 = s.on_status(status(accepted=14, done=12, state=mm.MachineState.RUN), 0.0)
    ev2 = s.on_status(status(accepted=14, done=14), 0.1)
    done = [ln.number for e in ev1 + ev2 if isinstance(e, BlocksDone) for ln in e.lines]
    assert done == [1, 2, 3, 4] and s.finished


def test_error_alarm_and_restart_stop_writing():
    s = ModbusStream(JOB.lines, base_seq=0, reset_count=4, heartbeat_interval_s=0.0)
    evs = s.on_status(
        status(
            accepted=7, done=5, state=mm.MachineState.ERROR, resets=4, ERROR_SEQ=7, ERROR_CODE=20
        ),
        0.0,
    )
    assert isinstance(evs[0], BlocksDone) and len(evs[0].lines) == 5
    ev = evs[-1]
    assert isinstance(ev, BlockRejected) and ev.line.number == 7 and ev.code == 20
    assert not s.sending and isinstance(s.next_request(0.0), ReadStatus)
    s2 = ModbusStream(JOB.lines, base_seq=0, reset_count=4, heartbeat_interval_s=0.0)
    ev = s2.on_status(status(state=mm.MachineState.ALARM, ALARM_CODE=2, done=3, resets=4), 0.0)
    assert isinstance(ev[-1], ControllerAlarm) and ev[-1].code == 2
    s3 = ModbusStream(JOB.lines, base_seq=0, reset_count=4, heartbeat_interval_s=0.0)
    assert isinstance(s3.on_status(status(resets=5), 0.0)[0], ControllerRestarted)


def test_send_response_waits_for_each_block():
    s = ModbusStream(
        JOB.lines, base_seq=0, reset_count=0, send_response=True, heartbeat_interval_s=0.0
    )
    s.on_status(status(free=8), 0.0)
    assert [w.seq for w in drain(s)] == [1]
    s.on_status(status(accepted=1, free=8), 0.0)
    assert [w.seq for w in drain(s)] == [2]


def test_heartbeat_and_commands_go_first():
    s = ModbusStream(JOB.lines, base_seq=0, reset_count=0, heartbeat_interval_s=0.25)
    hb = s.next_request(0.0)
    assert isinstance(hb, WriteHeartbeat) and hb.registers == (1,)
    s.written(hb, 0.0)
    cmd = s.command(mm.Command.HOLD)
    assert s.next_request(0.1) == cmd and cmd.registers == (2, 1)
    s.written(cmd, 0.1)
    assert isinstance(s.next_request(0.3), WriteHeartbeat)
    assert isinstance(cmd, WriteCommand)


def test_stall_is_reported_but_a_hold_is_not_a_stall():
    s = ModbusStream(JOB.lines, base_seq=0, reset_count=0, heartbeat_interval_s=0.0, stall_s=5.0)
    st = status(accepted=8, done=2, free=0, state=mm.MachineState.RUN)
    s.on_status(st, 0.0)
    assert s.on_status(st, 4.0) == []
    assert isinstance(s.on_status(st, 6.0)[0], Stalled)
    held = status(accepted=8, done=2, free=0, state=mm.MachineState.HOLD)
    s.on_status(held, 7.0)
    assert s.on_status(held, 60.0) == []


def test_a_block_never_accepted_is_an_error_naming_it():
    s = ModbusStream(JOB.lines, base_seq=0, reset_count=0, heartbeat_interval_s=0.0, max_rewrites=2)
    s.on_status(status(free=8), 0.0)
    with pytest.raises(ProtocolError, match=r"block 1 \(line 1 \('G1X1F100'\)\).*CRC"):
        for k in range(5):
            drain(s)
            s.on_status(status(free=8, LAST_BAD_REASON=1), 0.1 * (k + 1))
