"""The flat/bull estimate's compiled parts give what the numpy they replaced gives.

:func:`toolpath.planning.torus_kernel.window_nearest` (the contact poses) against the whole
window in numpy: every candidate's foot on its segment, candidates of another pass left
out, the first of the nearest. :func:`~toolpath.planning.torus_kernel.side_crossings` (where
two sections' sides cross, :mod:`toolpath.planning.torus_profile`) against both polylines
sorted together and taken at every point in numpy (the former ``torus_profile._crossing``).
:func:`~toolpath.planning.torus_kernel.disk_crossings` (the pose sections' bound,
:func:`~toolpath.planning.torus_profile.pose_section_ridges`) against its bisection over
all rows in numpy.
"""

import functools

import numba
import numpy as np
import pytest

from toolpath.planning import torus_profile
from toolpath.planning.torus_kernel import (
    RUNNING_BOUNDS_ROWS,
    disk_crossings,
    running_bounds,
    section_sides,
    side_crossings,
    window_nearest,
)
from toolpath.tolerances import TINY


def _numpy_nearest(start, target, a, e, pass_of, window):
    shift = np.arange(-window, window + 1)
    cand = np.clip(start[:, None] + shift, 0, len(pass_of) - 1)
    near = target[:, None]
    f = np.clip(np.einsum("ijk,ijk->ij", near - a[cand], e[cand])
                / np.maximum(np.einsum("ijk,ijk->ij", e[cand], e[cand]), 1e-300), 0.0, 1.0)
    foot = a[cand] + f[..., None] * e[cand]
    dist = np.einsum("ijk,ijk->ij", near - foot, near - foot)
    dist[pass_of[cand] != pass_of[start, None]] = np.inf
    return np.take_along_axis(cand, np.argmin(dist, axis=1)[:, None], 1)[:, 0]


def test_window_nearest_equals_the_whole_window_in_numpy():
    rng = np.random.default_rng(30)
    # 40 passes of 30 pieces (some of no length), a wandering polyline each
    n_pass, per = 40, 30
    pass_of = np.repeat(np.arange(n_pass), per)
    steps = rng.normal(scale=0.3, size=(n_pass * per, 3))
    steps[rng.random(len(steps)) < 0.05] = 0.0
    a = np.cumsum(steps, axis=0)
    e = np.roll(a, -1, axis=0) - a
    e[(np.arange(len(a)) + 1) % per == 0] = 0.0
    m = 3000
    start = rng.integers(0, len(a), m)
    target = a[start] + rng.normal(scale=2.0, size=(m, 3))
    for window in (1, 4, 24):
        got = window_nearest(start, target, a, e, pass_of, window)
        np.testing.assert_array_equal(got, _numpy_nearest(start, target, a, e, pass_of,
                                                          window))
        assert (pass_of[got] == pass_of[start]).all()
        assert (got != start).mean() > 0.3  # (most rows move: the window is searched)



def test_window_nearest_never_leaves_the_pieces_on_a_non_finite_target():
    """A NaN or infinite target picks what numpy's argmin picks, never -1 (the last piece)."""
    rng = np.random.default_rng(31)
    pass_of = np.repeat(np.arange(3), 8)
    a = rng.normal(size=(24, 3))
    e = rng.normal(size=(24, 3))
    e[::5] = 0.0
    start = np.array([1, 5, 10, 12, 16, 23])
    for bad in (np.nan, np.inf, -np.inf):
        target = a[start] + 0.5
        target[:, 1] = bad
        target[2] = np.nan  # a whole row of NaN
        for window in (2, 6):
            got = window_nearest(start, target, a, e, pass_of, window)
            assert (got >= 0).all()
            with np.errstate(invalid="ignore"):
                want = _numpy_nearest(start, target, a, e, pass_of, window)
            np.testing.assert_array_equal(got, want)

