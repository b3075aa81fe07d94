"""Pieces of feed moves, as the scallop measurement sweeps them: each move's poses chained."""

from itertools import pairwise

import numpy as np
import pytest
from measured_plans import planned

from toolpath.planning import SpherePatch
from toolpath.planning.sweep_kernel import piece_ends

CAP = SpherePatch(radius_mm=50.0, longitude_deg=(-20.0, 20.0), colatitude_deg=(15.0, 40.0))


def test_each_move_runs_from_its_first_pose_through_its_inner_poses_to_its_last():
    rng = np.random.default_rng(7)
    counts = np.array([1, 3, 2, 1, 4])
    first, last = rng.normal(size=(5, 3)), rng.normal(size=(5, 3))
    inner = rng.normal(size=(int((counts - 1).sum()), 3))
    starts, stops = piece_ends(first, last, inner, counts)
    expected = []
    k = 0
    for m, c in enumerate(counts):
        chain = [first[m], *inner[k:k + c - 1], last[m]]
        expected += list(pairwise(chain))
        k += c - 1
    assert starts.shape == stops.shape == (counts.sum(), 3)
    assert np.array_equal(starts, np.array([a for a, _ in expected]))
    assert np.array_equal(stops, np.array([b for _, b in expected]))


def test_a_ball_s_centre_pieces_are_the_poses_chained_even_through_a_half_turn():
    # centre_pieces places each pose once in a compiled loop: the same numbers as the
    # poses' tips and axes (move_poses) chained by piece_ends, R up the axis; a half-turn
    # (opposite axes) has a zero axis half way, kept zero (unit's rule), not 0 / 0
    from toolpath.planning.sweep_kernel import centre_pieces
    from toolpath.vectors import move_poses

    rng = np.random.default_rng(11)
    counts = np.array([1, 3, 2, 4, 1, 2])
    tip_a, tip_b = rng.normal(size=(6, 3)), rng.normal(size=(6, 3))
    axis_a = rng.normal(size=(6, 3))
    axis_a /= np.linalg.norm(axis_a, axis=1)[:, None]
    axis_b = axis_a + 0.3 * rng.normal(size=(6, 3))
    axis_b /= np.linalg.norm(axis_b, axis=1)[:, None]
    axis_b[3] = -axis_a[3]  # (a half-turn over 4 pieces: the axis at u = 1/2 is zero)
    move = np.repeat(np.arange(6), counts - 1)
    u = np.concatenate([np.arange(1, c) / c for c in counts])
    tips, axes = move_poses(tip_a[move], axis_a[move], tip_b[move], axis_b[move], u)
    assert not np.abs(axes).sum(axis=1).all()  # (the premise: one zero axis)
    expected = piece_ends(tip_a + 3.0 * axis_a, tip_b + 3.0 * axis_b, tips + 3.0 * axes,
                          counts)
    got = centre_pieces(tip_a, tip_b, axis_a, axis_b, counts, 3.0)
    assert np.isfinite(got[0]).all() and np.isfinite(got[1]).all()
    np.testing.assert_array_equal(got[0], expected[0])
    np.testing.assert_array_equal(got[1], expected[1])


def test_no_moves_no_pieces():
    starts, stops = piece_ends(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3)),
                               np.zeros(0, dtype=np.int64))
    assert starts.shape == stops.shape == (0, 3)


def _pairs_brute_force(middles, queries, radius_mm):
    """The full method: every (query, piece) whose middle lies within the radius, sorted."""
    d2 = ((queries[:, None, :] - middles[None, :, :]) ** 2).sum(axis=2)
    owner, item = np.nonzero(d2 <= radius_mm * radius_mm)
    return sorted(zip(owner.tolist(), item.tolist(), strict=True))


@pytest.mark.parametrize("spec", ["ball:6", "bull:8:1"])
def test_the_pieces_near_points_are_every_piece_whose_middle_lies_within_the_radius(spec):
    # a ball's pairs come from the cells binned for its estimate (finer than its reach),
    # a flat or bull-nose cutter's from the reach's: the same pairs either way
    measured = planned(CAP, spec, scallop_mm=0.02, chord_tol_mm=0.02, axis_mode="3")
    volume = measured.volume()
    middles = 0.5 * (volume.piece_a + volume.piece_b)
    rng = np.random.default_rng(5)
    rows = rng.choice(len(middles), 150, replace=False)
    queries = middles[rows] + rng.normal(scale=0.3, size=(150, 3))
    for radius_mm in (0.3 * volume.near_mm, volume.lateral + 0.4, volume.reach, None):
        owner, item = volume.pairs(queries, radius_mm)
        assert np.all(np.diff(owner) >= 0)  # grouped by query, in order
        got = sorted(zip(owner.tolist(), item.tolist(), strict=True))
        expected = _pairs_brute_force(middles, queries, radius_mm or volume.reach)
        assert len(expected) >= 50
        assert got == expected
    assert np.array_equal(volume.piece_vectors, volume.piece_b - volume.piece_a)
