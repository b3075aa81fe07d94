"""Trapezoid timing, junction speeds and the planner, in virtual time."""

import math

import numpy as np
import pytest

from gcode import GRBL, parse
from simulator import Controller, GrblProtocol, run_program
from simulator.motion import (
    AxisLimits,
    advance_in_block,
    block_kinematics,
    junction_speed_sq,
    trapezoid_time_s,
    trapezoid_time_s_array,
)
from simulator.planner import PlannerQueue, _reference_entry_speeds_sq, plan_entry_speeds_sq


def test_trapezoid_and_triangle_times():
    # 10 mm at 100 mm/s with 1000 mm/s^2: 0.1 s ramps over 5 mm each, no cruise
    assert trapezoid_time_s(10.0, 0.0, 0.0, 100.0, 1000.0) == pytest.approx(0.2, rel=1e-12)
    # 20 mm: ramps 5 mm each + 10 mm cruise at 100 mm/s
    assert trapezoid_time_s(20.0, 0.0, 0.0, 100.0, 1000.0) == pytest.approx(0.3, rel=1e-12)
    # 2 mm: triangle, peak sqrt(a L) = sqrt(2000)
    vp = math.sqrt(2000.0)
    assert trapezoid_time_s(2.0, 0.0, 0.0, 100.0, 1000.0) == pytest.approx(2 * vp / 1000.0)
    a = trapezoid_time_s_array(
        np.array([10.0, 20.0, 2.0, 0.0]),
        np.zeros(4),
        np.zeros(4),
        np.full(4, 100.0),
        np.full(4, 1000.0),
    )
    assert a == pytest.approx([0.2, 0.3, 2 * vp / 1000.0, 0.0])


def test_single_move_follows_the_trapezoid_in_virtual_time(router):
    # X accel 800 mm/s^2, F3000 = 50 mm/s: ramp 0.0625 s over 1.5625 mm
    c = Controller(router)
    assert c.submit("G1X-100F3000").accepted
    t_ramp = 50.0 / 800.0
    d_ramp = 0.5 * 800.0 * t_ramp**2
    c.step(t_ramp / 2)
    assert c.position()[0] == pytest.approx(-0.5 * 800.0 * (t_ramp / 2) ** 2, abs=1e-9)
    assert c.feed_mm_per_min() == pytest.approx(60 * 800.0 * t_ramp / 2)
    c.step(t_ramp / 2 + 1.0)
    assert c.position()[0] == pytest.approx(-(d_ramp + 50.0), abs=1e-9)
    assert c.feed_mm_per_min() == pytest.approx(3000.0)
    c.run_until_idle()
    total = 2 * t_ramp + (100.0 - 2 * d_ramp) / 50.0
    assert c.now_s == pytest.approx(total, rel=1e-12)
    assert c.position() == (-100.0, 0.0, 0.0)
    assert c.state.value == "Idle"


def test_advance_in_block_stepping_matches_closed_form():
    total = trapezoid_time_s(20.0, 10.0, 5.0, 100.0, 1000.0)
    s, v, t = 0.0, 10.0, 0.0
    while s < 20.0:
        s, v, used = advance_in_block(s, v, 20.0, 100.0, 5.0, 1000.0, 0.001, False)
        t += used
    assert t == pytest.approx(total, abs=1e-12)
    assert v == pytest.approx(5.0)


def test_junction_speed_follows_grbl():
    lim = AxisLimits(
        (100.0,) * 3 + (math.inf,) * 3, (1000.0,) * 3 + (math.inf,) * 3, (True,) * 3 + (False,) * 3
    )
    x = (1.0, 0, 0, 0, 0, 0)
    y = (0, 1.0, 0, 0, 0, 0)
    assert junction_speed_sq(x, x, lim, 0.01) > 1e30  # straight on
    assert junction_speed_sq(x, tuple(-v for v in x), lim, 0.01) == 0.0  # reversal
    # 90 degrees: sin(theta/2) = sqrt(0.5 (1 - cos)) with cos = 0 -> a * jd * s / (1 - s)
    s = math.sqrt(0.5)
    a_j = 1000.0 / (1 / math.sqrt(2))  # junction vector (-1, 1)/sqrt2 limited per axis
    assert junction_speed_sq(x, y, lim, 0.01) == pytest.approx(a_j * 0.01 * s / (1 - s))


