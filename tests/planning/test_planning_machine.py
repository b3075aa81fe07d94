"""Plans checked on a machine: travel violations name the right point; time estimate."""

import numpy as np
import pytest

from machines import MachineError, UnknownMachineError, load_machine
from machines.kinematics import solve_inverse
from toolpath.planning import PlaneSurface, PlanTravelLimitError, plan_finishing

# a 20 x 6 mm plate whose far end sticks out past the router's X travel (X <= 0 at
# x = 400 mm in the workpiece frame, whose origin is the bed centre)
PLATE = PlaneSurface(origin_mm=(385.0, 0.0, 0.0), t_vector_mm=(20.0, 0.0, 0.0),
                     s_vector_mm=(0.0, 6.0, 0.0))


def test_travel_violation_reports_the_first_offending_point():
    path, rep = plan_finishing(PLATE, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                               machine="grbl-router", on_limit="report", measure=False)
    (first, *_) = rep.travel_violations
    machine = load_machine("grbl-router")
    x_machine = machine.work_origin[0] + path.positions_mm[:, 0]  # tool length 0
    expected = int(np.argmax(x_machine > 1e-6))
    assert (first.axis, first.index) == ("X", expected)
    assert first.value == pytest.approx(x_machine[expected])
    # the same joints through the kinematics
    joints = solve_inverse(machine, path.positions_mm, path.tool_axes).joints
    assert joints[expected, 0] > 0.0 and np.all(joints[:expected, 0] <= 1e-6)
    assert rep.estimated_time_s > 0.0 and not rep.within_request


def test_travel_violation_raises_naming_point_and_pass():
    with pytest.raises(PlanTravelLimitError) as err:
        plan_finishing(PLATE, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                       machine="grbl-router", measure=False)
    assert isinstance(err.value, MachineError)
    text = str(err.value)
    assert "axis 'X'" in text and "toolpath point" in text and "pass 0" in text


def test_within_travel_and_time_at_the_rate_limits():
    plate = PlaneSurface(t_vector_mm=(20.0, 0.0, 0.0), s_vector_mm=(0.0, 6.0, 0.0))
    path, rep = plan_finishing(plate, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                               machine="grbl-router", feed_mm_per_min=600.0, measure=False)
    assert rep.travel_violations == () and rep.machine == "grbl-router"
    # at least the cutting length at the feed
    assert rep.estimated_time_s >= 60.0 * path.cutting_length_mm / 600.0 * 0.99


def test_unknown_machine():
    with pytest.raises(UnknownMachineError, match="'mill-9000'"):
        plan_finishing(PLATE, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                       machine="mill-9000")


def test_scallop_measurement_moves_the_cutter_as_the_joints_interpolate():
    # a move turning the trunnion's rotary axes: its pieces' ends are the forward
    # kinematics of the interpolated joints, off the straight chord between the tips, and
    # there are enough of them for the straight pieces to follow the bowed path
    from machines.kinematics import forward
    from toolpath.planning.cut_volume import split_moves

    machine = load_machine("trunnion-ac")
    ends = np.array([[10.0, 5.0, 20.0, 10.0, 0.0], [12.0, 6.0, 20.0, 25.0, 40.0]])
    order = [a.letter for a in machine.axes]
    q = ends[:, [("XYZAC".index(letter)) for letter in order]]
    tips, axes = forward(machine, q)
    p0, p1, x0, x1, _ = split_moves(tips[:1], tips[1:], axes[:1], axes[1:], 0.5, 3.0, 1e-4,
                               (machine, q[:1], q[1:]))
    u = np.linspace(0.0, 1.0, len(p0) + 1)[:, None]
    expected_tips, expected_axes = forward(machine, q[0] * (1.0 - u) + q[1] * u)
    np.testing.assert_allclose(np.r_[p0, p1[-1:]], expected_tips, atol=1e-9)
    np.testing.assert_allclose(np.r_[x0, x1[-1:]], expected_axes, atol=1e-12)
    straight = tips[0] + u * (tips[1] - tips[0])
    assert np.linalg.norm(expected_tips - straight, axis=1).max() > 0.1
    fine_u = np.linspace(0.0, 1.0, 2001)[:, None]
    fine_tips, _ = forward(machine, q[0] * (1.0 - fine_u) + q[1] * fine_u)
    piece = np.searchsorted(u[1:, 0], fine_u[:, 0], side="left").clip(0, len(p0) - 1)
    w = ((fine_u[:, 0] - u[piece, 0]) / (u[piece + 1, 0] - u[piece, 0]))[:, None]
    chords = p0[piece] * (1.0 - w) + p1[piece] * w
    assert np.linalg.norm(fine_tips - chords, axis=1).max() < 2e-4