def _on_merged(x: np.ndarray, before: np.ndarray, xp: np.ndarray,
               yp: np.ndarray, left: np.ndarray | float,
               right: np.ndarray | float) -> np.ndarray:
    """Polyline ``(xp, yp)`` (rows, ``xp`` rising) at ``x`` (rows).

    ``before`` counts its points at or left of each ``x``; ``left`` and ``right`` (rows
    or one value) stand beyond its ends.
    """
    k = xp.shape[1]
    i = np.clip(before, 1, k - 1)
    x0, x1 = np.take_along_axis(xp, i - 1, 1), np.take_along_axis(xp, i, 1)
    y0, y1 = np.take_along_axis(yp, i - 1, 1), np.take_along_axis(yp, i, 1)
    out = y0 + np.clip((x - x0) / np.maximum(x1 - x0, TINY), 0.0, 1.0) * (y1 - y0)
    out = np.where(before == 0, left, out)
    return np.where((before == k) & (x > xp[:, -1:]), right, out)


def _numpy_crossing(x1: np.ndarray, y1: np.ndarray, x2: np.ndarray,
                    y2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where the own side ``(x1, y1)`` first stands at or above the next's ``(x2, y2)``.

    Polylines (m, k), ``x`` rising. Returns ``x, y`` of the crossing (``nan``: none).
    """
    m, samples = x1.shape
    # both polylines at all their points (sorted together): linear between neighbours
    both = np.concatenate([x1, x2], axis=1)
    order = np.argsort(both, axis=1, kind="stable")
    xs = np.take_along_axis(both, order, 1)
    own_before = np.cumsum(order < samples, axis=1)
    # the own side left of its contact stands as there; nothing past either's edge
    g1 = _on_merged(xs, own_before, x1, y1, y1[:, :1], np.inf)
    g2 = _on_merged(xs, np.cumsum(order >= samples, axis=1), x2, y2, np.inf, y2[:, -1:])
    with np.errstate(invalid="ignore"):
        f = g1 - g2
    rise = f >= 0.0
    j = np.argmax(rise, axis=1)
    found = rise.any(axis=1) & (j > 0)
    j = np.maximum(j, 1)
    rows = np.arange(m)
    f0, f1 = f[rows, j - 1], f[rows, j]
    found &= ~np.isnan(f0) & ~np.isnan(f1)
    xa, xb = xs[rows, j - 1], xs[rows, j]
    with np.errstate(invalid="ignore", divide="ignore"):
        lam = np.where(np.isfinite(f0) & np.isfinite(f1), f0 / (f0 - f1), 0.0)
        ya = np.where(np.isfinite(g1[rows, j - 1]), g1[rows, j - 1], g2[rows, j - 1])
        yb = np.where(np.isfinite(g1[rows, j]), g1[rows, j], g2[rows, j])
    # -inf at the left: the next side starts at xb (its edge, the own side's height
    # there); +inf at the right: the own side ends at xa (the next side's height there)
    lam = np.where(np.isneginf(f0), 1.0, lam)
    x_r = xa + lam * (xb - xa)
    y_r = np.where(np.isposinf(f1) & np.isfinite(f0), g2[rows, j - 1], ya + lam * (yb - ya))
    y_r = np.where(np.isneginf(f0), g1[rows, j], y_r)
    found &= np.isfinite(x_r) & np.isfinite(y_r)
    return np.where(found, x_r, np.nan), np.where(found, y_r, np.nan)


def test_side_crossings_equal_both_sides_sorted_together_in_numpy():
    rng = np.random.default_rng(31)
    m, k = 4000, 16
    # rising x (some equal: ties between and within the sides), sides that cross, that
    # do not, and that stand apart (the own ending before the next starts: inf either side)
    x1 = np.cumsum(rng.choice([0.0, 0.1, 0.3], (m, k)), axis=1) - rng.uniform(0, 2, (m, 1))
    x2 = np.cumsum(rng.choice([0.0, 0.1, 0.3], (m, k)), axis=1) + rng.uniform(-1, 3, (m, 1))
    x1, x2 = np.round(x1, 1), np.round(x2, 1)
    y1 = np.cumsum(rng.normal(0.1, 0.3, (m, k)), axis=1)
    y2 = np.cumsum(rng.normal(-0.1, 0.3, (m, k)), axis=1) + rng.uniform(-1, 3, (m, 1))
    got_x, got_y = side_crossings(x1, y1, x2, y2)
    want_x, want_y = _numpy_crossing(x1, y1, x2, y2)
    np.testing.assert_array_equal(got_x, want_x)
    np.testing.assert_array_equal(got_y, want_y)
    found = np.isfinite(want_x)
    assert 0.2 < found.mean() < 0.9  # (crossings and none)


def _numpy_lowest(disks, at):
    cx, cy, rho_sq = disks
    off_sq = rho_sq[:, :, None] - (at[:, None, :] - cx[:, :, None]) ** 2
    with np.errstate(invalid="ignore"):
        arc = np.where(off_sq >= 0.0, cy[:, :, None] - np.sqrt(np.maximum(off_sq, 0.0)),
                       np.inf)
    return arc


def _numpy_disk_crossings(own, nxt, reach, steps):
    ends = np.stack([np.zeros_like(reach), reach], axis=1)
    with np.errstate(invalid="ignore"):
        gap = _numpy_lowest(own, ends).min(axis=1) - _numpy_lowest(nxt, ends).min(axis=1)
    ok = (gap[:, 0] < 0.0) & (gap[:, 1] > 0.0)
    xa, xb = ends[:, 0].copy(), ends[:, 1].copy()
    for _ in range(steps):
        mid = 0.5 * (xa + xb)
        with np.errstate(invalid="ignore"):
            above = (_numpy_lowest(own, mid[:, None]).min(axis=1)
                     - _numpy_lowest(nxt, mid[:, None]).min(axis=1))[:, 0]
        above = ~(above < 0.0)
        xb, xa = np.where(above, mid, xb), np.where(above, xa, mid)
    bracket = np.stack([xa, xb], axis=1)
    bound = np.minimum(*(_numpy_lowest(d, bracket).max(axis=2).min(axis=1) for d in (own, nxt)))
    return xb, bound, ok


def test_disk_crossings_equal_the_bisection_over_all_rows_in_numpy():
    rng = np.random.default_rng(32)
    m, disks = 3000, 17
    reach = rng.uniform(0.2, 2.0, m)

    def side(x0, slope):
        # a row of corner disks along a tilted ring: some miss the plane (negative radii)
        cx = x0[:, None] + np.linspace(-1.5, 1.5, disks) * rng.uniform(0.5, 1.5, (m, 1))
        cy = 1.0 + slope[:, None] * cx + rng.normal(scale=0.05, size=(m, disks))
        rho_sq = rng.uniform(-0.1, 1.0, (m, disks))
        return cx, cy, rho_sq

    own = side(rng.uniform(-0.5, 0.3, m), rng.uniform(0.0, 0.6, m))
    nxt = side(reach + rng.uniform(-0.3, 0.5, m), -rng.uniform(0.0, 0.6, m))
    got = disk_crossings(own, nxt, reach, 32)
    want = _numpy_disk_crossings(own, nxt, reach, 32)
    for g, w in zip(got, want, strict=True):
        np.testing.assert_array_equal(g, w)
    assert 0.2 < want[2].mean() < 0.95  # (crossed and not)


def _envelope(disks, x):
    """Lowest lower arc of the disks (each (m, S)) at ``x`` (k,): (m, k)."""
    cx, cy, rho_sq = (v[:, :, None] for v in disks)
    off = rho_sq - (x[None, None, :] - cx) ** 2
    with np.errstate(invalid="ignore"):
        arc = np.where(off >= 0.0, cy - np.sqrt(np.maximum(off, 0.0)), np.inf)
    return arc.min(axis=1)


@numba.njit
def _dense_envelope(cx, cy, rho_sq, x):
    """:func:`_envelope` of one row's disks (each (S,)) at ``x`` (k,), a point at a time.

    The same floats for finite disks (each arc ``cy - sqrt(rho_sq - (x - cx)^2)`` where
    that is not negative, the least of them; ``inf`` where none): without the numpy
    temporaries of every disk at every ``x`` (~20 s a side over 400 rows of 20,001 ``x``).
    """
    out = np.empty(x.size)
    for j in range(x.size):
        least = np.inf
        for i in range(cx.size):
            off = rho_sq[i] - (x[j] - cx[i]) ** 2
            if off >= 0.0:
                least = min(least, cy[i] - np.sqrt(off))
        out[j] = least
    return out


def _lower_envelope(sides, x, row):
    """``min(F_own, F_next)`` of row ``row`` at its dense ``x`` (:func:`_dense_envelope`)."""
    arrays = [tuple(v[row] for v in side) for side in sides]
    if not all(np.isfinite(v).all() for side in arrays for v in side):
        raise ValueError(f"row {row}: a disk not finite (the compiled envelope reads NaN "
                         "as numpy's min does not)")
    return np.minimum(*(_dense_envelope(*side, x[row]) for side in arrays))


def _several_poses(bend, limit_share):
    """Several poses a side, tilted and shifted at random, and the ridge between them.

    Envelopes neither convex nor crossing once. Returns running_bounds' arguments but
    ``levels`` and ``even`` (the contact poses' crossing, disk_crossings over the first
    pose of each side, is where the grid halves towards, as in pose_section_ridges; the
    surface's section ``y = bend x^2 / 2`` and its edge at ``limit_share`` of the reach,
    None: none), each side's disks and the ridge's height over that section,
    max_x min(F_own, F_next) - bend x^2 / 2 over [0, min(reach, limit)], sampled densely
    (the oracle).
    """
    args, limit, sides, x, lower = _poses_and_lower_envelope(limit_share)
    ridge = (lower - 0.5 * bend * x**2).max(axis=1)
    return args, np.full(len(ridge), bend), limit, sides, ridge


@functools.lru_cache(maxsize=2)
def _poses_and_lower_envelope(limit_share):
    """:func:`_several_poses`' poses and ``min(F_own, F_next)`` at its dense ``x``, once.

    (Whatever the bend: the oracle's sums, shared by the tests; compiled, ~2 s a call.)
    """
    rng = np.random.default_rng(7)
    m, k, ring, corner = 400, 4, 3.0, 1.0
    through = np.zeros((m, 3))
    nu, ex, ey = (np.tile(v, (m, 1)) for v in np.eye(3)[[1, 0, 2]])
    normal = ey.copy()
    reach = rng.uniform(0.3, 1.5, m)

    def poses(at):
        # a lead along the plane's normal (y): the ring's way to the contact runs along
        # -y, the ring points about it across, in x; contacts near x = at, y = 0
        axes = np.stack([rng.normal(scale=0.1, size=(m, k)), rng.uniform(0.1, 0.3, (m, k)),
                         np.ones((m, k))], axis=2)
        axes /= np.linalg.norm(axes, axis=2, keepdims=True)
        way = -(normal[:, None] - axes[..., 2:] * axes)
        way /= np.linalg.norm(way, axis=2, keepdims=True)
        centres = np.zeros((m, k, 3))
        centres[..., 0] = at[:, None] + rng.normal(scale=0.3, size=(m, k))
        centres[..., 1] = -ring * way[..., 1] + rng.normal(scale=0.3, size=(m, k))
        centres[..., 2] = corner + rng.uniform(0.0, 0.05, (m, k)) - ring * way[..., 2]
        return centres, axes

    own_c, own_a = poses(np.zeros(m))
    next_c, next_a = poses(reach)
    phi = np.linspace(-1.0, 1.0, 33)[None, :] * np.full((m, 1), 0.8)
    frame = (through, nu, ex, ey)
    sides = []
    for centres, axes in ((own_c, own_a), (next_c, next_a)):
        parts = [torus_profile._disks(centres[:, j], axes[:, j], normal, phi, frame, ring,
                                      corner) for j in range(k)]
        sides.append(tuple(np.concatenate(v, axis=1) for v in zip(*parts, strict=True)))
    first = [tuple(v[:, :phi.shape[1]] for v in side) for side in sides]
    centre, _, _ = disk_crossings(*first, reach, 32)
    limit = np.full(m, np.inf) if limit_share is None else limit_share * reach
    x = np.linspace(0.0, 1.0, 20_001)[None, :] * np.minimum(reach, limit)[:, None]
    lower = np.empty_like(x)
    for row in range(m):
        lower[row] = _lower_envelope(sides, x, row)
    args = (frame, normal, (own_c, own_a, next_c, next_a), phi, ring, corner, reach, centre)
    return args, limit, sides, x, lower


def test_the_compiled_dense_envelope_is_the_numpy_one():
    # the oracle's envelope a point at a time (_dense_envelope) against every disk at every
    # x in numpy (_envelope), the same floats, on rows of both edge limits; fails if the
    # compiled one keeps the disks' upper arcs (cy + sqrt)
    rng = np.random.default_rng(11)
    for limit_share in (None, 0.6):
        _, _, sides, x, lower = _poses_and_lower_envelope(limit_share)
        for row in rng.choice(len(x), 6, replace=False):
            one = [tuple(v[row:row + 1] for v in side) for side in sides]
            want = np.minimum(_envelope(one[0], x[row]), _envelope(one[1], x[row]))[0]
            assert np.isfinite(want).mean() > 0.5
            np.testing.assert_array_equal(lower[row], want)
            np.testing.assert_array_equal(_lower_envelope(sides, x, row), want)


@pytest.mark.parametrize("bend", [0.0, -0.1, 0.1])
def test_running_bounds_bound_the_ridge_of_several_poses_everywhere(bend):
    # the bound must stand at or above the ridge's height over the surface's section
    # y = bend x^2 / 2 and close to it where the ridge lies near the contact poses'
    # crossing. (bend -0.1: a sphere of radius 10 mm. Weighed by y alone and read at the
    # interval's middle, the bound stood up to 0.086 mm below the ridge's height here,
    # 0.050 with bend 0.1.)
    args, bends, limit, _, ridge = _several_poses(bend, None)
    at, bound = running_bounds(*args, 12, bends, limit)
    bound = bound - 0.5 * bend * at**2  # its height over the surface, where it is read
    finite = np.isfinite(ridge)
    m = len(ridge)
    assert finite.sum() > m // 2
    assert (bound[finite] >= ridge[finite] - 1e-12).all(), (bound - ridge)[finite].min()
    # close where the ridge lies near the contact poses' crossing (the grid halves there);
    # elsewhere coarse intervals read it high
    assert np.mean(bound[finite] - ridge[finite] < 1e-3) >= 0.1  # (0.13 of these rows)


def _halving_grid(span, mid, levels):
    """The grid running_bounds halves towards ``mid`` over ``[0, span]`` (one row)."""
    grid = [0.0]
    for k in range(1, levels + 1):
        if mid - span * 0.5**k > grid[-1]:
            grid.append(mid - span * 0.5**k)
    for k in range(levels + 1):
        at = min(mid + span * 0.5 ** (levels + 1 - k), span) if k > 0 else mid
        if at > grid[-1]:
            grid.append(at)
    if span > grid[-1]:
        grid.append(span)
    return np.array(grid)


@pytest.mark.parametrize(("bend", "limit_share"),
                         [(0.0, None), (-0.1, None), (0.1, None), (-0.1, 0.6), (0.1, 0.6)])
def test_running_bounds_over_an_even_grid_too_equal_every_interval_cut_and_bound_the_ridge(
        bend, limit_share):
    # with even steps, the height over the surface of the halving grid cut at every even
    # point too (all intervals' U in numpy, each weighed by its height over the surface's
    # section at its lowest point within the edge: the full method the branch and bound
    # skips intervals of), still at or above the ridge's, never above the halving grid's,
    # and close to the ridge's on most rows (the halving grid alone: 0.13 of them within
    # 1 um); read where the surface stands lowest, its y the interval's bound
    args, bends, limit, sides, ridge = _several_poses(bend, limit_share)
    levels, even = 12, 64
    at_c, coarse = running_bounds(*args, levels, bends, limit)
    at, bound = running_bounds(*args, levels, bends, limit, even)
    coarse, over = coarse - 0.5 * bend * at_c**2, bound - 0.5 * bend * at**2
    reach, centre = args[-2], args[-1]
    full, full_at, full_y = (np.empty(len(reach)) for _ in range(3))
    for row in range(len(reach)):
        span, mid = reach[row], min(max(centre[row], 0.0), reach[row])
        grid = np.union1d(_halving_grid(span, mid, levels), span * np.arange(even + 1) / even)
        one = [tuple(v[row:row + 1] for v in side) for side in sides]
        ends = []
        for side in one:
            cx, cy, rho_sq = (v[0][:, None] for v in side)
            off = rho_sq - (grid[None, :] - cx) ** 2
            with np.errstate(invalid="ignore"):
                arc = np.where(off >= 0.0, cy - np.sqrt(np.maximum(off, 0.0)), np.inf)
            ends.append(np.maximum(arc[:, :-1], arc[:, 1:]).min(axis=0))
        value = np.minimum(*ends)
        xa, xb = grid[:-1], np.minimum(grid[1:], limit[row])
        lowest = xb if bend < 0.0 else xa if bend > 0.0 else 0.5 * (xa + xb)
        height = np.where(xa <= limit[row], value - 0.5 * bend * lowest**2, -np.inf)
        best = np.argmax(height)
        full[row], full_at[row], full_y[row] = height[best], lowest[best], value[best]
    finite = np.isfinite(ridge)
    np.testing.assert_allclose(over[finite], full[finite], rtol=0, atol=1e-12)
    np.testing.assert_allclose(at[finite], full_at[finite], rtol=0, atol=1e-12)
    np.testing.assert_allclose(bound[finite], full_y[finite], rtol=0, atol=1e-12)
    assert (over[finite] >= ridge[finite] - 1e-12).all(), (over - ridge)[finite].min()
    assert (over <= coarse).all()
    assert np.mean(over[finite] - ridge[finite] < 1e-3) >= 0.5


def _section_sides_numpy(centre, pa, q, s, psi, corner_mm, lift_mm):
    """:func:`section_sides` over all rows at once, in numpy (its former reading)."""
    mx, my = np.sin(psi), -np.cos(psi)

    def support(shape):
        sx = shape[:, 0, 0, None] * mx + shape[:, 0, 1, None] * my
        sy = shape[:, 1, 0, None] * mx + shape[:, 1, 1, None] * my
        norm = np.sqrt(np.maximum(mx * sx + my * sy, TINY))
        return sx / norm, sy / norm

    ex, ey = support(s)
    cx, cy = support(q)
    up = (mx * pa[:, 0, None] + my * pa[:, 1, None]) > 0.0
    bx = centre[:, 0, None] + ex + corner_mm * cx + lift_mm * up * pa[:, 0, None]
    by = centre[:, 1, None] + ey + corner_mm * cy + lift_mm * up * pa[:, 1, None]
    return np.maximum.accumulate(bx, axis=1), by


def test_section_sides_equal_all_rows_at_once_in_numpy():
    rng = np.random.default_rng(32)
    m = 3000
    # projections of unit axes onto planes met aslant (as torus_profile._oblique makes)
    proj = rng.normal(size=(m, 2, 3)) * rng.uniform(0.5, 2.0, (m, 1, 1))
    axis = rng.normal(size=(m, 3))
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    axis[:5] = proj[:5, 0] / np.linalg.norm(proj[:5, 0], axis=1)[:, None]  # degenerate
    pa = np.einsum("ikj,ij->ik", proj, axis)
    q = np.einsum("ikj,ilj->ikl", proj, proj)
    s = 9.0 * (q - pa[:, :, None] * pa[:, None, :])
    centre = rng.normal(size=(m, 2))
    centre[7, 0] = np.nan  # a NaN carried on along x
    t = np.linspace(-0.5, 1.0, 64)
    for psi in (0.5 * np.pi * t * np.abs(t), -(0.5 * np.pi * t * np.abs(t))[::-1],
                np.zeros(1)):
        got = section_sides(centre, pa, q, s, psi, 1.0, 23.0)
        want = _section_sides_numpy(centre, pa, q, s, psi, 1.0, 23.0)
        for a, b in zip(got, want, strict=True):
            np.testing.assert_array_equal(a, b)


def test_running_bounds_read_the_same_in_one_thread_as_in_several():
    # its rows run in slices as the threads free (run_in_threads, dynamic): whichever
    # thread takes a slice, each row's bound is the same
    args, bends, limit, _, _ = _several_poses(0.1, 0.6)
    threads = numba.get_num_threads()
    assert len(args[-2]) >= 2 * RUNNING_BOUNDS_ROWS  # (sliced)
    try:
        numba.set_num_threads(1)
        alone = running_bounds(*args, 12, bends, limit, 64)
    finally:
        numba.set_num_threads(threads)
    shared = running_bounds(*args, 12, bends, limit, 64)
    for one, many in zip(alone, shared, strict=True):
        np.testing.assert_array_equal(one, many)
