"""Compiled helpers of the planner against straightforward numpy (the same numbers)."""

import dataclasses

import numba
import numpy as np
import pytest

from toolpath.planning import EllipticBladeSurface, finishing, passes, rate_limit, scallop
from toolpath.planning.clearance_kernel import bin_samples, clearances
from toolpath.planning.cutters import parse_cutter
from toolpath.planning.linking import distinct_rows
from toolpath.planning.options import FinishingOptions
from toolpath.planning.passes import MERGE_BLOCK, insert_rows
from toolpath.planning.sampling import (
    CHORD_FRACTIONS,
    ball_end_slopes,
    chord_extremes,
    contact_end_slopes,
    cutter_gap,
    point_move_gaps,
)
from toolpath.planning.tool_axis import angle_deg


@pytest.mark.parametrize("shape", [(), (3,)])
@pytest.mark.parametrize("dtype", [float, np.int64, np.int32])  # (8-byte words, bytes)
@pytest.mark.parametrize("share", [0.0, 0.003, 0.3, 1.0])
@pytest.mark.parametrize("size", [500, 3 * MERGE_BLOCK + 7])
def test_merge_places_new_rows_where_asked_and_old_ones_between(shape, dtype, share, size):
    # runs of old rows are copied whole: none, a few new rows, many, all new (and new
    # rows first and last); in one parallel block and in several
    rng = np.random.default_rng(1)
    is_new = rng.random(size) < share
    if 0.0 < share < 1.0:
        is_new[[0, -1]] = True
    old = rng.integers(0, 1000, size=((~is_new).sum(), *shape)).astype(dtype)
    new = rng.integers(1000, 2000, size=(is_new.sum(), *shape)).astype(dtype)
    want = np.empty((size, *shape), dtype=dtype)
    want[~is_new], want[is_new] = old, new
    new_at = np.flatnonzero(is_new)
    np.testing.assert_array_equal(insert_rows(old, new, new_at), want)
    with pytest.raises(ValueError, match="increasing places"):  # one place too many
        insert_rows(old, new, np.r_[new_at, size - 1])
    if new_at.size > 1:
        with pytest.raises(ValueError, match="increasing places"):
            insert_rows(old, new, new_at[::-1])
    with pytest.raises(ValueError, match="cannot go among rows"):  # rows of another shape
        insert_rows(old, new[..., None], new_at)


def test_samples_binned_by_cell_in_a_stable_order():
    # the counting sort equals a stable argsort of the cell ids, with each cell's box of
    # samples; no samples, no cells hit
    rng = np.random.default_rng(2)
    points = np.round(rng.uniform(-20.0, 20.0, size=(5000, 3)), 1)  # ties in every cell
    cells = bin_samples(points, 3.0)
    ijk = np.minimum(((points - cells.origin) / cells.cell_mm).astype(np.int64),
                     cells.shape - 1)
    cell_id = ijk[:, 0] + cells.shape[0] * (ijk[:, 1] + cells.shape[1] * ijk[:, 2])
    order = np.argsort(cell_id, kind="stable")
    np.testing.assert_array_equal(cells.index, order)
    np.testing.assert_array_equal(cells.points, points[order])
    np.testing.assert_array_equal(
        cells.cell_start, np.searchsorted(cell_id[order], np.arange(cells.shape.prod() + 1)))
    for cid in np.unique(cell_id)[::7]:  # each cell's samples' box; empty cells none
        inside = points[cell_id == cid]
        np.testing.assert_array_equal(cells.box[cid], np.r_[inside.min(0), inside.max(0)])
    empty_cells = np.setdiff1d(np.arange(cells.shape.prod()), cell_id)
    assert (cells.box[empty_cells, :3] == np.inf).all()
    assert (cells.box[empty_cells, 3:] == -np.inf).all()
    # each column's lowest and highest occupied z index
    column = ijk[:, 0] + cells.shape[0] * ijk[:, 1]
    for col in range(cells.shape[0] * cells.shape[1]):
        z = ijk[column == col, 2]
        want = [z.min(), z.max()] if z.size else [1, 0]
        np.testing.assert_array_equal(cells.column[col], want)
    empty = bin_samples(np.zeros((0, 3)), 3.0)
    tips = rng.normal(size=(4, 3))
    near, far, _, _ = clearances(empty, tips, np.tile([0.0, 0.0, 1.0], (4, 1)), None, 3.0,
                                 15.0, 3.1, 3.0, 3.0, 18.0, 6.0)
    assert np.isinf(near).all() and np.isinf(far).all()


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_sample_not_finite_is_named_not_binned(bad):
    # (binned, a NaN sample's cell index ran out of the cells' arrays: the process crashed)
    points = np.random.default_rng(5).normal(size=(50, 3))
    points[17, 1] = bad
    with pytest.raises(ValueError, match="sample 17 of 50 is not finite"):
        bin_samples(points, 3.0)


