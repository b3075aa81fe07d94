"""The swept-cutter index holds its pieces once: the near search's are the collision's first rows.

:class:`~verification.dexels.SweepIndex` concatenates the ball (or bull-nose) pieces and
the shank's once, the near search reading the first rows (a view, not a second copy: 1 GB
on a bull-nose 5-axis blade program), and builds the runs once over them, the near
search's being the runs that start among its rows. The searches must find what the pair
search over every candidate finds (``compiled=False``, its own copies).
"""

import numpy as np
import pytest

from verification.dexels import SweepIndex
from verification.piece_runs import piece_runs
from verification.pieces import Pieces

RADIUS_MM, CORNER_MM = 4.0, 1.0


def _pieces(rng, m, *, shank, height_mm):
    a = np.cumsum(rng.normal(0.0, 0.05, (m, 3)), axis=0) + np.array([0.0, 0.0, 1.0])
    e = rng.normal(0.0, 0.05, (m, 3))
    axis = np.tile([0.0, 0.0, 1.0], (m, 1)) + rng.normal(0.0, 0.05, (m, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    ee = np.einsum("ij,ij->i", e, e)
    return Pieces(a, e, ee, a + 0.5 * e, 0.5 * np.sqrt(ee), np.arange(m, dtype=np.int64),
                  np.full(m, shank), axis, np.full(m, np.nan), np.full(m, np.nan),
                  np.zeros(1), np.zeros(1, dtype=np.int64), np.full(m, height_mm))


def _index(ball, shank, points, compiled=True):
    return SweepIndex(ball, shank, RADIUS_MM, points.min(0), points.max(0), 0.5, 10.0,
                      corner_radius_mm=CORNER_MM, compiled=compiled)


def _dexels(rng, n=1500):
    points = np.column_stack((rng.uniform(-1.5, 1.5, (n, 2)), np.zeros(n)))
    return points, np.tile([0.0, 0.0, 1.0], (n, 1))


def _built(rng):
    """Ball and shank pieces, dexels over them, and the compiled index of both."""
    ball = _pieces(rng, 3000, shank=False, height_mm=2.0)
    shank = _pieces(rng, 400, shank=True, height_mm=6.0)
    points, dirs = _dexels(rng)
    return ball, shank, points, dirs, _index(ball, shank, points)


def test_the_near_pieces_are_a_view_of_the_collision_pieces(rng):
    ball, shank, _, _, index = _built(rng)
    near, far = index.pieces("near"), index.pieces("far")
    assert near.size == ball.size and far.size == ball.size + shank.size
    for name in ("a", "e", "mid", "axis", "height_mm", "half_mm"):
        assert np.shares_memory(getattr(near, name), getattr(far, name))
        np.testing.assert_array_equal(getattr(near, name), getattr(ball, name))
    assert index.ball is near


def test_the_near_runs_are_the_collision_runs_among_its_pieces(rng):
    ball, _, _, _, index = _built(rng)
    near, far = index._runs_of("near"), index._runs_of("far")
    assert near.along_mm is far.along_mm
    assert near.stop.max() <= ball.size and (far.start[near.size:] >= ball.size).all()
    # every piece in exactly one run, each run of one kind
    own = piece_runs(ball, core_radius_mm=RADIUS_MM - CORNER_MM, corner_radius_mm=CORNER_MM)
    assert near.stop[-1] == own.stop[-1] == ball.size
    np.testing.assert_array_equal(near.start[1:], near.stop[:-1])


@pytest.mark.parametrize("which", ["near", "far"])
def test_searches_over_the_shared_pieces_give_the_pair_searchs_values(rng, which):
    ball = _pieces(rng, 3000, shank=False, height_mm=2.0)
    shank = _pieces(rng, 400, shank=True, height_mm=6.0)
    points, dirs = _dexels(rng)
    reach = np.full(points.shape[0], 3.5 if which == "near" else 6.0)
    centres = points + CORNER_MM * dirs if which == "near" else points
    fast, exact = (_index(ball, shank, points, compiled).search(which, points, dirs, centres,
                                                                reach)
                   for compiled in (True, False))
    assert np.isfinite(exact.lam_mm).mean() > 0.5
    assert np.array_equal(fast.lam_mm, exact.lam_mm)
    assert np.array_equal(fast.piece, exact.piece)
    assert np.array_equal(fast.move, exact.move)


def test_listing_pieces_near_points_copies_no_fields_into_the_grid_s_order(rng):
    """The refine's :meth:`SweepIndex.pieces_within` walks a grid of the pieces but reads
    them in their own order: no copies of their fields sorted by cell (840 MB on the 7 M
    pieces of the bull-nose 5-axis blade program), the same pieces as a scan of all."""
    ball, _, points, _, index = _built(rng)
    centres = points[::300] + np.array([0.0, 0.0, 4.0])
    radii = np.full(centres.shape[0], 0.5)
    found = index.pieces_within("near", centres, radii)
    assert index._grids and not index._sorted
    v = centres[:, None, :] - ball.a[None, :, :]
    f = np.clip(np.einsum("qpj,pj->qp", v, ball.e) / ball.ee, 0.0, 1.0)
    gap = np.linalg.norm(v - f[..., None] * ball.e[None], axis=2)
    every = np.flatnonzero((gap <= radii[:, None] + ball.height_mm[None]).any(axis=0))
    assert 0 < every.shape[0] < ball.size
    np.testing.assert_array_equal(found, every)


def test_the_ball_pieces_given_are_copied_once_field_by_field(rng):
    """Building the index never holds the ball pieces twice whole: the ones given become
    views of the concatenation field by field (the same values), so each of their own
    arrays is freed as it is copied."""
    import tracemalloc

    tracemalloc.start()
    try:
        ball = _pieces(rng, 60_000, shank=False, height_mm=2.0)
        shank = _pieces(rng, 400, shank=True, height_mm=6.0)
        values = {name: getattr(ball, name).copy() for name in ("a", "mid", "move", "shank")}
        points, _ = _dexels(rng, 10)
        before, _ = tracemalloc.get_traced_memory()
        tracemalloc.reset_peak()
        index = _index(ball, shank, points)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    # the pieces as they were, plus one field of the ball's being copied (and the shank's)
    largest = ball.a.nbytes
    assert peak - before <= largest + 4 * largest // 100 + 200_000, peak - before
    far = index.pieces("far")
    for name, v in values.items():
        np.testing.assert_array_equal(getattr(ball, name), v)
        assert np.shares_memory(getattr(ball, name), getattr(far, name))
