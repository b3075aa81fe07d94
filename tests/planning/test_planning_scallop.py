"""Stepover from the scallop height: exact circle geometry, and the pass levels."""

import warnings

import numpy as np
import pytest

from toolpath.planning.errors import PlanningError
from toolpath.planning.sampling import CHORD_FRACTIONS, chord_extremes
from toolpath.planning.scallop import pass_levels, scallop_height_mm, stepover_mm


def _cusp_by_bisection(w, rho, k):
    """Oracle: cusp height between two cutter circles on a surface circle, by bisection on
    the bisector (independent of the law-of-cosines formula)."""
    if k == 0.0:
        centre = np.array([w / 2.0, rho])
        lo, hi = 0.0, rho
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            inside = np.hypot(*(np.array([0.0, mid]) - centre)) < rho
            lo, hi = (lo, mid) if inside else (mid, hi)
        return lo
    big = 1.0 / abs(k)
    alpha = w / big
    sign = 1.0 if k < 0 else -1.0  # convex: cutters outside the circle
    centre = (big + sign * rho) * np.array([np.cos(alpha), np.sin(alpha)])
    direction = np.array([np.cos(alpha / 2), np.sin(alpha / 2)])
    lo, hi = 0.0, rho
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        p = (big + sign * mid) * direction
        inside = np.hypot(*(p - centre)) < rho
        lo, hi = (lo, mid) if inside else (mid, hi)
    return lo


@pytest.mark.parametrize("k", [-1 / 5.0, -1 / 50.0, 0.0, 1 / 50.0, 1 / 8.0])
@pytest.mark.parametrize("h", [0.001, 0.01, 0.05])
def test_stepover_leaves_exactly_the_requested_cusp(k, h):
    w = float(stepover_mm(h, 3.0, k))
    assert _cusp_by_bisection(w, 3.0, k) == pytest.approx(h, rel=1e-7, abs=1e-12)
    assert float(scallop_height_mm(w, 3.0, k)) == pytest.approx(h, rel=1e-9)


def test_convex_needs_a_smaller_stepover_than_a_plane_and_concave_a_larger_one():
    flat = stepover_mm(0.005, 3.0, 0.0)
    assert stepover_mm(0.005, 3.0, -0.1) < flat < stepover_mm(0.005, 3.0, 0.1)
    assert stepover_mm(0.005, 3.0, 1 / 2.5) == 0.0  # a 2.5 mm hollow does not fit R 3
    # a flat face on a convex surface: point contacts, the bulge between them
    assert float(stepover_mm(0.01, np.inf, -1 / 40.0)) == pytest.approx(
        2 * np.sqrt(2 * 0.01 * 40.0), rel=1e-3)


def test_stepover_broadcasts_and_has_its_limits_without_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        k = np.array([-1 / 5.0, -1e-9, 0.0, 1e-9, 1 / 50.0, 1 / 2.5, np.nan])
        w = stepover_mm(0.005, np.array([[3.0], [np.inf]]), k)
        assert w.shape == (2, 7)
        for i, rho in enumerate((3.0, np.inf)):
            for j, kj in enumerate(k):
                assert w[i, j] == float(stepover_mm(0.005, rho, kj))
        flat = 2 * np.sqrt(0.005 * (6.0 - 0.005))
        assert w[0, 1] == pytest.approx(flat, rel=1e-8)  # (the series at tiny curvature)
        assert w[0, 5] == 0.0 and w[0, 6] == 0.0  # too hollow for R 3; no curvature
        assert w[1, 2] == np.inf and w[1, 4] == 0.0 and w[1, 6] == 0.0  # a flat face
        # a hollow the cutter nearly fills, under a tall cusp: half the hollow's circle
        assert float(stepover_mm(1.0, 3.0, 1 / 3.05)) == pytest.approx(np.pi * 3.05)