def test_repeated_toolpath_points_dropped_and_axes_made_unit():
    rng = np.random.default_rng(3)
    pts = np.repeat(rng.normal(size=(50, 3)), rng.integers(1, 4, size=50), axis=0)
    pts[5] = pts[4] + 1e-10  # within a nanometre: a repeat
    axes = rng.normal(size=pts.shape)
    keep = np.r_[True, np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-9]
    want_pts = pts[keep]
    want_axes = axes[keep] / np.linalg.norm(axes[keep], axis=1, keepdims=True)
    kept = np.empty(len(pts), dtype=np.int64)
    m = distinct_rows(pts, axes, kept)
    assert m == keep.sum()
    np.testing.assert_array_equal(kept[:m], np.flatnonzero(keep))
    np.testing.assert_array_equal(pts[:m], want_pts)
    np.testing.assert_allclose(axes[:m], want_axes, rtol=0.0, atol=1e-15)


@pytest.mark.parametrize("linking", ["zigzag", "oneway"])
def test_runs_in_cutting_order(linking):
    # runs on a closed section: gaps in the kept points, one run joined across the seam;
    # passes cut backwards take their runs last to first, each reversed
    surface, cutter = EllipticBladeSurface(), parse_cutter("ball:6")
    opts = FinishingOptions(scallop_mm=0.005, chord_tol_mm=0.01, linking=linking)
    res = opts.resolved(cutter, 0.0)
    direction = np.array([1, -1, 1]) if linking == "zigzag" else np.ones(3, dtype=np.int64)
    layout = passes.PassLayout(np.array([0.3, 0.5, 0.7]), np.array([0.3, 0.5, 0.7]),
                               direction)
    t, pid = np.tile(np.linspace(0.0, 1.0, 21), 3), np.repeat(np.arange(3), 21)
    pts = passes.evaluate_points(surface, cutter, opts, res, layout, t, pid)
    keep = np.ones(len(pts), dtype=bool)
    # passes 0 and 2 wrap round the seam, pass 1 (not kept at t = 0) does not
    keep[[5, 6, 21 + 0, 21 + 10, 42 + 8, 42 + 15]] = False
    runs = finishing._runs_of(keep, pts, closed=True)
    made = finishing._make_runs(surface, cutter, opts, res, pts, runs)
    want = []
    for p in range(3):
        mine = [r for r in runs if pts.pid[r[0]] == p]
        want += [r[::-1] for r in mine[::-1]] if direction[p] < 0 else mine
    assert len(made) == len(want) == 5
    for run, rows in zip(made, want, strict=True):
        np.testing.assert_array_equal(run.tips, pts.tips[rows])
        np.testing.assert_array_equal(run.axes, pts.axes[rows])
        assert run.pass_index == pts.pid[rows[0]]
        np.testing.assert_array_equal(run.feed_end, pts.feed_dirs[rows[-1]])
        np.testing.assert_array_equal(run.normal_start, pts.frame.normal[rows[0]])
    assert sum(not (np.abs(np.diff(rows)) == 1).all() for rows in want) == 2  # the seams


@numba.njit
def _dense_model_extremes(coef, grid):
    """Each row's gap model ``u (1 - u) (c0 + c1 u + c2 u^2)`` at every ``u`` of ``grid``:
    its lowest, highest and the first ``u`` index of the lowest.

    The same floats as the model over all rows at once in numpy (the same operations in
    the same order), a point at a time: without the rows-by-grid arrays (~6 s in numpy
    for 10,000 rows of 20,001 points).
    """
    m = coef.shape[0]
    lowest, highest = np.empty(m), np.empty(m)
    where_lowest = np.empty(m, dtype=np.intp)
    for i in range(m):
        c0, c1, c2 = coef[i, 0], coef[i, 1], coef[i, 2]
        low, high, at = np.inf, -np.inf, 0
        for j in range(grid.size):
            u = grid[j]
            value = u * (1.0 - u) * (c0 + c1 * u + c2 * u ** 2)
            if value < low:
                low, at = value, j
            high = max(high, value)
        lowest[i], highest[i], where_lowest[i] = low, high, at
    return lowest, highest, where_lowest


def test_the_compiled_dense_model_is_the_model_over_all_rows_in_numpy():
    # _dense_model_extremes against the model on the dense grid in numpy (the test below's
    # oracle as it was), the same floats and places; fails if the compiled one took the
    # last of equal lowest values or dropped the u (1 - u) factor
    rng = np.random.default_rng(4)
    coef = rng.normal(scale=0.01, size=(200, 3))
    coef[:3] = 0.0  # (the model 0 everywhere: the first u is the lowest's)
    grid = np.linspace(0.0, 1.0, 20_001)
    model = grid * (1.0 - grid) * (coef[:, :1] + coef[:, 1:2] * grid + coef[:, 2:] * grid ** 2)
    lowest, highest, where_lowest = _dense_model_extremes(coef, grid)
    np.testing.assert_array_equal(lowest, model.min(axis=1))
    np.testing.assert_array_equal(highest, model.max(axis=1))
    np.testing.assert_array_equal(where_lowest, model.argmin(axis=1))


