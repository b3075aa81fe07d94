"""Every fault option, through the API and a real link."""

import time

import pytest
import serial
from conftest import lines_of

from simulator import Controller, FaultPlan, GrblProtocol, run_simulator

TIMEOUT_S = 3.0


def _open(url):
    port = serial.serial_for_url(url, timeout=TIMEOUT_S)
    assert port.readline() == b"\r\n" and port.readline().startswith(b"Grbl 1.1h")
    return port


def _lines(n):
    return [f"G1X-{i + 1}F3000" for i in range(n)]


def _send_response(port, lines):
    got = []
    for line in lines:
        try:
            port.write((line + "\n").encode())
            got.append(port.readline())
        except serial.SerialException:  # the link was cut: the port reports it
            got.append(b"")
        if not got[-1]:
            break
    return got


def test_fault_specs_are_checked():
    for bad in [
        "nope=1",
        "latency",
        "error-at-line=0",
        "alarm-at-line=3:12",
        "restart-at-line=2:1",
        "drop-after-bytes=-5",
        "latency=-1",
    ]:
        with pytest.raises(ValueError, match="fault"):
            FaultPlan.parse([bad])
    with pytest.raises(ValueError, match="two faults at line 3"):
        FaultPlan.parse(["error-at-line=3", "alarm-at-line=3"])


def test_error_at_line(router):
    p = GrblProtocol(Controller(router), faults=FaultPlan.parse(["error-at-line=2:22"]))
    out = lines_of(p.feed(b"G1X-1F600\nG1X-2\nG1X-3\n"))
    assert out == ["ok", "error:22", "ok"]
    p.controller.run_until_idle()
    assert [e.line for e in p.controller.journal.entries()] == [1, 3]


def test_alarm_at_line(router):
    p = GrblProtocol(Controller(router), faults=FaultPlan.parse(["alarm-at-line=2"]))
    out = lines_of(p.feed(b"G1X-1F600\nG1X-2\nG1X-3\n"))
    assert out == ["ok", "ALARM:1", "[MSG:Reset to continue]"]
    assert p.feed(b"G1X-4\n") == b""
    out = lines_of(p.feed(b"\x18$X\nG1X-4F600\n"))
    assert out[-3:] == ["[MSG:Caution: Unlocked]", "ok", "ok"]


def test_non_critical_alarm_code(router):
    p = GrblProtocol(Controller(router), faults=FaultPlan.parse(["alarm-at-line=1:9"]))
    assert lines_of(p.feed(b"G1X-1F600\nG1X-2\n")) == ["ALARM:9"]  # the receive buffer is flushed
    assert lines_of(p.feed(b"G1X-2\n")) == ["error:9"]


def test_restart_at_line(router):
    p = GrblProtocol(Controller(router), faults=FaultPlan.parse(["restart-at-line=2"]))
    out = lines_of(p.feed(b"G1X-1F600\nG1X-2\n"))
    assert out == ["ok", "Grbl 1.1h ['$' for help]"]
    assert p.controller.restarts == 1
    assert lines_of(p.feed(b"G1X-3\n")) == ["error:22"]  # modal feed lost with the restart


@pytest.mark.parametrize("kind", ["tcp", "pty"])
def test_drop_after_lines(kind):
    with run_simulator(serial=kind, baud=0, faults=["drop-after-lines=3"]) as sim:
        url = sim.serial_url
        port = _open(url)
        got = _send_response(port, _lines(5))
        port.close()
        assert got[:2] == [b"ok\r\n", b"ok\r\n"]
        assert b"ok\r\n" not in got[2:]  # the link died with line 3's answer in flight
        assert sim.wait_idle(TIMEOUT_S)
        snap = sim.snapshot()
        assert snap["drops"] == 1 and snap["faults_fired"] == ["drop-after-lines=3"]
        assert [e.line for e in sim.journal()] == [1, 2, 3]  # line 3 reached the controller
        # a pty is re-created, as after a USB re-plug (the kernel may reuse its number)
        port = _open(sim.serial_url)  # the simulator serves again
        assert _send_response(port, ["G1X-9F600"]) == [b"ok\r\n"]
        port.close()


