"""Shortcuts of the bull-nose walk (:mod:`verification.sweep_search`) against the pair search.

Each prune skips work only where no piece can leave less than the best value: the walk
must find what the pair search over every candidate finds (``compiled=False``, the
oracle), and skip what the prune says it skips.
"""

import numpy as np
import pytest

from verification.dexels import SweepIndex
from verification.pieces import Pieces

RADIUS_MM, CORNER_MM = 4.0, 1.0
HEIGHT_MM = RADIUS_MM - 2.0 * CORNER_MM


def _passes(tip_z_mm, axis, *, pass_step_mm=0.5, step_mm=0.05, length_mm=12.0):
    """Bull-nose pieces of straight passes along x at ``tip_z_mm``, the cutter on ``axis``."""
    ys = np.arange(-3.0, 3.01, pass_step_mm)
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    xs = np.arange(-1.0, length_mm, step_mm)
    a = np.array([(x, y, tip_z_mm) for y in ys for x in xs]) + CORNER_MM * axis
    e = np.tile([step_mm, 0.0, 0.0], (a.shape[0], 1))
    m = a.shape[0]
    ee = np.einsum("ij,ij->i", e, e)
    return Pieces(a, e, ee, a + 0.5 * e, 0.5 * np.sqrt(ee), np.arange(m, dtype=np.int64),
                  np.zeros(m, dtype=bool), np.tile(axis, (m, 1)), np.full(m, np.nan),
                  np.full(m, np.nan), np.zeros(1), np.zeros(1, dtype=np.int64),
                  np.full(m, HEIGHT_MM))


def _search(pieces, points, dirs, compiled):
    none = pieces.taken(np.zeros(pieces.size, dtype=bool))
    index = SweepIndex(pieces, none, RADIUS_MM, points.min(0), points.max(0), 1.0, 10.0,
                       corner_radius_mm=CORNER_MM, compiled=compiled)
    reach = np.full(points.shape[0], 3.5)
    return index.search("near", points, dirs, points + CORNER_MM * dirs, reach)


def _plate_dexels(rng, n=2000):
    points = np.column_stack((rng.uniform(1.0, 10.0, n), rng.uniform(-2.0, 2.0, n),
                              np.zeros(n)))
    return points, np.tile([0.0, 0.0, 1.0], (n, 1))


@pytest.mark.parametrize("thickness_mm", [0.05, 0.5])
def test_a_cutter_on_the_other_side_of_a_thin_plate_is_skipped_unmeasured(rng, thickness_mm):
    # the cutter machines the plate's underside (tip on it, axis down): along the top's
    # dexels its sweep lies wholly below the design point, so it leaves nothing, and the
    # walk drops every run by its exit bound (reaches) without a Newton floor
    points, dirs = _plate_dexels(rng)
    below = _passes(-thickness_mm, (0.005, 0.002, -1.0))
    fast, exact = (_search(below, points, dirs, compiled) for compiled in (True, False))
    assert np.isinf(exact.lam_mm).all() and np.isinf(fast.lam_mm).all()
    assert exact.pairs > 0  # the pair search met them all
    assert fast.pairs == 0


@pytest.mark.parametrize("tilt", [(0.0, 0.0), (0.2, 0.0), (0.15, -0.1)])
def test_a_plate_cut_on_top_and_underneath_gives_the_pair_searchs_values(rng, tilt):
    # the top pass (tilted: its corner meets the dexels) leaves the material; the
    # underside's cutter, 0.3 mm below, must count for nothing
    points, dirs = _plate_dexels(rng)
    top = _passes(0.01, (tilt[0], tilt[1], 1.0), pass_step_mm=0.7)
    below = _passes(-0.3, (0.02, 0.01, -1.0))
    both = Pieces(*(np.concatenate((getattr(below, f), getattr(top, f)))
                    if f not in ("path_arc_mm", "path_move") else getattr(top, f)
                    for f in Pieces.__dataclass_fields__))
    fast, exact = (_search(both, points, dirs, compiled) for compiled in (True, False))
    assert np.array_equal(np.isinf(fast.lam_mm), np.isinf(exact.lam_mm))
    assert np.isfinite(exact.lam_mm).mean() > 0.9
    assert np.array_equal(fast.lam_mm, exact.lam_mm)
    assert np.array_equal(fast.piece, exact.piece)


def _tangent_dexels(rng, n=20_000):
    """Dexels whose point lies on a tilted piece's flat bottom, running within 1e-11 to
    1e-8 rad of the bottom's plane out of the cutter: one bull-nose piece each."""
    from verification.torus import line_sweep_interval, sweep_entry_bound

    ring_mm = RADIUS_MM - CORNER_MM
    axis = rng.normal(size=(n, 3)) * 0.05 + [0.0, 0.0, 1.0]
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    tip = rng.uniform(-50.0, 50.0, (n, 3))
    u = np.cross(axis, [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u, axis=1)[:, None]
    v = np.cross(axis, u)
    turn, radius = rng.uniform(0.0, 2.0 * np.pi, n), rng.uniform(0.0, 0.9 * ring_mm, n)
    chord = 0.05 * v
    outward = np.cos(turn)[:, None] * u + np.sin(turn)[:, None] * v
    points = tip + rng.uniform(0.0, 1.0, (n, 1)) * chord + radius[:, None] * outward
    dirs = outward - (10.0 ** rng.uniform(-11.5, -8.0, n))[:, None] * axis
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    c0, height = tip + CORNER_MM * axis, np.full(n, HEIGHT_MM)
    _, exit_bound = sweep_entry_bound(points, dirs, c0, chord, axis, height,
                                      core_radius_mm=ring_mm, corner_radius_mm=CORNER_MM)
    lam_in, lam_out = line_sweep_interval(points, dirs, c0, chord, axis, height,
                                          core_radius_mm=ring_mm, corner_radius_mm=CORNER_MM)
    # the exit bound's slab divides a rounding of the point's height by d . a ~ 1e-10
    torn = (exit_bound < -1e-11) & (lam_out > 0.0) & np.isfinite(lam_in)
    return points[torn], dirs[torn], c0[torn], chord[torn], axis[torn]


def test_a_dexel_in_a_pieces_bottom_plane_finds_what_the_pair_search_finds(rng):
    # a lone piece's exit bound can read -1e-6 mm where the point lies on its flat bottom
    # and the dexel runs along it; the pair search decides the piece reaches the point
    # from its distance to it (0), so the walk must not drop it by that bound (a review's
    # case: the walk read inf where the pair search read -5.5 mm)
    cases = _tangent_dexels(rng)
    assert len(cases[0]) >= 10
    for point, d, c0, chord, axis in zip(*(c[:40] for c in cases), strict=True):
        ee = np.array([chord @ chord])
        piece = Pieces(c0[None], chord[None], ee, (c0 + 0.5 * chord)[None],
                       0.5 * np.sqrt(ee), np.zeros(1, dtype=np.int64), np.zeros(1, dtype=bool),
                       axis[None], np.full(1, np.nan), np.full(1, np.nan), np.zeros(1),
                       np.zeros(1, dtype=np.int64), np.full(1, HEIGHT_MM))
        fast, exact = (_search(piece, point[None], d[None], compiled) for compiled in
                       (True, False))
        assert fast.lam_mm[0] == exact.lam_mm[0] and fast.piece[0] == exact.piece[0]