def test_chord_extremes_over_the_model_and_the_samples_in_parallel_blocks():
    # more rows than one parallel block; the model's extremes on a dense grid (dips within
    # the first or last twentieth of the move, which the coarse grid's ends hide, and bumps
    # between two of its samples too), and with the samples the measured gaps too (their
    # place stays the model's)
    rng = np.random.default_rng(4)
    gaps = rng.normal(scale=0.01, size=(10_000, 3))
    u = np.asarray(CHORD_FRACTIONS)
    basis = (u * (1.0 - u))[:, None] * np.stack([np.ones_like(u), u, u * u], axis=1)
    coef = np.linalg.solve(basis, gaps.T).T
    grid = np.linspace(0.0, 1.0, 20_001)
    # the model on the dense grid (_dense_model_extremes): its lowest, highest and where
    lowest, highest, where_lowest = _dense_model_extremes(coef, grid)
    low, u_low, high, u_high = chord_extremes(gaps)
    # never above the dense grid's lowest, below it by its resolution at most
    assert (low <= lowest + 1e-12).all() and (low > lowest - 1e-8).all()
    assert (high >= highest - 1e-12).all() and (high < highest + 1e-8).all()
    def at(x):
        return x * (1.0 - x) * (coef[:, 0] + coef[:, 1] * x + coef[:, 2] * x * x)

    np.testing.assert_allclose(at(u_low), low, rtol=0.0, atol=1e-15)
    np.testing.assert_allclose(at(u_high), high, rtol=0.0, atol=1e-15)
    assert ((where_lowest < 1000) & (low < -1e-6)).sum() > 20  # dips near the ends
    low_s, u_low_s, high_s, u_high_s = chord_extremes(gaps, with_samples=True)
    np.testing.assert_array_equal(low_s, np.minimum(low, gaps.min(axis=1)))
    np.testing.assert_array_equal(high_s, np.maximum(high, gaps.max(axis=1)))
    np.testing.assert_array_equal(u_low_s, u_low)
    np.testing.assert_array_equal(u_high_s, u_high)


def test_chord_extremes_from_end_slopes_and_one_gap_are_the_same_model():
    # g'(0) = a, g'(1) = -(a + b + c) and g(1/2) fix the model the three gaps fix
    rng = np.random.default_rng(5)
    coef = rng.normal(scale=0.01, size=(5_000, 3))
    def at(x):
        return x * (1.0 - x) * (coef[:, 0] + coef[:, 1] * x + coef[:, 2] * x * x)

    three = np.stack([at(x) for x in CHORD_FRACTIONS], axis=1)
    slopes = np.stack([coef[:, 0], -coef.sum(axis=1)], axis=1)
    mid = at(0.5)[:, None]
    from_slopes = chord_extremes(mid, (0.5,), end_slopes=slopes)
    for a, b in zip(chord_extremes(three), from_slopes, strict=True):
        np.testing.assert_allclose(a, b, rtol=0.0, atol=1e-12)
    low, _, high, _ = chord_extremes(mid, (0.5,), end_slopes=slopes, with_samples=True)
    assert (low <= mid[:, 0]).all() and (high >= mid[:, 0]).all()  # the slopes are no samples
    with pytest.raises(ValueError, match="three conditions, got 5"):
        chord_extremes(three, end_slopes=slopes)
    for empty in (chord_extremes(np.zeros((0, 3))),
                  chord_extremes(np.zeros((0, 1)), (0.5,), end_slopes=np.zeros((0, 2)))):
        assert all(x.shape == (0,) for x in empty)


def _two_passes(spec, axis_mode):
    """Two passes of 40 points on the elliptic blade: surface, cutter, points, the rows
    that start a move."""
    surface, cutter = EllipticBladeSurface(), parse_cutter(spec)
    opts = FinishingOptions(scallop_mm=0.005, chord_tol_mm=0.01, axis_mode=axis_mode,
                            lead_deg=10.0 if axis_mode == "lead-tilt" else 0.0)
    res = opts.resolved(cutter, 0.0)
    layout = passes.PassLayout(np.array([0.3, 0.6]), np.array([0.3, 0.6]), np.array([1, 1]))
    t, pid = np.tile(np.linspace(0.2, 0.8, 40), 2), np.repeat(np.arange(2), 40)
    pts = passes.evaluate_points(surface, cutter, opts, res, layout, t, pid)
    return surface, cutter, pts, np.flatnonzero(pts.same_pass)


@pytest.mark.parametrize("axis_mode", ["3", "lead-tilt"])
def test_ball_end_slopes_are_the_gap_slopes_at_the_ends(axis_mode):
    # the ball's gap measured just inside each end of real moves (3-axis, and lead-tilt
    # whose axis turns along the move) against the slope from the ends alone
    surface, cutter, pts, first = _two_passes("ball:6", axis_mode)
    slopes = ball_end_slopes(cutter.radius_mm, pts.tips, pts.axes, pts.frame.normal, first)
    h = 1e-4
    gaps, _, _ = point_move_gaps(surface, cutter, pts.tips, pts.axes, pts.t, pts.s, first,
                                 np.array([h, 1.0 - h]), newton=8)
    measured = np.stack([gaps[:, 0] / h, -gaps[:, 1] / h], axis=1)
    scale = np.abs(slopes).max()
    assert scale > 1e-3  # (moves that bend, in and out)
    np.testing.assert_allclose(slopes, measured, rtol=0.0, atol=5e-4 * scale)
    assert (slopes[:, 0] < 0).any() and (slopes[:, 1] > 0).any()