def test_drop_after_bytes():
    with run_simulator(serial="tcp", baud=0, faults=["drop-after-bytes=15"]) as sim:
        port = _open(sim.serial_url)
        got = _send_response(port, ["G1X-1F3000", "G1X-2F3000"])
        port.close()
        assert got[0] == b"ok\r\n" and got[1] == b""
        assert sim.wait_idle(TIMEOUT_S)
        assert sim.snapshot()["bytes_in"] == 15
        assert [e.line for e in sim.journal()] == [1]  # 4 bytes of line 2 never make a line


def test_latency_delays_every_answer():
    with run_simulator(serial="tcp", baud=0, faults=["latency=80"]) as sim:
        port = _open(sim.serial_url)
        t0 = time.monotonic()
        assert _send_response(port, ["G1X-1F600", "G1X-2"]) == [b"ok\r\n"] * 2
        assert time.monotonic() - t0 >= 2 * 0.08
        port.close()


def test_faults_through_modbus_seq(router):
    from gcode.senders import modbus_map as mm
    from simulator import ModbusDevice

    dev = ModbusDevice(Controller(router), faults=FaultPlan.parse(["error-at-line=2:33"]))
    for seq in (1, 2, 3):
        dev.write(mm.slot_address(seq), mm.encode_slot(seq, f"G1X-{seq}F600"))
    dev.service(0.0)
    dev.controller.run_until_idle()
    st = mm.decode_status(dev.read(*mm.STATUS_BLOCK))
    assert (st["STATE"], st["ERROR_SEQ"], st["ERROR_CODE"]) == (mm.MachineState.ERROR, 2, 33)
    assert (st["ACCEPTED_SEQ"], st["DONE_SEQ"]) == (2, 1)


# ---------------------------------------------------------------- status habits (issue 25)
def _full(router, faults):
    p = GrblProtocol(Controller(router), faults=FaultPlan.parse(faults))
    out = lines_of(p.feed("".join(line + "\n" for line in _lines(20)).encode()))
    assert out == ["ok"] * 20 and p.controller.planner_free == 0
    return p


def test_status_habit_specs_are_checked():
    for bad in ["status-when-full=never", "ignore-status=0", "ignore-status=1.5",
                "status-delay=-3", "status-delay=x"]:  # fmt: skip
        with pytest.raises(ValueError, match="fault"):
            FaultPlan.parse([bad])
    plan = FaultPlan.parse(["ignore-status=0.25"])
    assert [k for k in range(1, 13) if plan.ignores_status(k)] == [4, 8, 12]


def test_no_status_reply_while_the_planner_is_full_ignored(router):
    p = _full(router, ["status-when-full=ignore"])
    assert p.feed(b"?") == b""
    p.controller.run_until_idle()
    assert lines_of(p.poll()) == []  # forgotten: the host must ask again
    assert lines_of(p.feed(b"?"))[0].startswith("<Idle|")
    assert p.counters["status_ignored"] == 1 and p.counters["status"] == 1


def test_no_status_reply_while_the_planner_is_full_deferred_and_merged(router):
    p = _full(router, ["status-when-full=defer"])
    assert p.feed(b"?") == b"" and p.feed(b"?") == b""
    p.controller.run_until_idle()
    (report,) = lines_of(p.poll())  # one report answers both queries
    assert report.startswith("<Idle|") and p.counters["status_merged"] == 1


def test_a_share_of_status_queries_ignored_and_a_delayed_report_answers_two(router):
    p = GrblProtocol(Controller(router), faults=FaultPlan.parse(["ignore-status=0.5"]))
    answered = [bool(p.feed(b"?")) for _ in range(6)]
    assert answered == [True, False, True, False, True, False]
    p = GrblProtocol(Controller(router), faults=FaultPlan.parse(["status-delay=500"]))
    assert p.feed(b"?", now_s=10.0) == b"" and p.feed(b"?", now_s=10.3) == b""
    assert p.poll(now_s=10.4) == b""
    (report,) = lines_of(p.poll(now_s=10.5))
    assert report.startswith("<Idle|") and p.counters["status_merged"] == 1
