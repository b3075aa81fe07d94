"""The flat/bull-nose ray cast's skips leave its entries what the full method gives.

:func:`toolpath.planning.sweep_kernel.nearest_entries` skips pieces and golden-section
searches on lower bounds of the entry (the tip plane, the tip's reach, the poses' shift
over a piece, the sampled poses' distances from the ray's origin less their shift over half
a sample's spacing: without that shift the test fails), and seeks no entry at a sampled
pose, or a pose the golden-section search tries, whose distance from the ray's origin less
``TOUCH_MM`` already says it cannot be kept (with that bound raised by 0.02 mm, or the
samples' skip by as much, the test fails). Here the same method without any
skip, pose by pose (each pose's entry the first root of the ray's convex distance to the
cutter, by ternary search and bisection; the entry into a piece the best of its
:data:`~toolpath.planning.sweep_kernel.POSES` samples, refined by the golden-section
search between the best one's neighbours; the ray's entry the smallest over its pieces),
written in numpy from the cutter's exact signed distance, must give the same numbers on
random pieces and rays.
"""

import numpy as np
import pytest

from toolpath.planning.cutters import parse_cutter
from toolpath.planning.sweep_kernel import GOLDEN_STEPS, POSES, TOUCH_MM, nearest_entries

HORIZON_MM = 0.6
INV_PHI = (np.sqrt(5.0) - 1.0) / 2.0


def _turned(axis, angle, rng):
    """``axis`` (unit rows) turned by ``angle`` (rad) towards a random perpendicular."""
    side = np.cross(axis, rng.normal(size=axis.shape))
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    return np.cos(angle)[:, None] * axis + np.sin(angle)[:, None] * side