@pytest.mark.parametrize("spec", ["flat:6", "bull:8:1"])
@pytest.mark.parametrize("axis_mode", ["3", "lead-tilt"])
def test_disc_end_slopes_are_the_gap_slopes_at_the_ends(spec, axis_mode):
    # a flat or bull-nose cutter's gap is the lowest over its disc; by the envelope theorem
    # its slope at an end is the rate of the distance at the lowest point held on the
    # moving cutter: against the gap measured just inside each end (3-axis; lead-tilt,
    # whose axis turns along the move and swings the contact round the rim)
    surface, cutter, pts, first = _two_passes(spec, axis_mode)
    r = cutter.corner_radius_mm
    gap, t_foot, s_foot = cutter_gap(surface, cutter, pts.tips, pts.axes, pts.t, pts.s,
                                     newton=8, refine_rim=True)
    foot, normal = surface.points_and_normals(t_foot, s_foot)
    off_axis = foot + (gap + r)[:, None] * normal - pts.tips - r * pts.axes
    assert np.abs(np.einsum("ij,ij->i", off_axis, pts.axes)).max() < 1e-6  # (in the disc)
    slopes = contact_end_slopes(r, pts.tips, pts.axes, normal, off_axis, first)
    h = 1e-4
    gaps, _, _ = point_move_gaps(surface, cutter, pts.tips, pts.axes, pts.t, pts.s, first,
                                 np.array([0.0, h, 1.0 - h, 1.0]), newton=8, refine_rim=True)
    measured = np.stack([(gaps[:, 1] - gaps[:, 0]) / h, (gaps[:, 3] - gaps[:, 2]) / h], axis=1)
    scale = np.abs(slopes).max()
    assert scale > 1e-3  # (moves that bend, in and out)
    np.testing.assert_allclose(slopes, measured, rtol=0.0, atol=2e-3 * scale)
    # the axis's turn counts: a ball's formula at the corner circle's centre (the contact
    # taken on the axis) is off where the axis turns
    on_axis = contact_end_slopes(r, pts.tips, pts.axes, normal, np.zeros((0, 3)), first)
    turned = np.abs(on_axis - measured).max() > 0.05 * scale
    assert turned == (axis_mode == "lead-tilt")


@pytest.mark.parametrize("axis_mode", ["3", "lead-tilt"])
def test_chord_check_keeps_the_points_and_leaves_every_move_within_the_tolerance(axis_mode):
    # the points given stay where they are (new ones go strictly inside the split moves),
    # the mask travels along (new points kept), and every move between kept points, measured
    # at many places with several Newton steps, cuts no deeper than the chord tolerance and
    # stands no higher than the undercut allowance; the reported error is the worst of them
    surface, cutter = EllipticBladeSurface(), parse_cutter("ball:6")
    opts = FinishingOptions(scallop_mm=0.005, chord_tol_mm=0.01, axis_mode=axis_mode,
                            lead_deg=10.0 if axis_mode == "lead-tilt" else 0.0)
    res = opts.resolved(cutter, 0.0)
    levels = np.linspace(0.1, 0.9, 5)
    layout = passes.PassLayout(levels, levels, np.array([1, -1, 1, -1, 1]))
    t, pid = np.tile(np.linspace(0.0, 1.0, 30), 5), np.repeat(np.arange(5), 30)
    start = passes.evaluate_points(surface, cutter, opts, res, layout, t, pid)
    keep = (start.t < 0.45) | (start.t > 0.55) if axis_mode == "3" else None
    out = passes.refine_chords(surface, cutter, opts, res, layout, start, keep=keep)
    pts = out.points
    assert len(pts) > len(start) + 100
    old = np.flatnonzero(np.isin(np.round(pts.t * 1e12) + 1e13 * pts.pid,
                                 np.round(start.t * 1e12) + 1e13 * start.pid))
    assert old.size == len(start)
    for name in ("t", "pid", "axes", "tips"):
        np.testing.assert_array_equal(getattr(pts, name)[old], getattr(start, name))
    assert (np.diff(pts.pid) >= 0).all() and (np.diff(pts.t)[pts.same_pass] > 0).all()
    if keep is None:
        assert out.keep is None
    else:
        np.testing.assert_array_equal(out.keep[old], keep)
        assert out.keep[np.setdiff1d(np.arange(len(pts)), old)].all()
    ok = out.keep if out.keep is not None else np.ones(len(pts), dtype=bool)
    moves = np.flatnonzero(pts.same_pass & ok[:-1] & ok[1:])
    fractions = np.linspace(0.05, 0.95, 19)
    gaps, _, _ = point_move_gaps(surface, cutter, pts.tips, pts.axes, pts.t, pts.s, moves,
                                 fractions, newton=6)
    deepest, highest = -float(gaps.min()), float(gaps.max())
    assert deepest <= 1.02 * res.planned_chord_tol_mm
    assert highest <= 1.02 * max(res.undercut_mm, res.planned_chord_tol_mm)
    assert 0.9 * max(deepest, highest) <= out.worst_mm <= res.planned_chord_tol_mm


def test_reach_boundary_is_the_last_reachable_parameter_to_the_precision_of_bisection():
    # n . a less its limit along t: crossing 0 at known places, gently and steeply (a
    # leading edge turns the normal by half a turn between two points)
    roots = np.array([0.3, 0.52, 0.7071, 0.9])
    steep = np.array([1.0, 40.0, 1.0, 400.0])

    def height(t, rows):
        return np.tanh(steep[rows] * (roots[rows] - t))  # reachable below the root

    good, bad = np.array([0.2, 0.5, 0.6, 0.85]), np.array([0.4, 0.6, 0.8, 0.95])
    t = passes._reach_boundary(height, good, bad, height(good, np.arange(4)),
                               height(bad, np.arange(4)))
    assert (height(t, np.arange(4)) >= 0.0).all()
    # (within the height's tolerance: the slope at the root is steep)
    assert np.all(t <= roots) and np.all(roots - t < 1e-12 + passes.REACH_HEIGHT_TOL / steep)
    # (the other way round: reachable above the root)
    t = passes._reach_boundary(lambda t, rows: -height(t, rows), bad, good,
                               -height(bad, np.arange(4)), -height(good, np.arange(4)))
    assert np.all(t >= roots) and np.all(t - roots < 1e-12 + passes.REACH_HEIGHT_TOL / steep)


