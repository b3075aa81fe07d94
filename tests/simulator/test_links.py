"""pyserial against the pseudo-terminal and TCP endpoints; pacing; exactly-once journal."""

import time

import pytest
import serial

from simulator import run_simulator

TIMEOUT_S = 3.0


def _open(sim):
    port = serial.serial_for_url(sim.serial_url, timeout=TIMEOUT_S)
    assert port.readline() == b"\r\n"
    assert port.readline() == b"Grbl 1.1h ['$' for help]\r\n"
    return port


def _program(n):
    return [f"N{i + 1}G1X-{(i % 50) + 1}.{i % 7}Y-{(i % 13) + 1}F3000" for i in range(n)]


def stream_char_counting(port, lines, budget=128):
    """Character-counting sender: keep at most ``budget`` unacknowledged bytes."""
    inflight = []
    answers = []
    for line in lines:
        data = (line + "\n").encode()
        while sum(inflight) + len(data) > budget:
            answers.append(port.readline())
            assert answers[-1], "time-out waiting for ok"
            inflight.pop(0)
        port.write(data)
        inflight.append(len(data))
    while inflight:
        answers.append(port.readline())
        assert answers[-1], "time-out waiting for ok"
        inflight.pop(0)
    return answers


@pytest.mark.parametrize("kind", ["pty", "tcp"])
def test_pyserial_streams_and_every_line_runs_exactly_once(kind):
    lines = _program(120)
    with run_simulator(serial=kind, baud=0) as sim:
        port = _open(sim)
        answers = stream_char_counting(port, lines)
        assert answers == [b"ok\r\n"] * len(lines)
        assert sim.wait_idle(TIMEOUT_S)
        port.write(b"?")
        assert port.readline().startswith(b"<Idle|MPos:")
        port.close()
        journal = sim.journal()
    assert [e.n_word for e in journal] == list(range(1, len(lines) + 1))
    assert len({e.seq for e in journal}) == len(lines)
    assert [e.text for e in journal] == lines


def test_send_response_over_tcp_in_realtime_mode():
    with run_simulator(serial="tcp", speed="x50", baud=0) as sim:
        port = _open(sim)
        for line in _program(10):
            port.write((line + "\n").encode())
            assert port.readline() == b"ok\r\n"
        assert sim.wait_idle(TIMEOUT_S)
        port.close()
        assert len(sim.journal()) == 10
        assert sim.snapshot()["virtual_time_s"] > 0.0


def test_baud_pacing_bounds_the_transfer_time():
    # 1 kB through a 9600-baud link (960 B/s) cannot take less than about a second
    lines = [f"G1X-{i % 9 + 1}F3000" for i in range(100)]
    payload = "".join(line + "\n" for line in lines).encode()
    with run_simulator(serial="tcp", baud=9600) as sim:
        port = _open(sim)
        t0 = time.monotonic()
        answers = stream_char_counting(port, lines)
        elapsed = time.monotonic() - t0
        port.close()
    assert answers == [b"ok\r\n"] * len(lines)
    assert elapsed >= 0.9 * len(payload) / 960.0


def test_reconnect_restarts_and_greets_again():
    with run_simulator(serial="tcp", baud=0) as sim:
        p1 = _open(sim)
        p1.close()
        p2 = _open(sim)
        p2.close()
        assert sim.wait_for(lambda s: s.snapshot()["connects"] == 2, TIMEOUT_S)
        assert sim.snapshot()["restarts"] == 2


def test_run_simulator_rejects_bad_options():
    with pytest.raises(ValueError, match="serial must be"):
        with run_simulator(serial="usb"):
            pass
    with pytest.raises(ValueError, match="speed"):
        with run_simulator(speed="fast"):
            pass
    with pytest.raises(ValueError, match="nothing to serve"):
        with run_simulator(serial=None, modbus=None):
            pass