def test_feed_semantics_rotary_and_inverse_time(trunnion):
    lim = AxisLimits.from_machine(trunnion)
    k = block_kinematics(
        (3.0, 4.0, 0, 30.0, 0, 0), 600.0, rapid=False, inverse_time=False, limits=lim
    )
    # G94: F applies to the 5 mm XYZ part: 0.5 s, so the joint-space speed is L / 0.5
    assert k.length / k.nominal_speed == pytest.approx(0.5)
    k = block_kinematics((0, 0, 0, 90.0, 0, 0), 600.0, rapid=False, inverse_time=False, limits=lim)
    assert k.nominal_speed == pytest.approx(10.0)  # rotary-only: deg/min
    k = block_kinematics((3.0, 4.0, 0, 0, 0, 0), 120.0, rapid=False, inverse_time=True, limits=lim)
    assert k.length / k.nominal_speed == pytest.approx(0.5)  # G93 F120: 60/120 s


@pytest.mark.parametrize("w", [1, 2, 15])
def test_vectorized_planner_equals_the_loop(w):
    rng = np.random.default_rng(7)
    j = rng.uniform(0.0, 400.0, 200)
    j[rng.random(200) < 0.1] = 0.0
    d = rng.uniform(0.0, 100.0, 200)
    got = plan_entry_speeds_sq(j, d, planner_blocks=w)
    assert got == pytest.approx(_reference_entry_speeds_sq(list(j), list(d), w), abs=1e-9)


def test_planner_queue_is_bounded():
    q = PlannerQueue(2)
    from simulator.planner import MotionBlock

    def blk():
        return MotionBlock(
            (0.0,) * 6, (1.0,) + (0.0,) * 5, 1.0, (1.0,) + (0.0,) * 5, 10.0, 100.0, 0.0, 1.0, 1
        )

    q.append(blk())
    q.append(blk())
    assert q.full
    with pytest.raises(OverflowError, match="full"):
        q.append(blk())


def _program_text(rng, n):
    lines = ["G21", "G90", "G0X-10Y-10Z-5"]
    x = y = -50.0
    for _ in range(n):
        r = rng.random()
        x = min(-1.0, max(-700.0, x + rng.uniform(-5, 5)))
        y = min(-1.0, max(-500.0, y + rng.uniform(-5, 5)))
        if r < 0.05:
            lines.append(f"G2X{x:.3f}Y{y:.3f}R20F1200")
        elif r < 0.08:
            lines.append("G4P0.1")
        elif r < 0.1:
            lines.append("M3S1000")
        elif r < 0.12:
            lines.append(f"G1X{x:.3f}Y{y:.3f}")
        else:
            lines.append(f"G1X{x:.3f}Y{y:.3f}F{rng.choice([600, 1500, 3000])}")
    return "\n".join(lines) + "\n"


def test_streamed_run_equals_whole_program_run(router):
    text = _program_text(np.random.default_rng(3), 250)
    batch = Controller(router)
    run = run_program(batch, parse(text, GRBL))
    streamed = Controller(router)
    out = GrblProtocol(streamed).feed(text.encode())
    streamed.run_until_idle()
    assert out.count(b"ok") == text.count("\n") and b"error" not in out
    a, b = batch.journal, streamed.journal
    assert len(a) == len(b) == run.lines
    assert (a.lines() == b.lines()).all()
    assert np.abs(a.positions() - b.positions()).max() == 0.0
    assert a.times_s() == pytest.approx(b.times_s(), rel=1e-9, abs=1e-9)
    assert batch.now_s == pytest.approx(streamed.now_s, rel=1e-12)
    assert batch.parser_state == streamed.parser_state


def test_short_queue_is_slower_than_full_queue(router):
    text = "".join(f"G1X-{i * 0.5 + 0.5:.3f}F3000\n" for i in range(100))
    prog = parse(text, GRBL)
    t = {}
    for blocks in (1, 15):
        c = Controller(router, planner_blocks=blocks)
        t[blocks] = run_program(c, prog).duration_s
    assert t[1] > 2 * t[15]  # with no look-ahead the axis stops at every block end


def test_rotary_rate_cap(trunnion):
    lim = AxisLimits.from_machine(trunnion)
    # 90 deg of A in 0.5 s would be 10800 deg/min > 9000: capped, takes 0.6 s
    k = block_kinematics(
        (3.0, 4.0, 0, 90.0, 0, 0), 600.0, rapid=False, inverse_time=False, limits=lim
    )
    assert k.length / k.nominal_speed == pytest.approx(0.6)