@pytest.mark.parametrize("shape", ["step", "crease", "flat zero", "on the boundary"])
def test_reach_boundary_where_the_secant_stalls(shape):
    # a step (a crease between a face and a wall at the margin), a kink, a cubic zero, and
    # a reachable end exactly on the boundary: the bracket still closes in (bisection
    # takes over), or the height is within its tolerance at a point evaluated, never an end
    root = 0.3 + 1e-3 * np.pi
    heights = {"step": lambda t: np.where(t < root, 1.0, -1e-6),
               "crease": lambda t: np.where(t < root, 1e-3 * (root - t), 10.0 * (root - t)),
               "flat zero": lambda t: (root - t) ** 3,
               "on the boundary": lambda t: root - t}
    height = heights[shape]
    good = np.array([root if shape == "on the boundary" else 0.2])
    bad = np.array([0.4])
    t = passes._reach_boundary(lambda t, rows: height(t), good, bad, height(good),
                               height(bad))
    h = height(t)
    assert h[0] >= 0.0
    assert root - t[0] <= 2.0 ** -40 * 0.2 + 1e-15 or h[0] <= passes.REACH_HEIGHT_TOL
    # (a reachable end on the boundary is the boundary: reach_split adds no point there)
    assert (t[0] == good[0]) == (shape == "on the boundary")


def test_least_rate_of_a_tube_is_the_steepest_pair_and_fits_it():
    # the least rate at which a path fits [lo, hi]: the largest (lo[k] - hi[j]) / |x[k] -
    # x[j]| over all pairs (brute force here); a path fits at it, none a little below
    rng = np.random.default_rng(4)
    for _ in range(500):
        n = int(rng.integers(2, 60))
        x = np.cumsum(rng.uniform(0.01, 1.0, n))
        centre = np.cumsum(rng.normal(0.0, 1.0, n))
        half = rng.uniform(0.0, 0.5, n)
        lo, hi = centre - half, centre + half
        rate = rate_limit._least_rate(x, lo, hi)
        apart = np.abs(x[:, None] - x[None, :])
        np.fill_diagonal(apart, np.inf)
        want = max(0.0, float(((lo[:, None] - 1e-12 - hi[None, :]) / apart).max()))
        assert rate == pytest.approx(want, rel=1e-12, abs=1e-15)
        phi = np.empty(n)
        assert rate_limit._rate_tube(x, lo, hi, centre, rate * (1.0 + 1e-12), False, phi)
        if rate > 1e-6:
            assert not rate_limit._rate_tube(x, lo, hi, centre, rate * (1.0 - 1e-6), False,
                                             phi)
    # a repeated x: left to the bisection
    assert rate_limit._least_rate(np.array([0.0, 1.0, 1.0]), np.zeros(3), np.ones(3)) == np.inf


def test_chord_check_splits_a_flat_face_whose_lean_swings_round_the_normal():
    # round a propeller's leading edge the axes' lean swung from ahead to behind and beside
    # between two points (the tilt joint's travel leaning them back): splitting that move
    # slerped the axes, the slerp leaned less than the lead, the lead was put back, and
    # every new point stood at the first end: the move stayed whole, its tip jumping 5 mm,
    # and the program cut 5.5 mm into the edge. Here one pass's axes lean 130 degrees round
    # from its feed from a point on: the move onto it is split until every part is within
    # the tolerance, none left stalled, the tip moving round in small steps
    surface, cutter = EllipticBladeSurface(), parse_cutter("flat:6")
    opts = FinishingOptions(scallop_mm=0.005, chord_tol_mm=0.01, axis_mode="lead-tilt",
                            lead_deg=10.0, max_points=20_000)
    res = opts.resolved(cutter, 0.0)
    levels = np.linspace(0.1, 0.9, 5)
    layout = passes.PassLayout(levels, levels, np.array([1, -1, 1, -1, 1]))
    t, pid = np.tile(np.linspace(0.0, 1.0, 30), 5), np.repeat(np.arange(5), 30)
    start = passes.evaluate_points(surface, cutter, opts, res, layout, t, pid)
    assert start.smoothing is not None
    swung = (start.pid == 2) & (start.t > 0.3) & (start.t < 0.45)
    n = start.frame.normal[swung]
    f = start.frame.e1[swung] * start.direction[swung][:, None]
    f -= np.einsum("ij,ij->i", f, n)[:, None] * n
    f /= np.linalg.norm(f, axis=1, keepdims=True)
    th, ph = np.radians(10.0), np.radians(130.0)
    axes = start.axes.copy()
    axes[swung] = np.cos(th) * n + np.sin(th) * (np.cos(ph) * f + np.sin(ph) * np.cross(n, f))
    tips = cutter.tips_from_contacts(start.frame.point, start.frame.normal, axes)
    start = dataclasses.replace(start, axes=axes, tips=tips,
                                smoothing=dataclasses.replace(start.smoothing, axes=axes))
    first = int(np.flatnonzero(swung)[0])
    assert np.linalg.norm(tips[first] - tips[first - 1]) > 4.0
    out = passes.refine_chords(surface, cutter, opts, res, layout, start)
    pts = out.points
    assert out.n_stalled == 0 and out.worst_mm <= res.planned_chord_tol_mm
    onto = (pts.pid == 2) & (pts.t > start.t[first - 1]) & (pts.t < start.t[first])
    assert onto.sum() >= 8
    rows = np.flatnonzero(onto)
    rows = np.r_[rows[0] - 1, rows]
    steps = np.linalg.norm(np.diff(pts.tips[np.r_[rows, rows[-1] + 1]], axis=0), axis=1)
    assert steps.max() < 1.5
    lean = angle_deg(pts.axes[onto], pts.frame.normal[onto])  # (the ends': 10.08, 10)
    assert lean.min() > 10.0 - 1e-6 and lean.max() < 10.1
    gaps, _, _ = point_move_gaps(surface, cutter, pts.tips, pts.axes, pts.t, pts.s, rows,
                                 np.linspace(0.05, 0.95, 19), newton=6)
    assert -gaps.min() <= 1.02 * res.planned_chord_tol_mm


