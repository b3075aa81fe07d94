"""Neighbouring dexels walk the piece grid together: the same candidates as one by one.

The ball walk (:func:`verification.capsule_search.lowest_capsule_entries`) gathers the
candidates of a few neighbouring dexels over one ball holding theirs
(:func:`~verification.capsule_search.group_ball`) and sorts them out per dexel
(:func:`~verification.capsule_search.own_slots`). Against the full method, each dexel's own
walk (:func:`~verification.capsule_search.candidate_slots`), the slots must be the very
same, in the same order, so the walk's values, pieces and pair counts cannot change.
"""

import math

import numpy as np
import pytest

from verification.capsule_search import (
    GROUP_REACH,
    candidate_slots,
    group_ball,
    own_slots,
)
from verification.grid import PieceGrid


def _grid(rng, n_pieces=4000, cell=0.3):
    # midpoints on a wavy sheet, as pieces of passes over a surface lie
    xy = rng.uniform(0.0, 6.0, size=(n_pieces, 2))
    z = 0.4 * np.sin(xy[:, 0]) * np.cos(0.7 * xy[:, 1]) + rng.normal(0.0, 0.05, n_pieces)
    mid = np.column_stack([xy, z])
    grid = PieceGrid.build(mid, mid.min(axis=0) - 1.0, mid.max(axis=0) + 1.0, cell)
    return grid, np.ascontiguousarray(mid[grid.order])


def _own_walk(grid, sorted_mid, c, lim2):
    span = max(1, math.ceil(math.sqrt(lim2) / grid.cell_mm))
    buf, n = candidate_slots(c[0], c[1], c[2], lim2, span, np.asarray(grid.dims),
                             grid.origin_mm, grid.cell_mm, grid.starts, sorted_mid,
                             np.empty(4, dtype=np.int64))
    return buf[:n].copy()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_group_finds_each_dexels_own_candidates(seed):
    rng = np.random.default_rng(seed)
    grid, sorted_mid = _grid(rng)
    dims = np.asarray(grid.dims)
    checked = 0
    for _ in range(60):
        # a run of samples 0.13 mm apart along a row, radii varying with convexity
        start = rng.uniform(0.5, 5.5, size=3)
        start[2] = rng.uniform(-0.5, 0.5)
        step = rng.normal(size=3)
        step *= 0.13 / np.linalg.norm(step)
        centres = start + np.arange(4)[:, None] * step
        lim2 = rng.uniform(0.4, 0.8, size=4) ** 2
        gx, gy, gz, g2 = group_ball(centres, lim2, 0, 4)
        assert g2 > 0.0
        span = max(1, math.ceil(math.sqrt(g2) / grid.cell_mm))
        shared, n_shared = candidate_slots(gx, gy, gz, g2, span, dims, grid.origin_mm,
                                           grid.cell_mm, grid.starts, sorted_mid,
                                           np.empty(4, dtype=np.int64))
        for q in range(4):
            buf, n = own_slots(shared, n_shared, *centres[q], lim2[q], sorted_mid,
                               np.empty(2, dtype=np.int64))
            own = _own_walk(grid, sorted_mid, centres[q], lim2[q])
            np.testing.assert_array_equal(buf[:n], own)
            checked += n
    assert checked > 1000  # the groups met pieces, not empty space


def test_a_group_is_walked_together_only_when_compact_and_finite():
    lim2 = np.full(4, 0.25)
    near = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.2, 0.0, 0.0], [0.3, 0.0, 0.0]])
    *_, g2 = group_ball(near, lim2, 0, 4)
    # the mean centre lies 0.15 from the ends: reach 0.5 + 0.15, a hair wider
    assert g2 == pytest.approx(0.65**2, rel=1e-8)
    assert g2 >= 0.65**2
    row_end = near.copy()
    row_end[3] = [0.0, 40.0, 0.0]  # the next row starts far away
    assert group_ball(row_end, lim2, 0, 4)[3] == 0.0
    assert 2 * 0.5 * GROUP_REACH < 40.0
    unknown = near.copy()
    unknown[1] = np.nan
    assert group_ball(unknown, lim2, 0, 4)[3] == 0.0
    assert group_ball(near, np.r_[lim2[:3], np.inf], 0, 4)[3] == 0.0
    assert group_ball(near, lim2, 2, 3)[3] == 0.0  # a single dexel walks alone