def _random_passes(rng, n_passes, n_pieces):
    """Passes of ``n_pieces`` pieces each, far apart: tips (mm) and unit axes at their ends.

    Each piece travels 0 (a point segment: a still or pivoting cutter), 0.05-0.5 or 3-12 mm
    and turns its axis by 0, 1-5 or 10-40 deg, at random.
    """
    m = n_passes * n_pieces
    travel = rng.choice([0.0, 1.0, 2.0], m)
    travel = np.where(travel == 1.0, rng.uniform(0.05, 0.5, m),
                      np.where(travel == 2.0, rng.uniform(3.0, 12.0, m), 0.0))
    turn = rng.choice([0.0, 1.0, 2.0], m)
    turn = np.radians(np.where(turn == 1.0, rng.uniform(1.0, 5.0, m),
                               np.where(turn == 2.0, rng.uniform(10.0, 40.0, m), 0.0)))
    tip = 100.0 * np.arange(n_passes)[:, None] * np.array([1.0, 0.0, 0.0])
    axis = rng.normal(size=(n_passes, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    way = rng.normal(size=(n_passes, 3))
    p0, p1, a0, a1 = [], [], [], []
    for k in range(n_pieces):
        j = np.arange(n_passes) * n_pieces + k
        way = way + rng.normal(scale=0.5, size=way.shape)
        way /= np.linalg.norm(way, axis=1, keepdims=True)
        p0.append(tip)
        a0.append(axis)
        tip = tip + travel[j, None] * way
        axis = _turned(axis, turn[j], rng)
        p1.append(tip)
        a1.append(axis)
    # piece k of pass i at row i * n_pieces + k
    return [np.stack(x, axis=1).reshape(m, 3) for x in (p0, p1, a0, a1)]


def _rays(rng, cutter, poses, n_passes, n_pieces, n_rays):
    """Rays from round a random pose of a random pass: origins, unit directions, passes.

    Origins round the cutting end (mostly just outside its side, corner and tip), a
    quarter near the axis of a middle pose up its flutes or under its tip, a tenth under
    the tip falling away from the spindle; directions at random, half into the axis.
    """
    p0, p1, a0, a1 = poses
    owner = rng.integers(0, n_passes, n_rays)
    j = owner * n_pieces + rng.integers(0, n_pieces, n_rays)
    u = rng.uniform(0.0, 1.0, (n_rays, 1))
    tip = p0[j] + u * (p1[j] - p0[j])
    axis = a0[j] + u * (a1[j] - a0[j])
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    side = np.cross(axis, rng.normal(size=(n_rays, 3)))
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    off = np.where(rng.random(n_rays) < 0.7, rng.uniform(1.0, 1.3, n_rays),
                   rng.uniform(0.6, 1.0, n_rays)) * cutter.radius_mm
    q = (tip + off[:, None] * side
         + rng.uniform(-1.0, 2.0 * cutter.corner_radius_mm + 1.0, (n_rays, 1)) * axis)
    n = rng.normal(size=(n_rays, 3))
    inward = rng.random(n_rays) < 0.5
    n[inward] = -side[inward] + rng.normal(scale=0.4, size=(inward.sum(), 3))
    # a quarter from near the axis of a middle pose, up its flutes or under its tip (the
    # end poses of a long or turning piece stand farthest off them)
    within = rng.random(n_rays) < 0.25
    u[within] = rng.uniform(0.35, 0.65, (within.sum(), 1))
    tip = p0[j] + u * (p1[j] - p0[j])
    axis = a0[j] + u * (a1[j] - a0[j])
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    q[within] = (tip + rng.uniform(0.0, 0.5 * cutter.radius_mm, (n_rays, 1)) * side
                 + rng.uniform(-HORIZON_MM, cutter.flute_length_mm, (n_rays, 1)) * axis)[within]
    below = rng.random(n_rays) < 0.1  # under the tip, falling away from the spindle
    q[below] = (tip - rng.uniform(0.0, 1.0, (n_rays, 1)) * axis)[below]
    n[below] = (-axis + rng.normal(scale=0.5, size=(n_rays, 3)))[below]
    return q, n / np.linalg.norm(n, axis=1, keepdims=True), owner


def _pose_entries(cutter, q, n, poses, u):
    """Entry of each ray ``q + l n`` into the cutter at pose ``u`` of its piece (rows), mm.

    The first ``l`` in ``[0, HORIZON_MM]`` where the convex signed distance ``g(l)`` falls
    to :data:`TOUCH_MM`: 0 if it starts there; inf if it starts farther than the horizon
    (``g`` is 1-Lipschitz); else the minimum of ``g`` by ternary search, inf if above it,
    else the root before it by bisection.
    """
    p0, p1, a0, a1 = poses
    tip = p0 + u[:, None] * (p1 - p0)
    axis = a0 + u[:, None] * (a1 - a0)
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    start = cutter.signed_distance(q, tip, axis)
    out = np.where(start <= TOUCH_MM, 0.0, np.inf)
    rows = np.flatnonzero((start > TOUCH_MM) & (start <= HORIZON_MM + TOUCH_MM))
    q, n, tip, axis = q[rows], n[rows], tip[rows], axis[rows]

    def g(lam):
        return cutter.signed_distance(q + lam[:, None] * n, tip, axis)

    lo, hi = np.zeros(rows.size), np.full(rows.size, HORIZON_MM)
    for _ in range(70):
        m1, m2 = lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0
        left = g(m1) <= g(m2)
        lo, hi = np.where(left, lo, m1), np.where(left, m2, hi)
    reached = g(lo) <= TOUCH_MM
    root_lo, root_hi = np.zeros(rows.size), lo
    for _ in range(55):
        mid = 0.5 * (root_lo + root_hi)
        inside = g(mid) <= TOUCH_MM
        root_lo, root_hi = np.where(inside, root_lo, mid), np.where(inside, mid, root_hi)
    out[rows] = np.where(reached, root_hi, np.inf)
    return out


def _piece_entries(cutter, q, n, poses):
    """Entry of each ray into its piece (rows) by the full method, without skips, mm.

    The best of the :data:`POSES` equally spaced poses, then (entered, not at 0) a
    golden-section search between the best one's neighbours, as the kernel does.
    """
    samples = np.stack([_pose_entries(cutter, q, n, poses, np.full(len(q), m / (POSES - 1)))
                        for m in range(POSES)], axis=1)
    best = np.argmin(samples, axis=1)
    found = samples[np.arange(len(q)), best]
    lo = np.maximum(best - 1, 0) / (POSES - 1)
    hi = np.minimum(best + 1, POSES - 1) / (POSES - 1)
    x1, x2 = hi - INV_PHI * (hi - lo), lo + INV_PHI * (hi - lo)
    f1, f2 = _pose_entries(cutter, q, n, poses, x1), _pose_entries(cutter, q, n, poses, x2)
    for _ in range(GOLDEN_STEPS):
        left = f1 <= f2
        hi = np.where(left, x2, hi)
        lo = np.where(left, lo, x1)
        new_x = np.where(left, hi - INV_PHI * (hi - lo), lo + INV_PHI * (hi - lo))
        new_f = _pose_entries(cutter, q, n, poses, new_x)
        x1, x2 = np.where(left, new_x, x2), np.where(left, x1, new_x)
        f1, f2 = np.where(left, new_f, f2), np.where(left, f1, new_f)
    searched = (found > 0.0) & np.isfinite(found)
    return np.where(searched, np.minimum(found, np.minimum(f1, f2)), found)


@pytest.mark.parametrize("spec", ["flat:6", "flat:2", "bull:4:1"])
def test_ray_entries_with_skips_equal_the_full_method_on_random_pieces(spec):
    # 2000 rays, each among the 4 pieces of its pass (point segments and pieces of up to
    # 12 mm, still, pivoting and turning up to 40 deg): the kernel, trying the nearest
    # piece first and skipping the pieces and searches its bounds say cannot beat the best
    # entry so far, gives each ray the entry of the full method (to its root-finding's
    # round-off: the kernel stops within TOUCH_MM of the solid, up to 1.5e-6 mm apart)
    cutter = parse_cutter(spec)
    rng = np.random.default_rng(27)
    n_passes, n_pieces, n_rays = 80, 4, 2000
    poses = _random_passes(rng, n_passes, n_pieces)
    q, n, owner = _rays(rng, cutter, poses, n_passes, n_pieces, n_rays)
    got = nearest_entries(q, n, owner * n_pieces, (owner + 1) * n_pieces,
                          np.arange(n_passes * n_pieces), *poses,
                          corner_radius_mm=cutter.corner_radius_mm, radius_mm=cutter.radius_mm,
                          flute_length_mm=cutter.flute_length_mm, horizon_mm=HORIZON_MM)
    pair_ray = np.repeat(np.arange(n_rays), n_pieces)
    pair_piece = (owner[:, None] * n_pieces + np.arange(n_pieces)).ravel()
    each = _piece_entries(cutter, q[pair_ray], n[pair_ray],
                          [x[pair_piece] for x in poses]).reshape(n_rays, n_pieces)
    expected = each.min(axis=1)
    finite = np.isfinite(expected)
    np.testing.assert_array_equal(np.isfinite(got), finite)
    np.testing.assert_allclose(got[finite], expected[finite], rtol=0.0, atol=1e-5)
    # the mix the bounds are tried on: rays entering beyond their origin, and missing
    entering = (expected > 0.0) & finite
    assert entering.sum() > 0.05 * n_rays and (~finite).sum() > 0.1 * n_rays


def test_ray_stopping_within_its_horizon_takes_the_first_of_tied_pieces():
    # 24 pieces of one move fanning out from a shared start pose beside the ray (so every
    # piece is as near as the others: the sort's ties) to end poses over the ray farther
    # on, each entered at its own distance. With the stop at the horizon the ray takes the
    # first piece, in the order given, whose sampled pose it enters within the stop: the
    # ties kept in order (an unstable sort of all the pairs, set-aside ones included, took
    # another piece: 0.95 mm against 3.01); with no stop, the smallest entry of any order
    cutter = parse_cutter("bull:8:1")
    m = 24
    q, n = np.zeros((1, 3)), np.array([[1.0, 0.0, 0.0]])
    tips0 = np.tile([0.0, -6.0, -1.0], (m, 1))
    tips1 = np.column_stack([6.0 + 0.25 * np.arange(m), np.zeros(m), np.full(m, -1.0)])
    axes = np.tile([0.0, 0.0, 1.0], (m, 1))
    kw = dict(corner_radius_mm=cutter.corner_radius_mm, radius_mm=cutter.radius_mm,
              flute_length_mm=cutter.flute_length_mm, horizon_mm=30.0)
    order = np.arange(m)[::-1].copy()

    def entries(item, stop_mm):
        return nearest_entries(q, n, np.array([0]), np.array([len(item)]), item, tips0, tips1,
                               axes, axes, stop_mm=stop_mm, **kw)[0]

    first = entries(order[:1], 30.0)
    assert 0.0 < first < 30.0
    assert entries(order, 30.0) == first
    exact = entries(order, 0.0)
    assert exact == min(entries(np.array([k]), 0.0) for k in range(m))
    assert exact == entries(order[::-1].copy(), 0.0) < first
