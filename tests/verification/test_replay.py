"""Replay: positions from the interpreter and kinematics, joint sampling, unknown start."""

import itertools

import numpy as np
import pytest

from gcode import Arc, Linear, Program, Rapid
from gcode.machine_frame import joint_columns, work_offset_vector
from machines import forward, load_machine
from verification import VerificationError, replay
from verification.pieces import simplify_polyline


def test_three_axis_replay_is_the_program_in_the_workpiece_frame(router):
    program = Program((Rapid(x=0.0, y=0.0, z=5.0), Linear(z=-1.0, feed=300.0),
                       Linear(x=10.0, feed=800.0),
                       Arc(clockwise=False, x=20.0, y=10.0, i=0.0, j=10.0, feed=800.0)))
    motion = replay(program, router, chord_tol_mm=1e-3, radius_mm=3.0)
    assert motion.first_swept == 1
    assert motion.tips_mm[0].tolist() == [0.0, 0.0, 5.0]
    assert motion.tips_mm[-1] == pytest.approx([20.0, 10.0, -1.0])
    np.testing.assert_allclose(motion.axes, np.tile([0.0, 0.0, 1.0], (motion.n_instances, 1)))
    # the arc is sampled within the chord tolerance: radius 10 -> >= pi/2 / (2 acos(1 - 1e-4))
    arc = np.flatnonzero(motion.move_of_instance == 3)
    assert arc.size >= 55
    radii = np.linalg.norm(motion.tips_mm[arc, :2] - [10.0, 10.0], axis=1)
    assert radii == pytest.approx(10.0)
    assert motion.tip_deviation_mm.max() == 0.0 and motion.substeps[:3].tolist() == [0, 1, 1]


def test_modulo_c_turns_the_short_way_round():
    machine = load_machine("head-table-bc")
    program = Program((Rapid(x=0.0, y=0.0, z=-300.0, b=0.0, c=350.0),
                       Linear(c=10.0, feed=100.0)))
    motion = replay(program, machine, chord_tol_mm=1e-3, radius_mm=3.0)
    assert motion.rotary_deg[1] == pytest.approx(20.0)  # not 340


def test_a_block_that_turns_a_rotary_axis_is_sampled_until_its_chords_are_within_tolerance():
    machine = load_machine("trunnion-ac")
    program = Program((Rapid(x=0.0, y=0.0, z=-300.0, a=0.0, c=0.0),
                       Linear(a=-40.0, feed=100.0)))
    tol = 1e-3
    motion = replay(program, machine, chord_tol_mm=tol, radius_mm=3.0)
    moving = np.flatnonzero(motion.move_of_instance == 1)
    # mid-points between consecutive samples, recomputed exactly, stay within the tolerance
    start = np.array([[0.0, 0.0, -300.0, 0.0, 0.0, 0.0]]) + work_offset_vector(machine)
    j0 = joint_columns(machine, start)
    j1 = j0.copy()
    j1[0, 3] = -40.0
    n = moving.size
    u = (np.arange(n) + 0.5) / n
    mid, _ = forward(machine, j0 + u[:, None] * (j1 - j0))
    chords = 0.5 * (motion.tips_mm[np.r_[0, moving[:-1]]] + motion.tips_mm[moving])
    assert np.linalg.norm(mid - chords, axis=1).max() <= tol
    assert motion.tip_deviation_mm[1] > 1.0  # the tip swings far off the straight line


def test_a_program_that_never_sets_an_axis_cannot_be_verified(router):
    with pytest.raises(VerificationError, match="axis Z"):
        replay(Program((Rapid(x=0.0, y=0.0), Linear(x=5.0, feed=100.0))), router,
               chord_tol_mm=1e-3, radius_mm=3.0)
    with pytest.raises(VerificationError, match="no motion block"):
        replay(Program(()), router, chord_tol_mm=1e-3, radius_mm=3.0)