def test_split_places_pieces_of_many_moves_as_the_full_forward_kinematics():
    # moves of one piece and of several, in a row: each piece's ends are the forward
    # kinematics of its move's interpolated joints (the moves' own ends taken from the
    # tips and axes given, the inner poses solved), and tip-linear without a machine
    from machines.kinematics import forward
    from toolpath.planning.cut_volume import split_moves

    machine = load_machine("trunnion-ac")
    order = [a.letter for a in machine.axes]
    canon = np.array([[10.0, 5.0, 20.0, 10.0, 0.0], [10.1, 5.0, 20.0, 10.0, 0.0],
                      [12.0, 6.0, 20.0, 25.0, 40.0], [12.2, 6.1, 20.0, 25.5, 41.0],
                      [20.0, 6.1, 20.0, 25.5, 41.0]])
    q = canon[:, ["XYZAC".index(letter) for letter in order]]
    tips, axes = forward(machine, q)
    for joints in ((machine, q[:-1], q[1:]), None):
        p0, p1, x0, x1, owner = split_moves(tips[:-1], tips[1:], axes[:-1], axes[1:], 0.5, 3.0,
                                       1e-4, joints)
        counts = np.bincount(owner, minlength=4)
        assert counts.min() == 1 and counts.max() > 2
        for move in range(4):
            rows = np.flatnonzero(owner == move)
            u = np.linspace(0.0, 1.0, rows.size + 1)[:, None]
            if joints is None:
                want_tips = tips[move] * (1.0 - u) + tips[move + 1] * u
                want_axes = axes[move] * (1.0 - u) + axes[move + 1] * u
                want_axes /= np.linalg.norm(want_axes, axis=1, keepdims=True)
            else:
                want_tips, want_axes = forward(machine, q[move] * (1.0 - u) + q[move + 1] * u)
            np.testing.assert_allclose(np.r_[p0[rows], p1[rows[-1:]]], want_tips, atol=1e-9)
            np.testing.assert_allclose(np.r_[x0[rows], x1[rows[-1:]]], want_axes, atol=1e-12)
            np.testing.assert_array_equal(p0[rows[1:]], p1[rows[:-1]])  # shared ends


def test_a_balls_pieces_are_the_split_moves_centres():
    # split_centres (a ball's pieces: its centres' ends) gives the very numbers of
    # split_moves' tips and axes, R up the axis, tip-linear and under joint interpolation
    from machines.kinematics import forward
    from toolpath.planning.cut_volume import split_centres, split_moves

    machine = load_machine("trunnion-ac")
    order = [a.letter for a in machine.axes]
    canon = np.array([[10.0, 5.0, 20.0, 10.0, 0.0], [10.1, 5.0, 20.0, 10.0, 0.0],
                      [12.0, 6.0, 20.0, 25.0, 40.0], [20.0, 6.1, 20.0, 25.5, 41.0]])
    q = canon[:, ["XYZAC".index(letter) for letter in order]]
    tips, axes = forward(machine, q)
    for joints in ((machine, q[:-1], q[1:]), None):
        args = (tips[:-1], tips[1:], axes[:-1], axes[1:], 0.5, 3.0, 1e-4, joints)
        p0, p1, x0, x1, owner = split_moves(*args)
        c0, c1, centre_owner = split_centres(*args)
        assert len(p0) > 4
        np.testing.assert_array_equal(c0, p0 + 3.0 * x0)
        np.testing.assert_array_equal(c1, p1 + 3.0 * x1)
        np.testing.assert_array_equal(centre_owner, owner)
        # single-precision input: the same float64 numbers, not sums taken in float32
        low = tuple(x.astype(np.float32) for x in args[:4]) + args[4:]
        c0_low, c1_low, _ = split_centres(*low)
        p0, p1, x0, x1, _ = split_moves(*low)
        np.testing.assert_array_equal(c0_low, p0 + 3.0 * x0)
        np.testing.assert_array_equal(c1_low, p1 + 3.0 * x1)
