"""The flat and bull-nose cusp estimate's compiled parts, row by row.

The estimate (:func:`~.cusp_estimates.torus_cusp_estimates`) seeks the pose of a pass whose
contact lies nearest a seed's: over the pieces within a window of a start piece along the
pass, the piece whose segment ``a + f e`` (``0 <= f <= 1``) comes nearest a target point
(:func:`window_nearest`, without the ``(rows, window, 3)`` arrays of candidates). It takes
each prism's section's boundary points at a run of outward normals (:func:`section_sides`,
without the ``(rows, samples)`` temporaries of numpy's sums), meets
two passes' sections where the own side first stands at or above the next's
(:func:`side_crossings`, for :mod:`.torus_profile`: the two polylines walked together,
stopping at the crossing, without sorting them together), and bounds the ridge between
two poses' sections of corner disks (:func:`disk_crossings`, for
:func:`~.torus_profile.pose_section_ridges`: its bisection row by row); those four do
the numpy's sums in its order: the same numbers. :func:`running_bounds` (no numpy
original) bounds the ridge between several poses a side over a grid halving towards the
contact poses' crossing (and, where that reads over a wide interval, an even grid too).
It builds each pose's disks in its loop, as :func:`~.torus_profile._disks` does in numpy,
rather than take them as (m, K S) arrays (~23 MB each at 4,000 rows, 11 poses and 65
ring points), and weighs each interval by its bound's height over the surface's section
(:func:`_over`). Each loop's rows are independent: they run in slices in threads
(:func:`~toolpath.row_threads.run_in_threads`; :func:`running_bounds`' costly rows taken
as the threads free, :data:`RUNNING_BOUNDS_ROWS` at a time).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from ..row_threads import run_in_threads
from ..tolerances import TINY

__all__ = ["RUNNING_BOUNDS_ROWS", "disk_crossings", "running_bounds", "section_sides",
           "side_crossings", "window_nearest"]

#: Rows of :func:`running_bounds` a thread takes at a time (``dynamic``: the next slice
#: nobody has taken, as it frees; :func:`~toolpath.row_threads.run_in_threads`). A row
#: costs about 0.15 ms (17 poses a side, bull:8:1 on the standing dev blade), and its
#: branch and bound cuts more intervals on some rows than on others: 64 rows, about 10 ms,
#: against about 2 us to hand out a slice (and 0.13 ms a call: a trivial kernel's 4,096
#: rows in 64 slices).
RUNNING_BOUNDS_ROWS = 64


@numba.njit(cache=True, nogil=True)
def _window_nearest(start, target, a, e, pass_of, window, out, first, stop):
    """The loop of :func:`window_nearest`, rows ``first .. stop - 1``, into ``out``."""
    last = pass_of.size - 1
    for i in range(first, stop):
        own = pass_of[start[i]]
        best = -1
        best_d = np.inf
        nan_seen = False  # as numpy's argmin: the first NaN distance wins, and stays
        for shift in range(-window, window + 1):
            j = min(max(start[i] + shift, 0), last)
            if pass_of[j] != own:
                if best < 0:  # (as argmin over all-inf rows so far: the first candidate)
                    best = j
                continue
            px = target[i, 0] - a[j, 0]
            py = target[i, 1] - a[j, 1]
            pz = target[i, 2] - a[j, 2]
            ee = e[j, 0] * e[j, 0] + e[j, 1] * e[j, 1] + e[j, 2] * e[j, 2]
            f = (px * e[j, 0] + py * e[j, 1] + pz * e[j, 2]) / max(ee, TINY)
            f = min(max(f, 0.0), 1.0)
            dx = target[i, 0] - (a[j, 0] + f * e[j, 0])
            dy = target[i, 1] - (a[j, 1] + f * e[j, 1])
            dz = target[i, 2] - (a[j, 2] + f * e[j, 2])
            d = dx * dx + dy * dy + dz * dz
            if math.isnan(d):
                if not nan_seen:
                    best, nan_seen = j, True
            elif (d < best_d or best < 0) and not nan_seen:
                best, best_d = j, d
        out[i] = best


def window_nearest(start: NDArray[np.int64], target: NDArray[np.float64],
                   a: NDArray[np.float64], e: NDArray[np.float64],
                   pass_of: NDArray[np.int64], window: int) -> NDArray[np.int64]:
    """Per row, the piece of ``start``'s pass within ``window`` of it nearest ``target``.

    Pieces ``start - window .. start + window`` (clipped to the pieces there are; pieces of
    another pass left out), the squared distance from ``target`` (m, 3) to each segment
    ``a + f e`` (``f`` clipped to ``[0, 1]``); the first of equal ones. Returns the piece
    indices (m,).
    """
    out = np.empty(len(start), dtype=np.int64)
    if len(start):
        run_in_threads(_window_nearest, len(start), np.ascontiguousarray(start, dtype=np.int64),
                       np.ascontiguousarray(target, dtype=float),
                       np.ascontiguousarray(a, dtype=float), np.ascontiguousarray(e, dtype=float),
                       np.ascontiguousarray(pass_of, dtype=np.int64), int(window), out)
    return out


@numba.njit(cache=True, nogil=True)
def _section_sides(centre, pa, q, s, mx, my, corner, lift, out_x, out_y, first, stop):
    """The loop of :func:`section_sides`, rows ``first .. stop - 1``, into ``out_x``, ``out_y``."""
    for row in range(first, stop):
        run = -np.inf
        for j in range(mx.size):
            # the ring's ellipse's support point, then the corner's, as numpy sums them
            sx = s[row, 0, 0] * mx[j] + s[row, 0, 1] * my[j]
            sy = s[row, 1, 0] * mx[j] + s[row, 1, 1] * my[j]
            norm = math.sqrt(max(mx[j] * sx + my[j] * sy, TINY))
            ex, ey = sx / norm, sy / norm
            sx = q[row, 0, 0] * mx[j] + q[row, 0, 1] * my[j]
            sy = q[row, 1, 0] * mx[j] + q[row, 1, 1] * my[j]
            norm = math.sqrt(max(mx[j] * sx + my[j] * sy, TINY))
            cx, cy = sx / norm, sy / norm
            up = 1.0 if (mx[j] * pa[row, 0] + my[j] * pa[row, 1]) > 0.0 else 0.0
            bx = centre[row, 0] + ex + corner * cx + lift * up * pa[row, 0]
            out_y[row, j] = centre[row, 1] + ey + corner * cy + lift * up * pa[row, 1]
            if math.isnan(run) or math.isnan(bx):
                run = np.nan
            elif bx > run:
                run = bx
            out_x[row, j] = run


def section_sides(centre: NDArray[np.float64], pa: NDArray[np.float64],
                  q: NDArray[np.float64], s: NDArray[np.float64], psi: NDArray[np.float64],
                  corner_mm: float, lift_mm: float
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Boundary points of sections at outward normals ``m = (sin psi, -cos psi)``, row by row.

    For :func:`~.torus_profile._section_side`: ``centre`` (m, 2), the axis's image ``pa``
    (m, 2), the corner's and the ring's shapes ``q``, ``s`` (m, 2, 2), ``psi`` (k,).
    The support points ``S m / sqrt(m' S m)`` and ``r Q m / sqrt(m' Q m)`` (``m' S m``
    at least ``TINY``), lifted by ``L - r`` along ``pa`` where ``m . pa > 0``; ``x``
    never falling along the side (its running maximum, as ``np.maximum.accumulate``:
    a NaN carried on). Returns ``x, y`` (m, k).
    """
    m, k = len(centre), len(psi)
    out_x, out_y = np.empty((m, k)), np.empty((m, k))
    if m and k:
        mx, my = np.sin(psi), -np.cos(psi)
        run_in_threads(_section_sides, m,
                       *(np.ascontiguousarray(v, dtype=float) for v in (centre, pa, q, s, mx, my)),
                       float(corner_mm), float(lift_mm), out_x, out_y)
    return out_x, out_y


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _on_side(x, before, xp, yp, row, left, right):
    """Polyline ``(xp[row], yp[row])`` (``x`` rising) at ``x``.

    ``before`` of its points stand at or left of ``x``; ``left``, ``right`` beyond its ends.
    """
    k = xp.shape[1]
    if before == 0:
        return left
    if before == k and x > xp[row, k - 1]:
        return right
    i = min(max(before, 1), k - 1)
    x0, x1 = xp[row, i - 1], xp[row, i]
    y0, y1 = yp[row, i - 1], yp[row, i]
    return y0 + min(max((x - x0) / max(x1 - x0, TINY), 0.0), 1.0) * (y1 - y0)


