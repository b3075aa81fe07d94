"""Issue 9: joint interpolation within a 5-axis block is seen on a big rotary move only."""

import pytest
from verify_programs import five_axis_line

from machines import load_machine
from toolpath.planning.analytic import PlaneSurface
from verification import VerifyOptions, verify_program

PLANE = PlaneSurface((-3.0, -3.0, 0.0), (26.0, 0.0, 0.0), (0.0, 6.0, 0.0))
OPTIONS = VerifyOptions(spacing_mm=0.1, horizon_mm=0.05)


def test_one_block_with_a_large_b_swing_gouges_at_its_line(ball6):
    machine = load_machine("head-table-bc")
    report = verify_program(five_axis_line(machine, ball6, 1), PLANE, machine, ball6,
                            options=OPTIONS)
    # blocks: rapid above, plunge to the start, the 40 deg move (block 2, line 3)
    assert report.joints.line == 3 and report.joints.rotary_deg == pytest.approx(40.0)
    assert report.joints.max_mm > 1.0
    assert report.max_gouge is not None and report.max_gouge.line == 3
    assert report.max_gouge_mm > 1.0


def test_the_same_move_in_small_blocks_follows_the_surface(ball6):
    machine = load_machine("head-table-bc")
    report = verify_program(five_axis_line(machine, ball6, 400), PLANE, machine, ball6,
                            options=OPTIONS)
    assert report.joints.max_mm < report.gouge_tol_mm
    assert report.max_gouge is None
    # the ball touches the plane all along the line: remaining material there ~0
    dev = report.deviation_map.deviation_mm
    on_line = abs(report.deviation_map.points_mm[..., 1]) < 0.05
    inside = (report.deviation_map.points_mm[..., 0] > 0.5) & (
        report.deviation_map.points_mm[..., 0] < 19.5)
    assert abs(dev[on_line & inside]).max() < 0.002


def test_trunnion_big_rotary_block_lifts_the_ball_off_the_line(ball6):
    machine = load_machine("trunnion-ac")
    big = verify_program(five_axis_line(machine, ball6, 1, lean="y"), PLANE, machine, ball6,
                         options=OPTIONS)
    small = verify_program(five_axis_line(machine, ball6, 200, lean="y"), PLANE, machine,
                           ball6, options=OPTIONS)
    assert big.joints.max_mm > 1.0 and big.joints.line == 3
    assert small.joints.max_mm < 0.002 and small.joints.blocks_over_tol == 0
    # along the contact line the big block leaves material (the ball lifts), the small ones do not
    for report, left in ((big, True), (small, False)):
        m = report.deviation_map
        line = (abs(m.points_mm[..., 1]) < 0.05) & (m.points_mm[..., 0] > 1.0) & (
            m.points_mm[..., 0] < 19.0)
        worst = m.deviation_mm[line]
        assert (worst.max() > 0.05) == left