def test_pass_levels_respect_the_window_minimum():
    grid = np.linspace(0.0, 1.0, 101)
    allowed = 0.01 + 0.02 * (grid > 0.5)  # tighter on the lower half
    levels = pass_levels(grid, allowed, balance=False)
    assert levels[0] == 0.0 and levels[-1] == 1.0 and np.all(np.diff(levels) > 0)
    steps = np.diff(levels)
    for lo, step in zip(levels[:-1], steps, strict=True):
        window = (grid >= lo - 1e-12) & (grid <= lo + step + 0.01)
        assert step <= allowed[window].min() + 1e-8
    balanced = pass_levels(grid, allowed)
    assert len(balanced) == len(levels)
    assert np.diff(balanced).max() <= np.diff(levels).max() + 1e-8  # the 1e-9 snap to s = 1


def test_pass_levels_refuse_zero_and_too_many():
    grid = np.linspace(0.0, 1.0, 11)
    with pytest.raises(PlanningError, match=r"s=0\.5"):
        pass_levels(grid, np.where(np.isclose(grid, 0.5), 0.0, 0.1))
    with pytest.raises(PlanningError, match="max_passes=10"):
        pass_levels(grid, np.full(11, 0.001), max_passes=10)


def test_chord_extremes_see_both_sides_of_an_inflected_move():
    # a move standing 0.0067 above the surface near its start and cutting 0.018 in near
    # its end (g(u) = u (1 - u)(a + b u)): the largest magnitude alone would hide the
    # undercut, which the concave allowance limits much tighter than the chord tolerance
    u = np.array(CHORD_FRACTIONS)
    a, b = 0.09, -0.25
    gaps = (u * (1 - u) * (a + b * u))[None, :]
    low, u_low, high, u_high = chord_extremes(gaps)
    grid = np.linspace(0.0, 1.0, 100_001)
    exact = grid * (1 - grid) * (a + b * grid)
    assert low[0] == pytest.approx(exact.min(), abs=2e-5)
    assert high[0] == pytest.approx(exact.max(), abs=2e-5)
    assert u_low[0] == pytest.approx(grid[exact.argmin()], abs=0.01)
    assert u_high[0] == pytest.approx(grid[exact.argmax()], abs=0.01)
    assert 0.006 < high[0] < -low[0]


def test_points_equidistribute_the_density_pass_by_pass():
    # each pass gets ceil(total) equal shares (at least one) of the density's trapezoid
    # integral, the points where the integral (interpolated linearly) reaches each share;
    # ends exact
    from toolpath.planning.sampling import equidistribute, pass_densities

    t_grid = np.r_[0.0, np.sort(np.random.default_rng(2).random(50)), 1.0]
    density = np.vstack([np.full(t_grid.size, 7.5), 3.0 + 40.0 * t_grid ** 2,
                         np.full(t_grid.size, 1e-6)])
    t, pid = equidistribute(t_grid, density)
    for p in range(3):
        cum = np.r_[0.0, np.cumsum(0.5 * (density[p, 1:] + density[p, :-1]) * np.diff(t_grid))]
        n = max(int(np.ceil(cum[-1] - 1e-9)), 1)
        want = np.interp(np.arange(n + 1) * (cum[-1] / n), cum, t_grid)
        want[0], want[-1] = 0.0, 1.0
        np.testing.assert_allclose(t[pid == p], want, rtol=0.0, atol=1e-12)
    assert np.bincount(pid).tolist() == [9, 18, 2]
    # a spiral ring's density follows its climbing s
    s_grid = np.linspace(0.0, 1.0, 5)
    grid = np.outer(np.ones(t_grid.size), 1.0 + s_grid)  # density 1 + s
    got = pass_densities(t_grid, s_grid, grid, np.array([0.25, 0.0]), np.array([0.25, 1.0]))
    np.testing.assert_allclose(got, [np.full(t_grid.size, 1.25), 1.0 + t_grid], rtol=1e-12)


def test_pass_levels_refuse_a_grid_of_one_level():
    with pytest.raises(ValueError, match="at least two probe levels"):
        pass_levels([0.0], [0.1])