@numba.njit(cache=True, nogil=True)
def _side_crossings(x1, y1, x2, y2, out_x, out_y, first, stop):
    """The loop of :func:`side_crossings`, rows ``first .. stop - 1``, into ``out_x``, ``out_y``."""
    k = x1.shape[1]
    for row in range(first, stop):
        out_x[row] = np.nan
        out_y[row] = np.nan
        i1 = 0
        i2 = 0
        xa = g1a = g2a = fa = 0.0
        for p in range(2 * k):
            # the merged points in order, the own side's first of equal ones
            if i2 >= k or (i1 < k and x1[row, i1] <= x2[row, i2]):
                xb = x1[row, i1]
                i1 += 1
            else:
                xb = x2[row, i2]
                i2 += 1
            # the own side left of its contact stands as there; nothing past either's edge
            g1b = _on_side(xb, i1, x1, y1, row, y1[row, 0], np.inf)
            g2b = _on_side(xb, i2, x2, y2, row, np.inf, y2[row, k - 1])
            fb = g1b - g2b
            if fb >= 0.0:
                if p == 0 or math.isnan(fa):
                    break
                if math.isfinite(fa) and math.isfinite(fb):
                    lam = fa / (fa - fb)
                else:
                    lam = 0.0
                ya = g1a if math.isfinite(g1a) else g2a
                yb = g1b if math.isfinite(g1b) else g2b
                if fa == -np.inf:
                    lam = 1.0
                x_r = xa + lam * (xb - xa)
                if fb == np.inf and math.isfinite(fa):
                    y_r = g2a
                else:
                    y_r = ya + lam * (yb - ya)
                if fa == -np.inf:
                    y_r = g1b
                if math.isfinite(x_r) and math.isfinite(y_r):
                    out_x[row] = x_r
                    out_y[row] = y_r
                break
            xa, g1a, g2a, fa = xb, g1b, g2b, fb