def test_simplify_keeps_every_vertex_within_tolerance(rng):
    t = np.linspace(0.0, np.pi, 3001)
    circle = np.column_stack([40 * np.cos(t), 40 * np.sin(t), 0.001 * rng.normal(size=t.size)])
    keep = simplify_polyline(circle, 0.005, 5.0)
    assert keep[0] == 0 and keep[-1] == t.size - 1 and keep.size < 300
    worst = 0.0
    for a, b in itertools.pairwise(keep):
        e = circle[b] - circle[a]
        v = circle[a:b + 1] - circle[a]
        f = np.clip(v @ e / (e @ e), 0.0, 1.0)
        worst = max(worst, float(np.linalg.norm(v - f[:, None] * e, axis=1).max()))
    assert worst <= 0.005
    assert np.linalg.norm(np.diff(circle[keep], axis=0), axis=1).max() <= 5.0


def _simplify_checking_every_chord(points, tol_mm, max_length_mm):
    """The rounds of :func:`simplify_polyline` with every chord checked in every round."""
    keep, idle, parity = list(range(points.shape[0])), 0, 1
    while len(keep) > 2 and idle < 2:
        drop = []
        for p in range(max(parity, 1), len(keep) - 1, 2):
            a, c = keep[p - 1], keep[p + 1]
            ac = points[c] - points[a]
            aa = float(ac @ ac)
            if aa > max_length_mm ** 2:
                continue
            v = points[a + 1:c] - points[a]
            f = np.clip(v @ ac / (aa if aa > 0.0 else 1.0), 0.0, 1.0)
            if np.linalg.norm(v - f[:, None] * ac, axis=1).max() <= tol_mm:
                drop.append(p)
        keep = [k for i, k in enumerate(keep) if i not in set(drop)]
        idle = 0 if drop else idle + 1
        parity = 1 - parity
    return np.array(keep)


@pytest.mark.parametrize("noise_mm", [0.0005, 0.002])
def test_simplify_skips_only_chords_it_already_refused(rng, noise_mm):
    # a chord refused once is not checked again while its ends stay: the vertices kept are
    # those of rounds that check every chord (on noise near the tolerance many chords are
    # refused, then offered again with a new end)
    t = np.linspace(0.0, 2.0 * np.pi, 2500)
    wavy = np.column_stack([30 * np.cos(t), 30 * np.sin(t) + 0.01 * np.sin(40 * t),
                            noise_mm * rng.normal(size=t.size)])
    for tol_mm, longest_mm in ((0.002, 5.0), (0.004, 0.8)):
        np.testing.assert_array_equal(simplify_polyline(wavy, tol_mm, longest_mm),
                                      _simplify_checking_every_chord(wavy, tol_mm, longest_mm))


@pytest.mark.parametrize("name", ["trunnion-ac", "head-table-bc"])
def test_instances_posed_while_counting_steps_are_those_posed_afresh(rng, name):
    # moves without rotary travel, small and large turns (several rounds of counting):
    # every instance is the pose at u = j / n of its move, bit for bit
    from verification.replay import _instances, _pose, _sample_u, _substeps

    machine = load_machine(name)
    n = 600
    j1 = np.cumsum(rng.normal(0.0, 1.0, (n, machine.n_axes)), axis=0)
    rotary = [i for i, a in enumerate(machine.axes) if a.is_rotary]
    turn = rng.choice([0.0, 0.5, 30.0], size=(n, 1)) * rng.normal(size=(n, len(rotary)))
    j1[:, rotary] = 10.0 + np.cumsum(turn, axis=0)
    j0 = np.vstack([j1[:1] - 1.0, j1[:-1]])
    counts, _, posed = _substeps(machine, j0, j1, 1e-3, 3.0)
    assert len(posed) >= 2 and (counts == 1).any() and counts.max() > 10
    move, u = _sample_u(counts)
    tips, axes, _ = _pose(machine, j0, j1, move, u, 3.0)
    got_move, got_tips, got_axes = _instances(machine, j0, j1, counts, posed, 3.0)
    np.testing.assert_array_equal(got_move, move)
    np.testing.assert_array_equal(got_tips, tips)
    np.testing.assert_array_equal(got_axes, axes)