def test_planned_chord_error_counts_the_unchecked_splits_when_the_rounds_run_out():
    # with one round only, the split moves' parts are never checked: the estimate keeps
    # their whole moves' gaps (over the tolerance), not only the moves left whole
    surface, cutter = EllipticBladeSurface(), parse_cutter("ball:6")
    opts = FinishingOptions(scallop_mm=0.005, chord_tol_mm=0.01, axis_mode="lead-tilt",
                            lead_deg=10.0)
    res = opts.resolved(cutter, 0.0)
    levels = np.linspace(0.1, 0.9, 5)
    layout = passes.PassLayout(levels, levels, np.array([1, -1, 1, -1, 1]))
    t, pid = np.tile(np.linspace(0.0, 1.0, 30), 5), np.repeat(np.arange(5), 30)
    start = passes.evaluate_points(surface, cutter, opts, res, layout, t, pid)
    settled = passes.refine_chords(surface, cutter, opts, res, layout, start).worst_mm
    assert 0.9 * res.planned_chord_tol_mm < settled <= res.planned_chord_tol_mm
    cut_short = passes.refine_chords(surface, cutter, opts, res, layout, start,
                                     max_rounds=1).worst_mm
    assert cut_short > res.planned_chord_tol_mm


def _five_flat_passes():
    """Five passes of 30 points on the elliptic blade, flat:6, 3-axis (the stall tests')."""
    surface, cutter = EllipticBladeSurface(), parse_cutter("flat:6")
    opts = FinishingOptions(scallop_mm=0.005, chord_tol_mm=0.01, max_points=20_000)
    res = opts.resolved(cutter, 0.0)
    levels = np.linspace(0.1, 0.9, 5)
    layout = passes.PassLayout(levels, levels, np.array([1, -1, 1, -1, 1]))
    t, pid = np.tile(np.linspace(0.0, 1.0, 30), 5), np.repeat(np.arange(5), 30)
    start = passes.evaluate_points(surface, cutter, opts, res, layout, t, pid)
    return surface, cutter, opts, res, layout, start


def test_chord_check_stops_splitting_moves_whose_gap_does_not_fall_with_their_length(
        monkeypatch):
    # the runaway of a flat end on a propeller (--on-gouge lift): over a stretch the gap
    # measured inside every move stood 1 mm deep whatever the move's length (a gap read
    # beside a knife edge), and each round split those moves into up to 8 parts, 12 rounds
    # (16 min, then out of memory). Here a stretch of one pass reads 1 mm deep in every
    # move: its moves are split STALLED_SPLITS times, their parts found stalled and left
    # whole, counted in the planned error; the points stay bounded and the other moves as
    # before. Fails with STALLED_SHARE = inf (or the stalled moves split anyway): too many
    # points. (A ball's moves are never found stalled: its gap falls to 0 at its own
    # locations.)
    surface, cutter, opts, res, layout, start = _five_flat_passes()
    clean = passes.refine_chords(surface, cutter, opts, res, layout, start)
    assert clean.n_stalled == 0
    measured = passes._gap_extremes

    def deep_stretch(surface, cutter, res, pts, idx, machine, q):
        low, high = measured(surface, cutter, res, pts, idx, machine, q)
        inside = (pts.pid[idx] == 2) & (pts.t[idx] >= 0.4) & (pts.t[idx + 1] <= 0.6)
        return np.where(inside, -1.0, low), high

    def deep_ends(surface, cutter, pts, idx):  # (at length 0 too)
        inside = (pts.pid[idx] == 2) & (pts.t[idx] >= 0.4) & (pts.t[idx + 1] <= 0.6)
        return np.where(inside, 1.0, 0.0)

    monkeypatch.setattr(passes, "_gap_extremes", deep_stretch)
    monkeypatch.setattr(passes, "_end_gaps_mm", deep_ends)
    out = passes.refine_chords(surface, cutter, opts, res, layout, start)
    in_stretch = (start.pid == 2) & (start.t >= 0.4) & (start.t <= 0.6)
    moves = int(in_stretch.sum()) - 1
    assert out.n_stalled >= moves and out.stalled_mm == 1.0 and out.worst_mm == 1.0
    # split STALLED_SPLITS times (into MAX_PARTS each; a move either side of the stretch
    # too), then left whole
    assert len(out.points) <= (len(clean.points)
                               + passes.MAX_PARTS ** passes.STALLED_SPLITS * (moves + 1))