def side_crossings(x1: NDArray[np.float64], y1: NDArray[np.float64],
                   x2: NDArray[np.float64], y2: NDArray[np.float64]
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Where the own side ``(x1, y1)`` first stands at or above the next's ``(x2, y2)``.

    Polylines (m, k), ``x`` rising, taken at all their points merged in order (the own
    side's first of equal ``x``), each linear between its points: the own side left of
    its first point stands as there and ends at its last (``inf`` past it), the next side
    starts at its first (``inf`` before it) and stands as at its last beyond. At the first
    merged point where the own side is at or above the next (not the first point; no NaN
    difference either side), the crossing between it and the point before: linear where
    both differences are finite; an infinite one puts it at that end, at the side's height
    there. Returns ``x, y`` of the crossing (``nan``: none).
    """
    m = x1.shape[0]
    out_x, out_y = np.empty(m), np.empty(m)
    if m:
        x1, y1, x2, y2 = (np.ascontiguousarray(v, dtype=float) for v in (x1, y1, x2, y2))
        run_in_threads(_side_crossings, m, x1, y1, x2, y2, out_x, out_y)
    return out_x, out_y


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _arc(cx, cy, rho_sq, row, d, at):
    """Disk ``d``'s lower arc at ``at``, ``inf`` where it does not cover ``at``."""
    off_sq = rho_sq[row, d] - (at - cx[row, d]) ** 2
    if off_sq >= 0.0:
        return cy[row, d] - math.sqrt(off_sq)
    return np.inf


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _lowest(cx, cy, rho_sq, row, at):
    """The lowest of row ``row``'s disks' lower arcs at ``at`` (``inf``: none covers)."""
    low = np.inf
    for d in range(cx.shape[1]):
        low = min(low, _arc(cx, cy, rho_sq, row, d, at))
    return low


@numba.njit(cache=True, nogil=True)
def _disk_crossings(own, nxt, reach, steps, out_x, out_h, out_ok, first, stop):
    """The loop of :func:`disk_crossings`, rows ``first .. stop - 1``, into the ``out_*``."""
    ocx, ocy, orho = own
    ncx, ncy, nrho = nxt
    for row in range(first, stop):
        start = _lowest(ocx, ocy, orho, row, 0.0) - _lowest(ncx, ncy, nrho, row, 0.0)
        end = (_lowest(ocx, ocy, orho, row, reach[row])
               - _lowest(ncx, ncy, nrho, row, reach[row]))
        out_ok[row] = start < 0.0 and end > 0.0
        xa, xb = 0.0, reach[row]
        for _ in range(steps):
            mid = 0.5 * (xa + xb)
            gap = _lowest(ocx, ocy, orho, row, mid) - _lowest(ncx, ncy, nrho, row, mid)
            if not gap < 0.0:  # (nan: neither covers; taken as crossed)
                xb = mid
            else:
                xa = mid
        bound = np.inf
        for cx, cy, rho_sq in (own, nxt):
            side = np.inf
            for d in range(cx.shape[1]):
                side = min(side, max(_arc(cx, cy, rho_sq, row, d, xa),
                                     _arc(cx, cy, rho_sq, row, d, xb)))
            bound = min(bound, side)
        out_x[row] = xb
        out_h[row] = bound


def disk_crossings(own: tuple[NDArray[np.float64], ...], nxt: tuple[NDArray[np.float64], ...],
                   reach: NDArray[np.float64], steps: int
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """Where two poses' sections, each the lower envelope of its disks, cross; a bound there.

    ``own``, ``nxt``: each pose's disks, centres ``x``, ``y`` and squared radii (m, S;
    negative where the ball misses the plane). From ``x = 0`` to ``x = reach`` (m,), the
    own envelope below the next's at 0 and above at ``reach`` (else not ``ok``), bisected
    ``steps`` times (no gap below 0, as where neither covers, counts as crossed) to
    ``[x_a, x_b]``; over it each disk's lower arc stands no higher than at its ends, so
    the lesser of the two sides' ``min_i max(f_i(x_a), f_i(x_b))`` bounds the crossing.
    Returns ``x_b``, that bound (``inf`` where a side's disks cover neither end) and
    ``ok``.
    """
    m = len(reach)
    out_x, out_h, out_ok = np.empty(m), np.empty(m), np.zeros(m, dtype=bool)
    if m:
        own, nxt = (tuple(np.ascontiguousarray(v, dtype=float) for v in disks)
                    for disks in (own, nxt))
        run_in_threads(_disk_crossings, m, own, nxt, np.ascontiguousarray(reach, dtype=float),
                       int(steps), out_x, out_h, out_ok)
    return out_x, out_h, out_ok


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _halving_grid(span, centre, levels, grid):
    """Cut ``[0, span]`` at ``centre`` and ``centre +- span 2^-k`` into ``grid``; the count.

    0, then towards ``centre`` (clipped to ``[0, span]``) by halving steps, ``centre``,
    away again, ``span``: rising, no point repeated.
    """
    mid = min(max(centre, 0.0), span)
    count = 1
    grid[0] = 0.0
    for k in range(1, levels + 1):
        at = mid - span * 0.5 ** k
        if at > grid[count - 1]:
            grid[count] = at
            count += 1
    for k in range(levels + 1):
        at = min(mid + span * 0.5 ** (levels + 1 - k), span) if k > 0 else mid
        if at > grid[count - 1]:
            grid[count] = at
            count += 1
    if span > grid[count - 1]:
        grid[count] = span
        count += 1
    return count


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _over(xa, xb, value, bend, limit):
    """How high ``value`` on ``y`` over ``[xa, xb]`` stands over the surface at most; where.

    The surface's section in the plane is ``y_s(x) = bend x^2 / 2`` (to second order;
    ``bend`` its normal curvature along ``x``, negative where it falls away, as on a
    convex part), so a point of the interval at most ``value`` high in ``y`` stands at
    most ``value - min y_s`` over the surface, the minimum over ``[xa, min(xb, limit)]``
    (``0 <= xa``: the far end where ``bend < 0``, the near end where ``bend > 0``). Only
    ``x <= limit`` counts (the surface's edge: the ray cast looks no farther, and no
    height is read beyond it). Returns that height and the ``x`` where the surface stands
    lowest (the middle where ``bend`` is 0); ``-inf`` where ``xa > limit``. Over a part
    of the interval ``value`` is no higher (a part's ``U``, :func:`running_bounds`) and
    the surface's lowest point no lower (a minimum over fewer points), so a part's height
    is at most the whole's: what lets :func:`_even_bounds` prune.
    """
    if xa > limit:
        return -np.inf, xa
    end = min(xb, limit)
    if bend < 0.0:
        at = end
    elif bend > 0.0:
        at = xa
    else:
        at = 0.5 * (xa + end)
    return value - 0.5 * bend * at * at, at


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _highest_over(grid, count, ub, bend, limit):
    """The interval whose bound stands highest over the surface: its ``x``, ``y``, height.

    ``ub`` (2, count - 1): each side's bound ``U`` on ``y`` over each interval of ``grid``;
    each interval's ``min(U_own, U_next)`` weighed by its height over the surface
    (:func:`_over`). The largest bounds the ridge's height, not its ``y``: where the
    surface falls away the highest ``y`` need not be the highest ridge (on a sphere of
    radius 10 mm, bull:8:1, lead 30 deg, trunnion-ac, bounds weighed by ``y`` read down
    to 0.739 of the ray cast; test_planning_measure_pose_sections' "small sphere").
    Returns the ``x`` where that interval's surface stands lowest (the caller reads the
    point's height over the surface there), its ``min(U_own, U_next)`` (``-inf``: no
    interval within ``limit``) and its height over the surface.
    """
    best, where, high = -np.inf, 0.0, -np.inf
    for j in range(count - 1):
        value = min(ub[0, j], ub[1, j])
        over, at = _over(grid[j], grid[j + 1], value, bend, limit)
        if over > best:
            best, where, high = over, at, value
    return where, high, best


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _disk_bounds(disks, counts, points, count, ub):
    """Each side's ``U`` over the intervals of ``points[:count]``, into ``ub``.

    ``disks`` (2, 3, D): each side's disks' centres ``x``, ``y`` and squared radii, the
    first ``counts[side]`` of them. Each disk is met only at the points within one of its
    cover (binary search; the others read ``inf`` there all the same); the disks covering
    none of them are passed over.
    """
    xa, xb = points[0], points[count - 1]
    for side in range(2):
        for j in range(count - 1):
            ub[side, j] = np.inf
        for d in range(counts[side]):
            cx, cy, rho_sq = disks[side, 0, d], disks[side, 1, d], disks[side, 2, d]
            rho = math.sqrt(rho_sq)
            if cx + rho < xa or cx - rho > xb:
                continue
            lo = max(np.searchsorted(points[:count], cx - rho) - 1, 0)
            hi = min(np.searchsorted(points[:count], cx + rho) + 1, count)
            before = np.inf
            for j in range(lo, hi):
                off_sq = rho_sq - (points[j] - cx) ** 2
                here = cy - math.sqrt(off_sq) if off_sq >= 0.0 else np.inf
                if j > lo:
                    ub[side, j - 1] = min(ub[side, j - 1], max(before, here))
                before = here


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _even_bounds(disks, counts, grid, count, ub, span, even, bend, limit, fine, low, order,
                 overs):
    """:func:`_highest_over` over ``grid[:count]`` cut at ``span k / even`` too, B&B.

    ``ub`` holds each side's ``U`` over ``grid``'s intervals (:func:`_disk_bounds`). The
    intervals are taken in falling order of their height over the surface (:func:`_over`),
    each cut at the even points inside it and its parts' heights taken; none is cut once
    its height is no more than the highest part found (a part's height is at most its
    interval's: its ``U`` no higher, the surface's lowest point over it no lower): the
    highest over the finer grid, as though every interval were cut. Returns its part's
    ``x``, ``y`` and height as :func:`_highest_over` does.
    """
    n = count - 1
    for j in range(n):
        order[j] = j
        overs[j] = _over(grid[j], grid[j + 1], min(ub[0, j], ub[1, j]), bend, limit)[0]
    # (insertion sort by falling height: a few dozen intervals)
    for j in range(1, n):
        at = order[j]
        i = j - 1
        while i >= 0 and overs[order[i]] < overs[at]:
            order[i + 1] = order[i]
            i -= 1
        order[i + 1] = at
    found, found_at, found_y = -np.inf, 0.0, -np.inf
    for rank in range(n):
        j = order[rank]
        if overs[j] <= found:
            break
        xa, xb = grid[j], grid[j + 1]
        # the interval's ends and the even points inside it
        points = 1
        fine[0] = xa
        k = math.floor(xa * even / span) if span > 0.0 else even + 1
        while k <= even:
            at = span * k / even
            if at >= xb:
                break
            if at > fine[points - 1]:
                fine[points] = at
                points += 1
            k += 1
        fine[points] = xb
        points += 1
        if points == 2:  # not cut: its height stands
            part_y = min(ub[0, j], ub[1, j])
            part_over, part_at = _over(xa, xb, part_y, bend, limit)
        else:
            _disk_bounds(disks, counts, fine, points, low)
            part_at, part_y, part_over = _highest_over(fine, points, low, bend, limit)
        if part_over > found:
            found, found_at, found_y = part_over, part_at, part_y
    return found_at, found_y, found


@numba.njit(cache=True, nogil=True)
def _running_bounds(frame, normal, poses, phi, ring, corner, reach, centre, levels, even,
                    bend, limit, out_x, out_h, first, stop):
    """The loop of :func:`running_bounds`, rows ``first .. stop - 1``, into ``out_x``, ``out_h``."""
    through, nu, ex, ey = frame
    own_c, own_a, next_c, next_a = poses
    count_max = 2 * levels + 3
    grid = np.empty(count_max)
    ub = np.empty((2, count_max - 1))
    fine = np.empty(even + 2)
    low = np.empty((2, even + 1))
    order = np.empty(count_max, dtype=np.int64)
    overs = np.empty(count_max)
    size = max(own_c.shape[1], next_c.shape[1]) * phi.shape[1]
    disks = np.empty((2, 3, size))
    counts = np.zeros(2, dtype=np.int64)
    cos_d, sin_d = np.empty(phi.shape[1]), np.empty(phi.shape[1])
    w, v, p = np.empty(3), np.empty(3), np.empty(3)
    for row in range(first, stop):
        span = reach[row]
        count = _halving_grid(span, centre[row], levels, grid)
        for d in range(phi.shape[1]):
            cos_d[d], sin_d[d] = math.cos(phi[row, d]), math.sin(phi[row, d])
        for side in range(2):
            centres, axes = (own_c, own_a) if side == 0 else (next_c, next_a)
            counts[side] = 0
            for pose in range(centres.shape[1]):
                # the ring's way to the contact, across the axis towards -n, and a x w
                dot = 0.0
                for c in range(3):
                    dot += normal[row, c] * axes[row, pose, c]
                norm = 0.0
                for c in range(3):
                    w[c] = -(normal[row, c] - dot * axes[row, pose, c])
                    norm += w[c] * w[c]
                norm = math.sqrt(max(norm, TINY))
                for c in range(3):
                    w[c] /= norm
                v[0] = axes[row, pose, 1] * w[2] - axes[row, pose, 2] * w[1]
                v[1] = axes[row, pose, 2] * w[0] - axes[row, pose, 0] * w[2]
                v[2] = axes[row, pose, 0] * w[1] - axes[row, pose, 1] * w[0]
                for d in range(phi.shape[1]):
                    for c in range(3):
                        p[c] = (centres[row, pose, c] - through[row, c]
                                + ring * (cos_d[d] * w[c] + sin_d[d] * v[c]))
                    delta = p[0] * nu[row, 0] + p[1] * nu[row, 1] + p[2] * nu[row, 2]
                    rho_sq = corner * corner - delta * delta
                    if rho_sq < 0.0:
                        continue
                    cx = p[0] * ex[row, 0] + p[1] * ex[row, 1] + p[2] * ex[row, 2]
                    rho = math.sqrt(rho_sq)
                    if cx + rho < 0.0 or cx - rho > span:
                        continue  # covers no interval
                    at = counts[side]
                    disks[side, 0, at] = cx
                    disks[side, 1, at] = p[0] * ey[row, 0] + p[1] * ey[row, 1] + p[2] * ey[row, 2]
                    disks[side, 2, at] = rho_sq
                    counts[side] = at + 1
        _disk_bounds(disks, counts, grid, count, ub)
        if even > 0:
            out_x[row], out_h[row], _ = _even_bounds(disks, counts, grid, count, ub, span,
                                                     even, bend[row], limit[row], fine, low,
                                                     order, overs)
        else:
            out_x[row], out_h[row], _ = _highest_over(grid, count, ub, bend[row], limit[row])


def running_bounds(frame: tuple[NDArray[np.float64], ...], normal: NDArray[np.float64],
                   poses: tuple[NDArray[np.float64], ...], phi: NDArray[np.float64],
                   ring_mm: float, corner_mm: float, reach: NDArray[np.float64],
                   centre: NDArray[np.float64], levels: int, bend: NDArray[np.float64],
                   limit: NDArray[np.float64], even: int = 0
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """An upper bound on the ridge ``min(F_own(x), F_next(x))`` over ``[0, reach]``, row by row.

    Each side is the lower envelope ``F`` of the disks in which the balls of radius
    ``corner_mm`` round ring points ``phi`` (m, S; about the contact, as
    :func:`~.torus_profile.pose_section_ridges` takes them) of several poses cut the plane
    ``frame`` (its point, normal and axes ``x, y``, each (m, 3)): ``poses`` the own ring
    centres and axes, the next's (m, K, 3 each); ``normal`` (m, 3) the seed's. ``F`` is
    convex on no account (several poses). ``[0, reach]`` is cut at ``centre`` (m,) and at
    ``centre +- reach 2^-k``, ``k = 1 .. levels``: intervals halving towards ``centre``.
    Over an interval ``I = [x_a, x_b]`` each disk's lower arc (convex where it covers both
    ends) stands no higher than at its ends, so ``U(I) = min_i max(f_i(x_a), f_i(x_b))``
    bounds ``F`` there (``inf`` where the disk misses an end). On each interval
    ``min(F_own, F_next) <= min(U_own(I), U_next(I))``, and the largest of these over the
    intervals bounds the ridge whatever the envelopes' shapes (no crossing need be unique,
    nor the envelopes monotone). The ridge's height over the surface, not its ``y``, is
    what is bounded: the interval chosen is the one standing highest over the surface's
    section ``bend x^2 / 2`` (``bend`` (m,), 1/mm), ``x`` up to ``limit`` (m,), the
    surface's edge (:func:`_highest_over`). Where the ridge lies near ``centre`` the
    intervals there are narrow, so the bound is close; away from it wide intervals read
    high: where a side's poses stand apart, no one disk covers a wide interval whole
    (``U = inf``) and the other side's far end decides. So with ``even > 0`` the grid is
    cut at ``reach k / even``, ``k = 0 .. even``, too (:func:`_even_bounds`, branch and
    bound: only the intervals standing higher over the surface than the highest part found
    are cut): a finer grid's intervals each lie in one of the coarser's, and a disk
    covering an interval covers each part of it, its convex arc over the part no higher
    than at the interval's ends, so each part's ``U`` is at most the whole's, and its
    height over the surface too (:func:`_over`): the bound only falls, and still bounds
    the ridge. Each disk is met only at the grid points its cover spans (the others read
    ``inf`` all the same).

    Returns the ``x`` where that interval's surface stands lowest and the interval's bound
    on ``y`` (``inf`` where no disk covers an interval whole on a side that decides it).
    """
    m = len(reach)
    out_x, out_h = np.empty(m), np.empty(m)
    if m:
        def c(v):
            return np.ascontiguousarray(v, dtype=float)
        run_in_threads(_running_bounds, m, tuple(c(v) for v in frame), c(normal),
                       tuple(c(v) for v in poses), c(phi), float(ring_mm), float(corner_mm),
                       c(reach), c(centre), int(levels), int(even), c(bend), c(limit), out_x,
                       out_h, min_rows=RUNNING_BOUNDS_ROWS, dynamic=True)
    return out_x, out_h
