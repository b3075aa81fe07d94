"""Neighbouring dexels share work in the bull-nose walk: the same result as the full method.

:func:`verification.sweep_search.lowest_sweep_entries` gathers the runs of a few
neighbouring dexels in one walk of the grid over a ball holding their balls
(:func:`~verification.capsule_search.group_ball`), then sorts them out per dexel
(:func:`~verification.capsule_search.own_slots`); and measures first, where a candidate,
the piece that left least on the previous dexel (``seeded``). Against the full method,
the pair search over every candidate (``SweepIndex(compiled=False)``), every dexel must get
the same value, piece and side; against each dexel walking alone (``grouped=False``) the
same runs met too (the same pair count); unseeded, the same values and pieces.
"""

import functools

import numpy as np
import pytest

import verification.dexels as dexels_module
from verification.dexels import SweepIndex
from verification.pieces import Pieces
from verification.sweep_search import lowest_sweep_entries

RADIUS_MM, CORNER_MM = 4.0, 1.0
HEIGHT_MM = RADIUS_MM - 2.0 * CORNER_MM


def _wave(x, y):
    return 0.6 * np.sin(0.5 * x) * np.cos(0.4 * y)


def _normals(x, y):
    dzdx = 0.3 * np.cos(0.5 * x) * np.cos(0.4 * y)
    dzdy = -0.24 * np.sin(0.5 * x) * np.sin(0.4 * y)
    n = np.column_stack((-dzdx, -dzdy, np.ones_like(x)))
    return n / np.linalg.norm(n, axis=1)[:, None]


def _five_axis_passes(*, pass_step_mm=0.6, step_mm=0.08, lead=0.15):
    """Bull-nose pieces of passes along x over the wave, the axis on the normal tilted
    ahead by ``lead`` (turning along each pass: runs of many pieces, halved)."""
    ys = np.arange(-3.0, 3.01, pass_step_mm)
    xs = np.arange(-1.0, 9.0, step_mm)
    x, y = np.meshgrid(xs, ys)
    x, y = x.ravel(), y.ravel()
    axis = _normals(x, y) + np.array([lead, 0.0, 0.0])
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    # the corner's centre a corner radius off the surface, the core's bottom centre in
    # from it by the core radius, away from the surface normal's side
    n = _normals(x, y)
    side = n - (n * axis).sum(axis=1)[:, None] * axis
    norm = np.linalg.norm(side, axis=1)
    side = np.where(norm[:, None] > 1e-12, side / np.maximum(norm, 1e-300)[:, None], 0.0)
    tips = np.column_stack((x, y, _wave(x, y) + 0.004))
    corner = tips + CORNER_MM * n
    a_all = corner - (RADIUS_MM - CORNER_MM) * side
    starts = np.ones(x.shape[0], dtype=bool)
    starts[np.arange(x.shape[0]) % xs.shape[0] == xs.shape[0] - 1] = False  # pass ends
    k = np.flatnonzero(starts)
    a, e = a_all[k], a_all[k + 1] - a_all[k]
    m = a.shape[0]
    ee = np.einsum("ij,ij->i", e, e)
    return Pieces(a, e, ee, a + 0.5 * e, 0.5 * np.sqrt(ee), np.arange(m, dtype=np.int64),
                  np.zeros(m, dtype=bool), axis[k], np.full(m, np.nan), np.full(m, np.nan),
                  np.zeros(1), np.zeros(1, dtype=np.int64), np.full(m, HEIGHT_MM))


def _row_dexels(rng, rows=12, per_row=150, spacing_mm=0.05):
    """Dexels on the wave along rows in x (neighbours next in order), on its normals."""
    x = np.concatenate([rng.uniform(0.0, 1.0) + spacing_mm * np.arange(per_row)
                        for _ in range(rows)])
    y = np.repeat(rng.uniform(-2.5, 2.5, rows), per_row)
    points = np.column_stack((x, y, _wave(x, y)))
    return points, _normals(x, y)


def _search(pieces, points, dirs, reach_mm, *, compiled):
    none = pieces.taken(np.zeros(pieces.size, dtype=bool))
    index = SweepIndex(pieces, none, RADIUS_MM, points.min(0), points.max(0), 1.0, 10.0,
                       corner_radius_mm=CORNER_MM, compiled=compiled)
    reach = np.full(points.shape[0], reach_mm)
    return index.search("near", points, dirs, points + CORNER_MM * dirs, reach)


def _walked(monkeypatch, pieces, points, dirs, reach_mm, **how):
    with monkeypatch.context() as m:
        m.setattr(dexels_module, "lowest_sweep_entries",
                  functools.partial(lowest_sweep_entries, **how))
        return _search(pieces, points, dirs, reach_mm, compiled=True)


def _assert_same(fast, exact):
    assert np.array_equal(fast.lam_mm, exact.lam_mm)
    assert np.array_equal(fast.piece, exact.piece)
    assert np.array_equal(fast.behind, exact.behind)


# a short reach leaves out pieces that would cut: the candidates' edge decides values
CASES = [(0.0, 3.5), (0.15, 3.5), (0.15, 0.8), (-0.2, 0.8)]


@pytest.mark.parametrize(("lead", "reach_mm"), CASES)
def test_grouped_walk_meets_each_dexels_own_runs(rng, monkeypatch, lead, reach_mm):
    pieces = _five_axis_passes(lead=lead)
    points, dirs = _row_dexels(rng)
    grouped = _search(pieces, points, dirs, reach_mm, compiled=True)
    exact = _search(pieces, points, dirs, reach_mm, compiled=False)
    alone = _walked(monkeypatch, pieces, points, dirs, reach_mm, grouped=False)
    assert np.isfinite(exact.lam_mm).mean() > 0.9  # the passes cut the dexels
    _assert_same(grouped, exact)
    # the very runs each dexel's own walk meets: the same floors and pieces measured
    _assert_same(grouped, alone)
    assert grouped.pairs == alone.pairs > 0


@pytest.mark.parametrize(("lead", "reach_mm"), CASES)
def test_seeded_walk_finds_the_pair_searchs_values_and_pieces(rng, monkeypatch, lead,
                                                              reach_mm):
    # the previous dexel's piece measured first: only where a candidate here, and then
    # only as a value to prune by, so the least (value, piece) is the unseeded walk's
    pieces = _five_axis_passes(lead=lead)
    points, dirs = _row_dexels(rng)
    seeded = _search(pieces, points, dirs, reach_mm, compiled=True)
    exact = _search(pieces, points, dirs, reach_mm, compiled=False)
    unseeded = _walked(monkeypatch, pieces, points, dirs, reach_mm, seeded=False)
    _assert_same(seeded, exact)
    _assert_same(seeded, unseeded)
    assert seeded.pairs != unseeded.pairs  # seeds were measured (here a few more pairs)