def test_a_move_whose_ends_sit_on_the_surface_is_split_until_its_gap_falls(monkeypatch):
    # a joint move on head-table-bc (dev_rotor_dca flat:6) read 0.127 mm against 0.05 three
    # splits down, more than its line's first move (the splits even in t, the axes' turn
    # gathered in one part): left whole as stalled, it cut 0.79 mm (toolpath verify). Its
    # ends sat on the surface: the gap was the chord's. Here one move of a pass reads 1 mm
    # deep in every part longer than three splits leave it, its ends read for real (on the
    # surface): it is split a fourth time, and its parts are then clean. Fails if the
    # stall rule ignores the ends (the move left whole: n_stalled > 0, worst 1 mm).
    surface, cutter, opts, res, layout, start = _five_flat_passes()
    measured = passes._gap_extremes
    longest = (1.0 / 29) / passes.MAX_PARTS ** passes.STALLED_SPLITS  # three splits down

    def deep_until_short(surface, cutter, res, pts, idx, machine, q):
        low, high = measured(surface, cutter, res, pts, idx, machine, q)
        inside = (pts.pid[idx] == 2) & (pts.t[idx] >= 0.41) & (pts.t[idx + 1] <= 0.45)
        return np.where(inside & (pts.t[idx + 1] - pts.t[idx] > 0.75 * longest), -1.0,
                        low), high

    monkeypatch.setattr(passes, "_gap_extremes", deep_until_short)
    out = passes.refine_chords(surface, cutter, opts, res, layout, start)
    assert out.n_stalled == 0 and out.worst_mm <= res.planned_chord_tol_mm
    pts = out.points
    stretch = (pts.pid == 2) & (pts.t > 0.41) & (pts.t < 0.45)
    assert stretch.sum() >= passes.MAX_PARTS ** (passes.STALLED_SPLITS + 1) - 1


def test_moves_split_for_the_tilt_cap_alone_stop_at_motion_splits(monkeypatch):
    # where neighbouring contacts' axes jump (each inserted point leaned back within the
    # tilt cap by its own need: a short cut of dev_rotor_dca on head-table-bc, flat:6), a
    # move's middle leans past the cap however short it is split, and every round split
    # such moves in two: 0.45 to 0.93 million points, 15 minutes in the chord check. Here
    # a stretch of one pass reads past the cap in every move: its moves are split
    # MOTION_SPLITS times, then left whole; the other moves as before. Fails without the
    # depth limit: too many points.
    surface, cutter, opts, res, layout, start = _five_flat_passes()
    clean = passes.refine_chords(surface, cutter, opts, res, layout, start)

    def past_in_stretch(res, pts, idx):
        return (pts.pid[idx] == 2) & (pts.t[idx] >= 0.4) & (pts.t[idx + 1] <= 0.6)

    monkeypatch.setattr(passes, "middle_past_tilt", past_in_stretch)
    out = passes.refine_chords(surface, cutter, opts, res, layout, start)
    in_stretch = (start.pid == 2) & (start.t >= 0.4) & (start.t <= 0.6)
    moves = int(in_stretch.sum()) - 1
    # each stretch move split MOTION_SPLITS times (at least in two), then no more: without
    # the limit the rounds go on doubling them past max_points (a PlanningError)
    added = len(out.points) - len(clean.points)
    assert added >= moves * (2 ** passes.MOTION_SPLITS - 1)
    assert out.worst_mm == clean.worst_mm and out.n_stalled == 0


def test_a_move_is_stalled_only_once_its_splits_have_shrunk_it():
    # three splits down, a gap still above STALLED_SHARE of its line's first is left whole
    # only if the splits shrank the move to STALLED_TRAVEL_SHARE of the first's travel: a
    # blunt leading edge's turn gathered at one end of a move stays in one part of the
    # even splits (its travel 70 % of the first's three splits down) and goes on
    cutter = parse_cutter("bull:6:1")
    over, origin = np.array([1.7, 1.7, 1.7, 1.7]), np.array([1.66, 1.66, 1.66, 1.66])
    depth = np.array([3, 3, 2, 3])
    travel, origin_travel = np.array([1.29, 0.2, 0.2, 0.9]), np.full(4, 1.83)
    stalled = passes._not_shrunk(cutter, over, origin, depth, travel, origin_travel)
    # (the last: split to half its first's travel, not yet a quarter)
    assert stalled.tolist() == [False, True, False, False]
    # a ball's moves never stall
    assert not passes._not_shrunk(parse_cutter("ball:6"), over, origin, depth, travel,
                                  origin_travel).any()


