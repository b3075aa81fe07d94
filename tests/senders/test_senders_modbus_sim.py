"""The Modbus sender against the simulator's Modbus server (TCP and RTU on a pty)."""

from __future__ import annotations

import numpy as np
import pytest
from _senders_support import (
    ModbusProxy,
    assert_exactly_once,
    end_position,
    zigzag_program,
)

from gcode.senders import modbus_map as mm
from gcode.senders.errors import AlarmError, ControllerResetError, LineRejectedError
from gcode.senders.grbl_sender import HoldChoice
from gcode.senders.job import Job
from gcode.senders.modbus_sender import ModbusLink, ModbusSender, parse_modbus_url


def sender_for(url: str, **kw) -> ModbusSender:
    sender = ModbusSender(ModbusLink(url, timeout_s=kw.pop("timeout_s", 1.0)), **kw)
    sender.connect()
    return sender


def tcp_url(sim) -> str:
    return f"tcp://127.0.0.1:{sim.endpoints.modbus_port}"


def test_urls():
    assert parse_modbus_url("tcp://127.0.0.1:5020") == ("tcp", "127.0.0.1", 5020)
    assert parse_modbus_url("rtu:/dev/pts/3?baud=19200") == ("rtu", "/dev/pts/3", 19200)
    with pytest.raises(ValueError, match="tcp://HOST:PORT"):
        parse_modbus_url("udp://x")


@pytest.mark.parametrize("kind", ["tcp", "rtu"])
def test_whole_job_over_modbus_runs_every_block_exactly_once(simulator_factory, kind):
    text = zigzag_program(120 if kind == "tcp" else 40)
    job = Job.from_text(text)
    with simulator_factory(serial=None, modbus=kind) as sim:
        url = tcp_url(sim) if kind == "tcp" else f"rtu:{sim.endpoints.modbus_rtu_path}"
        sender = sender_for(url)
        result = sender.run(job)
        sender.close()
        assert_exactly_once(sim.journal(), [ln.text for ln in job.lines])
        assert np.allclose(sim.snapshot()["position"], end_position(text), atol=1e-6)
    assert result.blocks_done == len(job.lines)


def _on_slot_writes(sender: ModbusSender, actions: dict) -> None:
    """Run ``actions[seq]()`` just before block ``seq`` is first written (fault triggers)."""
    write = sender.link.write

    def wrapped(address, values):
        if address >= mm.SLOT_BASE:
            action = actions.pop(mm.decode_u32(values[0], values[1]), None)
            if action is not None:
                action()
        return write(address, values)

    sender.link.write = wrapped


def test_modbus_time_outs_are_retried_idempotently_exactly_once(simulator_factory):
    job = Job.from_text(zigzag_program(120))
    with simulator_factory(serial=None, modbus="tcp") as sim:
        proxy = ModbusProxy(sim.endpoints.modbus_port)
        try:
            sender = sender_for(f"tcp://127.0.0.1:{proxy.port}", timeout_s=0.2)
            # the server takes these blocks, the client never hears back: it times out,
            # reconnects, reads ACCEPTED_SEQ and goes on; a rewrite would be ignored
            _on_slot_writes(
                sender,
                {
                    10: lambda: proxy.swallow_responses(1),
                    40: lambda: proxy.swallow_responses(2),
                    90: lambda: proxy.swallow_responses(1),
                },
            )
            sender.run(job)
            sender.close()
        finally:
            proxy.close()
        assert proxy.swallowed == 4 and sender.link.timeouts >= 3
        assert sender.link.reconnects >= 3
        assert_exactly_once(sim.journal(), [ln.text for ln in job.lines])


def test_modbus_reconnect_continues_from_the_accepted_sequence_exactly_once(simulator_factory):
    job = Job.from_text(zigzag_program(120))
    with simulator_factory(serial=None, modbus="tcp") as sim:
        proxy = ModbusProxy(sim.endpoints.modbus_port)
        try:
            sender = sender_for(f"tcp://127.0.0.1:{proxy.port}", timeout_s=0.5)
            _on_slot_writes(sender, {30: proxy.cut, 75: proxy.cut})
            sender.run(job)
            sender.close()
        finally:
            proxy.close()
        assert proxy.connections >= 3 and sender.link.reconnects >= 2
        assert_exactly_once(sim.journal(), [ln.text for ln in job.lines])


def test_modbus_error_stops_at_that_block_nothing_after_it_runs(simulator_factory):
    job = Job.from_text(zigzag_program(60))
    bad = job.lines[24]
    with simulator_factory(serial=None, modbus="tcp", faults=["error-at-line=25:20"]) as sim:
        sender = sender_for(tcp_url(sim))
        with pytest.raises(LineRejectedError) as info:
            sender.run(job)
        sender.close()
        assert_exactly_once(sim.journal(), [ln.text for ln in job.lines[:24]])
    err = info.value
    assert (err.line, err.text, err.code, err.resume_line) == (bad.number, bad.text, 20, bad.number)


def test_modbus_alarm_and_restart_are_reported_with_the_exact_resume_line(simulator_factory):
    job = Job.from_text(zigzag_program(60))
    with simulator_factory(serial=None, modbus="tcp", faults=["alarm-at-line=20:1"]) as sim:
        sender = sender_for(tcp_url(sim))
        with pytest.raises(AlarmError, match="ALARM:1") as info:
            sender.run(job)
        sender.close()
        ran = len(sim.journal())
    assert info.value.resume_line == job.lines[ran].number
    with simulator_factory(serial=None, modbus="tcp", faults=["restart-at-line=20"]) as sim:
        sender = sender_for(tcp_url(sim))
        with pytest.raises(ControllerResetError, match="restarted") as info:
            sender.run(job)
        sender.close()
        ran = len(sim.journal())
    assert info.value.resume_line == job.lines[ran].number


def test_modbus_feed_hold_then_resume_exactly_once(simulator_factory):
    job = Job.from_text(zigzag_program(80, feed=3000.0))
    with simulator_factory(serial=None, modbus="tcp", speed="x20") as sim:
        sender = sender_for(tcp_url(sim))
        states = []
        sender.on_progress = lambda p: p.done >= 20 and not states and sender.request_hold()

        def on_hold(p):
            states.append(sim.snapshot()["state"])
            return HoldChoice.RESUME

        sender.run(job, on_hold=on_hold)
        sender.close()
        assert states == ["Hold:0"]
        assert_exactly_once(sim.journal(), [ln.text for ln in job.lines])
