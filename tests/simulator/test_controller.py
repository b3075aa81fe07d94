"""Controller core: soft limits, states, journal, clock, whole-program runs, CLI."""

import io
from contextlib import redirect_stdout

import pytest

from gcode import GRBL, parse
from simulator import Alarm, Controller, Speed, State, VirtualClock, run_program
from simulator.cli import main as cli_main


def test_clock_and_speed():
    clock = VirtualClock()
    assert clock.advance(0.5) == 0.5 and clock.advance_to(0.2) == 0.5
    with pytest.raises(ValueError, match="clock step"):
        clock.advance(-1.0)
    assert Speed.parse("realtime").factor == 1.0 and Speed.parse("x2.5").factor == 2.5
    assert Speed.parse("x10").name == "x10" and Speed.parse("instant").instant
    for bad in ("x0", "x-1", "fast", "xx"):
        with pytest.raises(ValueError, match="unknown speed"):
            Speed.parse(bad)


def test_injected_clock_is_used(router):
    clock = VirtualClock(100.0)
    c = Controller(router, clock=clock)
    c.submit("G1X-10F600")
    c.run_until_idle()
    assert clock.now_s == c.now_s > 100.0
    assert c.journal[0].time_s == clock.now_s


def test_soft_limit_during_motion_holds_then_alarms(router):
    c = Controller(router)
    assert c.submit("G1X-100F3000").accepted
    c.step(0.5)
    res = c.submit("G1X10")
    assert res.status == "alarm" and res.code == 2 and "axis X" in res.message
    assert c.state is State.HOLD and c.critical
    c.step(1.0)  # decelerates to a stop, then the alarm fires
    assert c.alarm is Alarm.SOFT_LIMIT and c.alarm_critical
    x = c.position()[0]
    assert -100.0 < x < 0.0 and not c.planner
    assert c.soft_reset() is None  # already stopped: no ALARM:3
    assert c.alarm is Alarm.SOFT_LIMIT and not c.critical
    assert c.unlock() and c.state is State.IDLE
    assert c.position()[0] == x


def test_soft_limits_use_the_machine_travel(trunnion):
    c = Controller(trunnion)
    assert c.submit("G0A-120").accepted  # at the limit
    assert c.submit("G0A-120.01").status == "alarm"


def test_soft_limits_can_be_disabled(router):
    c = Controller(router)
    assert c.set_setting(20, 0) == 0
    assert c.submit("G1X10F600").accepted


def test_invalid_work_offsets_and_modes(router):
    with pytest.raises(ValueError, match="work offset"):
        Controller(router, work_offsets={7: (0.0,) * 6})
    with pytest.raises(ValueError, match="protocol mode"):
        Controller(router, mode="marlin")


def test_work_offsets_shift_machine_positions(router):
    c = Controller(router, work_offsets={1: (-400.0, -300.0, -110.0, 0.0, 0.0, 0.0)})
    c.submit("G1X10Y5Z1F3000")
    c.run_until_idle()
    assert c.position() == (-390.0, -295.0, -109.0)
    assert c.work_position() == pytest.approx((10.0, 5.0, 1.0))


def test_submit_refuses_when_not_accepting(router):
    c = Controller(router, planner_blocks=1)
    c.submit("G1X-1F600")
    with pytest.raises(RuntimeError, match="not accepting"):
        c.submit("G1X-2")


def test_arcs_become_chords_within_tolerance(router):
    c = Controller(router)
    c.submit("G0X-20Y-10")
    c.submit("G2X-10Y-20I10J0F1200")  # a quarter circle of radius 10 about (-10, -10)
    assert len(c.planner) > 10  # split into short chords
    c.run_until_idle()
    assert c.position() == pytest.approx((-10.0, -20.0, 0.0))
    assert [e.text for e in c.journal.entries()] == ["G0X-20Y-10", "G2X-10Y-20I10J0F1200"]


def test_journal_exactly_once_across_a_reset(router):
    c = Controller(router)
    for i in range(20):
        if not c.accepting:
            c.run_until_accepting()
        c.submit(f"G1X-{i + 1}F3000", line=i + 1)
    c.soft_reset()  # queued lines are discarded, never journaled
    c.unlock()
    done = [e.line for e in c.journal.entries()]
    assert done == list(range(1, len(done) + 1)) and len(done) < 20
    for i in range(len(done), 20):
        c.run_until_accepting()
        c.submit(f"G1X-{i + 1}F3000", line=i + 1)
    c.run_until_idle()
    assert [e.line for e in c.journal.entries()] == list(range(1, 21))
    assert c.journal.duplicates() == {}


def test_run_program_stops_before_a_soft_limit(router):
    c = Controller(router)
    run = run_program(c, parse("G1X-1F600\nG1X-2\nG1X5\nG1X-3\n", GRBL))
    assert run.alarm == 2 and run.lines == 2
    assert c.alarm is Alarm.SOFT_LIMIT and c.position() == (-2.0, 0.0, 0.0)
    with pytest.raises(RuntimeError, match="idle controller"):
        run_program(c, parse("G1X-1F600\n", GRBL))


def test_run_program_rejects_axes_the_mode_lacks(trunnion):
    c = Controller(trunnion, mode="grbl")
    with pytest.raises(ValueError, match="axis A"):
        run_program(c, parse("G1A5F600\n"))


def test_cli_prints_endpoints_and_stops(capsys):
    buf = io.StringIO()
    with redirect_stdout(buf):
        rc = cli_main(
            [
                "--serial",
                "tcp:0",
                "--modbus",
                "tcp:0",
                "--duration",
                "0.2",
                "--status-interval",
                "0.1",
                "--fault",
                "latency=5",
            ]
        )
    out = buf.getvalue()
    assert rc == 0
    assert "grbl tcp: socket://127.0.0.1:" in out and "modbus tcp: 127.0.0.1:" in out
    assert "simulator stopped" in capsys.readouterr().err


def test_cli_reports_user_errors(capsys):
    assert cli_main(["--machine", "nope", "--duration", "0"]) == 2
    assert "unknown machine 'nope'" in capsys.readouterr().err
    assert cli_main(["--fault", "explode=1", "--duration", "0"]) == 2
    assert "unknown fault 'explode=1'" in capsys.readouterr().err


def test_toolpath_simulate_is_registered():
    from streamline_cam.cli import _parser

    args = _parser().parse_args(["simulate", "--serial", "tcp:0", "--speed", "x10"])
    assert args.handler is not None and args.speed == "x10"