def test_plan_reports_the_moves_the_chord_check_left_stalled(monkeypatch):
    # the chord check's stalled moves (the test above) reach the plan's report, JSON and
    # text, so a user can tell a gap read beside an edge from a measured chord error. The
    # chord check is made to report 7 stalled moves up to 1 mm (a flat end's plan that
    # stalls takes minutes). Fails if the plan drops RefinedChords.n_stalled or stalled_mm
    # (the report's fields stay 0 and its line is missing).
    refine = finishing.refine_chords

    def stalled(*args, **kwargs):
        return dataclasses.replace(refine(*args, **kwargs), n_stalled=7, stalled_mm=1.0)

    monkeypatch.setattr(finishing, "refine_chords", stalled)
    _, report = finishing.plan_finishing(EllipticBladeSurface(), "ball:6", scallop_mm=0.05,
                                         chord_tol_mm=0.05, measure=False)
    assert (report.n_stalled_moves, report.stalled_gap_mm) == (7, 1.0)
    data = report.as_dict()
    assert (data["n_stalled_moves"], data["stalled_gap_mm"]) == (7, 1.0)
    line = [x for x in report.lines() if x.startswith("chord check")]
    assert line and "7 move(s) left whole" in line[0] and "1.0000 mm" in line[0]

def _greedy_by_search(grid, allowed, lower, scale, lookahead):
    """The greedy walk of pass_levels with np.searchsorted at every step."""
    last = lower.size - 1
    levels, s = [0.0], 0.0
    while s < 1.0:
        j0 = min(max(np.searchsorted(grid, s, side="right") - 1, 0), last)
        ds = scale * (allowed[j0] if s == grid[j0] else lower[j0])
        for _ in range(60):
            hi = min(s + lookahead * ds, 1.0)
            j1 = min(max(np.searchsorted(grid, hi, side="left") - 1, 0), last)
            new = min(ds, scale * lower[j0:j1 + 1].min())
            if new >= ds * (1.0 - 1e-12):
                break
            ds = new
        s = 1.0 if s + ds >= 1.0 - 1e-9 else s + ds
        levels.append(s)
    return levels


def test_greedy_walk_finds_the_probe_levels_a_search_finds():
    # the compiled walk finds probe levels walking forward: the same levels as searching
    rng = np.random.default_rng(11)
    for _ in range(60):
        m = int(rng.integers(2, 40))
        grid = (np.linspace(0.0, 1.0, m) if rng.random() < 0.5
                else np.sort(np.r_[0.0, rng.random(m - 2), 1.0]))
        allowed = rng.uniform(0.003, 0.3, m)
        lower = np.minimum(allowed[:-1], allowed[1:])
        scale, lookahead = float(rng.uniform(0.5, 1.0)), float(rng.choice([1.0, 2.0]))
        levels = np.empty(10_000)
        count = scallop._greedy(grid, allowed, lower, scale, lookahead, levels)
        assert levels[:count].tolist() == _greedy_by_search(grid, allowed, lower, scale,
                                                            lookahead)


def test_joints_of_split_moves_going_on_alone_are_those_along_the_whole_path():
    # the chord check's split moves go on alone (their ends and new points); their joints
    # come from one solve along the whole path, merged as the end merges it back
    from machines import load_machine
    from machines.kinematics import solve_inverse

    surface, cutter = EllipticBladeSurface(), parse_cutter("ball:6")
    opts = FinishingOptions(scallop_mm=0.005, chord_tol_mm=0.01, axis_mode="lead-tilt",
                            lead_deg=10.0)
    res = opts.resolved(cutter, 0.0)
    levels = np.linspace(0.1, 0.9, 4)
    layout = passes.PassLayout(levels, levels, np.array([1, -1, 1, -1]))
    t, pid = np.tile(np.linspace(0.0, 1.0, 25), 4), np.repeat(np.arange(4), 25)
    start = passes.evaluate_points(surface, cutter, opts, res, layout, t, pid)
    split = np.array([0, 1, 7, 30, 31, 60, 98])  # moves split -> split + 1 (same pass)
    split = split[start.same_pass[split]]
    origin = np.unique(np.r_[split, split + 1])
    alone = passes._take_points(start, origin)
    new_t, which = passes.split_evenly(start.t[split], start.t[split + 1],
                                       np.full(split.size, 3))
    alone, where_new, kept = passes.insert_points(surface, cutter, opts, res, layout, alone,
                                                  new_t, start.pid[split][which])
    assert kept
    origin = passes.insert_rows(origin, np.full(where_new.size, -1), np.sort(where_new))
    machine = load_machine("trunnion-ac")
    q = passes._joints_along(machine, start, alone, origin)
    whole, _ = passes._merged_back(start, None, alone, origin)
    full = solve_inverse(machine, whole.tips, whole.axes).joints
    key = np.round(whole.t * 1e12) + 1e13 * whole.pid
    rows = np.searchsorted(key, np.round(alone.t * 1e12) + 1e13 * alone.pid)
    np.testing.assert_array_equal(key[rows], np.round(alone.t * 1e12) + 1e13 * alone.pid)
    np.testing.assert_array_equal(q.joints, full[rows])
    np.testing.assert_array_equal(passes._joints_along(machine, whole, whole, None).joints,
                                  full)
    # given start's own joints (the first round's), the same joints: only the new points'
    # are computed, the others kept where C comes out as before
    known = solve_inverse(machine, start.tips, start.axes)
    again = passes._joints_along(machine, start, alone, origin, known)
    np.testing.assert_array_equal(again.joints, full[rows])
    np.testing.assert_array_equal(again.in_cone, q.in_cone)
