"""Pieces of feed moves, as the scallop measurement sweeps them: each move's poses chained."""

from itertools import pairwise

import numpy as np

from toolpath.planning.sweep_kernel import piece_ends


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


def test_no_moves_no_pieces():
    starts, stops = piece_ends(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3)),
                               np.zeros(0, dtype=np.int64))
    assert starts.shape == stops.shape == (0, 3)
