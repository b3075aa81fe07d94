r"""Where a line enters and leaves a flat or bull-nose cutter swept along a segment.

The cutter of :class:`toolpath.planning.cutters.Cutter` (radius ``R``, corner radius ``r``)
is the set of points within ``r`` of its *core*: the disc of radius ``rho0 = R - r`` at
height ``r`` above the tip, swept up the axis ``a`` by the core height ``L``. In the tool's
(radial, axial) half-plane the core is the rectangle ``[0, rho0] x [0, L]`` (``z`` measured
from the core's bottom centre ``C``), so the signed distance of a point ``Y = X - C`` to
the core is the closed-form 2-D distance to that rectangle
(:func:`core_signed_distance`), and the cutter is ``{X : sd_core(X - C) <= r}``: the flat
bottom out to ``rho0``, the torus tube of radius ``r``, the cylinder side. ``r = 0`` is a
flat end mill; ``rho0 = 0, L = 0`` a ball (the capsule kernel of :mod:`.capsule` is then
the same answer in closed form).

A piece is that cutter translated, axis fixed, from core centre ``C0`` to ``C0 + D``. Its
sweep ``S`` is convex (a convex solid plus a segment), and

.. math::

    \Phi(\lambda, w) = \mathrm{sd_{core}}(P + \lambda d - C_0 - w D) - r,
    \qquad F(\lambda) = \min_{w \in [0, 1]} \Phi(\lambda, w)

is jointly convex in ``(lam, w)``, so ``F`` (the signed distance of the dexel point
``P + lam d`` to the sweep, exact outside it) is convex in ``lam``, and the line meets
``S`` in the interval ``{F <= 0} = [lam_in, lam_out]``:

* **inner problem** (``w``): a chord across the axis (3-axis moves in the XY plane)
  changes only ``rho``, and ``sd`` grows with ``rho`` at a fixed ``z``: ``w`` is the
  projection of ``P + lam d - C0`` on ``D``, clipped to ``[0, 1]``. A chord along the
  axis changes only ``z``, and ``sd`` is even about the core's mid-height: ``w`` puts
  ``z`` there. Otherwise ``dPhi/dw = -grad(sd) . D`` is non-decreasing in ``w``; its
  root is bracketed between the ball's minimiser (the projection on ``D``) and an end,
  and found by Newton steps on it kept inside the bracket (where one leaves it, or
  ``Phi`` is linear in ``w`` on a flat face, the next point is the nearest ``w`` where
  its formula changes, else the middle; a step over half the one before last is
  replaced by the middle, so the bracket halves at least every other step). It stops
  when ``|Phi_w| (hi - lo) <= 1e-9`` mm at an end or the last point: by convexity the
  minimum is then known to 1e-9 mm;
* **outer problem** (``lam``): Newton's method on ``F`` from a lower bound (the entry into
  a bounding capsule and the slab the sweep spans along ``a``), with
  ``F'(lam) = grad(sd) . d`` at the inner minimiser (Danskin). On a convex function the
  tangent lies below the graph, so every iterate stays left of the first root and
  ``F > 0`` on everything skipped: the iteration is monotone, cannot overshoot, converges
  quadratically on a transversal entry (halving the gap at a tangency), and a line that
  misses shows ``F' >= 0`` with ``F > 0``. The exit is the same from the right.

Iteration stops at ``|F| <= CONVERGED_MM`` (1e-7 mm): the point returned lies within that
of the sweep's boundary.

Each kernel is written once, on scalars, in compiled code (:func:`sweep_interval`,
:func:`sweep_bound`), so the grid walk of :mod:`verification.sweep_search` calls it per
candidate; the array functions run it over rows of pairs.
"""

from __future__ import annotations

import math
from typing import Final

import numba
import numpy as np
from numpy.typing import NDArray

from .capsule import capsule_interval

__all__ = ["CONVERGED_MM", "core_signed_distance", "line_sweep_interval", "sweep_bound",
           "sweep_bound_within", "sweep_distance", "sweep_entry", "sweep_entry_bound",
           "sweep_entry_normal", "sweep_exit", "sweep_interval"]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

CONVERGED_MM: Final[float] = 1e-7
"""``|F|`` at which an entry or exit counts as found, mm (0.1 nm: far below the 0.5 um
replay tolerance, and reached in a few Newton steps)."""

_MAX_NEWTON: Final[int] = 40
"""Newton steps on ``lam`` (a tangent line halves its gap per step: 2^-40 of the span)."""

_MAX_INNER: Final[int] = 30
"""Steps on ``w`` of :func:`_inner_min` (bracketed Newton: a few where ``Phi`` is smooth)."""

_CLOSED_FORM: Final[float] = 1e-24
"""``(D.a)^2 / |D|^2`` (or the across part's) below which a chord counts as exactly across
(along) the axis: the inner minimiser is then in closed form."""

_PARALLEL: Final[float] = 1e-12
"""``|d . a|`` below which a line counts as parallel to the bounding slab's planes."""


@numba.njit(cache=True)
def _core_sd_along(yx: float, yy: float, yz: float, ax: float, ay: float, az: float,
                   height: float, core_radius: float, vx: float, vy: float, vz: float
                   ) -> tuple[float, float, float, float, float]:
    """Signed distance of ``y`` to the core, its gradient, and ``v^T Hess(sd) v``.

    The distance and gradient of :func:`core_signed_distance`; the second derivative of
    ``sd(y + t v)`` in ``t`` where ``sd`` is smooth (the distance to a face, the side, a
    rim): with ``n`` the radial unit vector, ``rho``'s is ``k_rho = (|v_h|^2 - (v.n)^2) /
    rho`` (``v_h`` the part of ``v`` across the axis); the side's is ``k_rho``, a flat face's
    0, a rim's (``sd = hypot(dx, dz)``) ``((v.n)^2 + dx k_rho + (v.a)^2 - (g.v)^2) / sd``;
    inside, the larger of ``dx, dz`` decides. 0 on the axis (``rho = 0``: no direction).
    """
    z = yx * ax + yy * ay + yz * az
    px, py, pz = yx - z * ax, yy - z * ay, yz - z * az
    rho = math.sqrt(px * px + py * py + pz * pz)
    if rho > 0.0:
        px, py, pz = px / rho, py / rho, pz / rho
    dx = rho - core_radius
    below = -z >= z - height
    dz = -z if below else z - height
    s_z = -1.0 if below else 1.0
    ox, oz = max(dx, 0.0), max(dz, 0.0)
    h = math.hypot(ox, oz)
    if h > 0.0:
        cx, cz, sd = ox / h, oz / h * s_z, h
    else:
        cx = 1.0 if dx >= dz else 0.0
        cz = (0.0 if dx >= dz else 1.0) * s_z
        sd = max(dx, dz)
    gx, gy, gz = cx * px + cz * ax, cx * py + cz * ay, cx * pz + cz * az
    va = vx * ax + vy * ay + vz * az
    vn = vx * px + vy * py + vz * pz
    k_rho = (vx * vx + vy * vy + vz * vz - va * va - vn * vn) / rho if rho > 0.0 else 0.0
    if ox > 0.0 and oz > 0.0:
        gv = gx * vx + gy * vy + gz * vz
        curv = (vn * vn + dx * k_rho + va * va - gv * gv) / h
    elif cx > 0.0:
        curv = k_rho
    else:
        curv = 0.0
    return sd, gx, gy, gz, curv


@numba.njit(cache=True)
def _core_sd(yx: float, yy: float, yz: float, ax: float, ay: float, az: float,
             height: float, core_radius: float
             ) -> tuple[float, float, float, float]:
    """Signed distance of ``y`` to the core and its gradient (:func:`core_signed_distance`)."""
    sd, gx, gy, gz, _ = _core_sd_along(yx, yy, yz, ax, ay, az, height, core_radius, 0.0, 0.0,
                                       0.0)
    return sd, gx, gy, gz


@numba.njit(cache=True)
def _phi(yx: float, yy: float, yz: float, w: float, chord: FloatArray, axis: FloatArray,
         height: float, core_radius: float, corner_radius: float
         ) -> tuple[float, float, float, float, float]:
    """``Phi(x, w)``, its gradient in ``x`` (``y = x - C0``) and ``d^2 Phi / dw^2``."""
    sd, gx, gy, gz, curv = _core_sd_along(
        yx - w * chord[0], yy - w * chord[1], yz - w * chord[2], axis[0], axis[1], axis[2],
        height, core_radius, chord[0], chord[1], chord[2])
    return sd - corner_radius, gx, gy, gz, curv


@numba.njit(cache=True)
def _next_break(x: float, right: bool, lo: float, hi: float, z0: float, rise: float,
                height: float, ud: float, aa: float, uu: float, core_radius: float) -> float:
    """The nearest ``w`` past ``x`` (rightwards or leftwards) where ``Phi``'s formula changes.

    ``Phi`` is smooth between the ``w`` where the point crosses the core's bottom, middle
    or top plane (``z0 - w rise`` in ``{0, L/2, L}``) or its side (``|u - w D_h| = rho0``,
    a quadratic: ``aa w^2 - 2 ud w + uu - rho0^2 = 0``); on a face it is linear in ``w``,
    so its minimum lies at or past the next of them. NaN where none lies strictly
    within ``(lo, hi)``.
    """
    best = math.nan
    disc = ud * ud - aa * (uu - core_radius * core_radius)
    root = math.sqrt(disc) if disc >= 0.0 and aa > 0.0 else math.nan
    for k in range(5):
        if k < 3:
            b = (z0 - 0.5 * k * height) / rise
        else:
            b = (ud + (root if k == 3 else -root)) / aa
        if not (lo < b < hi) or (b <= x if right else b >= x):
            continue
        if math.isnan(best) or (b < best if right else b > best):
            best = b
    return best


@numba.njit(cache=True)
def _inner_min(yx: float, yy: float, yz: float, chord: FloatArray, axis: FloatArray,
               height: float, core_radius: float, corner_radius: float
               ) -> tuple[float, float, float, float]:
    """``F = min_w Phi`` at ``x = C0 + y`` and the gradient of ``Phi`` at the minimiser.

    ``dPhi/dw = -grad . D`` is non-decreasing: an end where it does not change sign is the
    minimiser; otherwise a bracketed Newton iteration on it inside ``[0, 1]``. Closed forms:
    a chord across the axis moves ``rho`` only (``sd`` grows with ``rho`` at a fixed ``z``),
    one along the axis moves ``z`` only (``sd`` is even about the mid-height).

    The Newton step uses ``d^2 Phi / dw^2`` (:func:`_core_sd_along`); where it leaves the
    bracket, or ``Phi`` is linear there (a flat face: no curvature), the next point is the
    nearest change of formula downhill (:func:`_next_break`: the minimum lies at or past
    it), else the bracket's middle; the middle too where a step is over half the one
    before last (rtsafe's safeguard: on a bull-nose rim swept down a steep ramp the Newton
    steps crept, each a small share of the last). The minimiser near an entry sits on a
    rim, a zone of ``w`` a few ``F / |D|`` wide between two faces, where the slope jumps by ``|D|``:
    false position took ~27 steps per minimisation there (3-axis flat and bull-nose
    blades), this some 3 to 6. It stops when ``min(|slope|) x (hi - lo) <= 1e-9`` mm at an
    end of the bracket or the last point: by convexity the minimum is then known to that.
    """
    rise = chord[0] * axis[0] + chord[1] * axis[1] + chord[2] * axis[2]
    ux, uy, uz = chord[0] - rise * axis[0], chord[1] - rise * axis[1], chord[2] - rise * axis[2]
    cc = chord[0] * chord[0] + chord[1] * chord[1] + chord[2] * chord[2]
    aa = ux * ux + uy * uy + uz * uz
    flat = rise * rise <= _CLOSED_FORM * cc
    upright = aa <= _CLOSED_FORM * cc and not flat
    if flat:
        w = (yx * ux + yy * uy + yz * uz) / (aa if cc > 0.0 else 1.0)
    elif upright:
        w = (yx * axis[0] + yy * axis[1] + yz * axis[2] - 0.5 * height) / rise
    else:
        # the general case starts where a ball's minimiser would be: the projection on D
        w = (yx * chord[0] + yy * chord[1] + yz * chord[2]) / (cc if cc > 0.0 else 1.0)
    w = min(max(w, 0.0), 1.0)
    best, bx, by, bz, curv = _phi(yx, yy, yz, w, chord, axis, height, core_radius,
                                  corner_radius)
    slope = -(bx * chord[0] + by * chord[1] + bz * chord[2])
    if flat or upright or slope == 0.0:
        return best, bx, by, bz
    # bracket: the guess and the end on the downhill side, unless that end is lower
    right = slope > 0.0
    end = 0.0 if right else 1.0
    f, gx, gy, gz, _ = _phi(yx, yy, yz, end, chord, axis, height, core_radius, corner_radius)
    s_end = -(gx * chord[0] + gy * chord[1] + gz * chord[2])
    if f < best:
        best, bx, by, bz = f, gx, gy, gz
    if not (s_end < 0.0 if right else s_end > 0.0):
        return best, bx, by, bz
    lo, hi = (end, w) if right else (w, end)
    slo, shi = (s_end, slope) if right else (slope, s_end)
    # the breaks of _next_break: the point's height and its part across the axis
    z0 = yx * axis[0] + yy * axis[1] + yz * axis[2]
    rx, ry, rz = yx - z0 * axis[0], yy - z0 * axis[1], yz - z0 * axis[2]
    ud = rx * ux + ry * uy + rz * uz
    uu = rx * rx + ry * ry + rz * rz
    x, sx, kx = w, slope, curv
    step_last = step_before = hi - lo  # the last two steps' lengths (rtsafe's safeguard)
    for _ in range(_MAX_INNER):
        # convexity: min Phi >= Phi(v) - |slope(v)| (hi - lo) at either end and at x
        if not min(-slo, shi, abs(sx)) * (hi - lo) > CONVERGED_MM * 0.01:
            break
        nw = x - sx / kx if kx > 0.0 else math.nan
        if not lo < nw < hi:
            nw = _next_break(x, sx < 0.0, lo, hi, z0, rise, height, ud, aa, uu, core_radius)
        if not lo < nw < hi or abs(nw - x) > 0.5 * step_before:
            # outside the bracket, or not converging (a step over half the one before
            # last: Newton steps on a steep bull-nose ramp crawled to the cap): bisect
            nw = 0.5 * (lo + hi)
        step_before, step_last = step_last, abs(nw - x)
        f, gx, gy, gz, kx = _phi(yx, yy, yz, nw, chord, axis, height, core_radius,
                                 corner_radius)
        if f < best:
            best, bx, by, bz = f, gx, gy, gz
        sx = -(gx * chord[0] + gy * chord[1] + gz * chord[2])
        x = nw
        if sx > 0.0:
            hi, shi = nw, sx
        elif sx < 0.0:
            lo, slo = nw, sx
        else:  # the minimiser itself
            return f, gx, gy, gz
    return best, bx, by, bz


@numba.njit(cache=True)
def _newton(p: FloatArray, d: FloatArray, c0: FloatArray, chord: FloatArray,
            axis: FloatArray, height: float, core_radius: float, corner_radius: float,
            start: float, stop: float, sign: float) -> tuple[float, float, float, float]:
    """First root of ``F`` going from ``start`` towards ``stop`` (``sign`` +1: rightwards).

    ``+inf * sign`` where the line misses the sweep within ``[start, stop]``. With it the
    gradient of ``F`` at the last point measured (the sweep's outward normal at the root
    found, unit but where the core's distance has none; zeros where nothing was measured).
    """
    lam = start
    gx, gy, gz = 0.0, 0.0, 0.0
    for _ in range(_MAX_NEWTON):
        f, gx, gy, gz = _inner_min(p[0] + lam * d[0] - c0[0], p[1] + lam * d[1] - c0[1],
                                   p[2] + lam * d[2] - c0[2], chord, axis, height,
                                   core_radius, corner_radius)
        if f <= CONVERGED_MM:
            return lam, gx, gy, gz
        slope = sign * (gx * d[0] + gy * d[1] + gz * d[2])  # dF along the walk
        if not slope < 0.0:
            return sign * math.inf, gx, gy, gz
        lam = lam - sign * f / slope
        if sign * (lam - stop) > 0.0:
            return sign * math.inf, gx, gy, gz
    return lam, gx, gy, gz  # converging on a tangency: within 2^-40 of the span


@numba.njit(cache=True)
def sweep_bound(p: FloatArray, d: FloatArray, c0: FloatArray, chord: FloatArray,
                axis: FloatArray, height: float, core_radius: float, corner_radius: float
                ) -> tuple[float, float]:
    """Bounds ``lo <= lam_in``, ``hi >= lam_out`` of one line through one swept cutter.

    The sweep lies within ``sqrt(rho0^2 + (L/2)^2) + r`` of the path
    ``C0 + (L/2) a + w D`` of the core's mid-height centre, and between the planes
    ``(X - C0) . a = min(0, D . a) - r`` (the tip's lowest position) and
    ``max(0, D . a) + L + r``: the line's interval through both contains
    ``[lam_in, lam_out]``; ``(+inf, -inf)`` where the line misses them.
    """
    return sweep_bound_within(p, d, c0, chord, axis, height, core_radius, corner_radius,
                              math.inf, -math.inf)


@numba.njit(cache=True)
def sweep_bound_within(p: FloatArray, d: FloatArray, c0: FloatArray, chord: FloatArray,
                       axis: FloatArray, height: float, core_radius: float,
                       corner_radius: float, below: float, above: float
                       ) -> tuple[float, float]:
    """:func:`sweep_bound`, or ``(+inf, -inf)`` where ``lo >= below`` or ``hi < above``.

    The slab's interval (a few products) is taken first and the bounding capsule's
    (square roots) only where the slab alone does not already put ``lo`` at or past
    ``below`` or ``hi`` below ``above``: ``lo`` and ``hi`` are the larger and smaller of
    both intervals' ends, so those hold for them too, and a walk that drops a piece on
    ``lo >= below`` or ``hi < above`` drops the same pieces (the bounds it keeps are
    :func:`sweep_bound`'s, bit for bit). On a 3-axis flat or bull-nose program most
    pieces a dexel meets stand wholly above the best value found so far, or wholly
    behind the design point.
    """
    da = d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2]
    z0 = (p[0] - c0[0]) * axis[0] + (p[1] - c0[1]) * axis[1] + (p[2] - c0[2]) * axis[2]
    rise = chord[0] * axis[0] + chord[1] * axis[1] + chord[2] * axis[2]
    zlo = min(rise, 0.0) - corner_radius
    zhi = max(rise, 0.0) + height + corner_radius
    s_lo, s_hi = -math.inf, math.inf
    if abs(da) > _PARALLEL:
        t1, t2 = (zlo - z0) / da, (zhi - z0) / da
        s_lo, s_hi = min(t1, t2), max(t1, t2)
    elif z0 < zlo or z0 > zhi:
        return math.inf, -math.inf
    if not (s_lo < below and s_hi >= above):
        return math.inf, -math.inf
    half = 0.5 * height
    bound = math.sqrt(core_radius * core_radius + half * half) + corner_radius
    ee = chord[0] * chord[0] + chord[1] * chord[1] + chord[2] * chord[2]
    lo, hi = capsule_interval(p[0], p[1], p[2], d[0], d[1], d[2], c0[0] + half * axis[0],
                              c0[1] + half * axis[1], c0[2] + half * axis[2], chord[0],
                              chord[1], chord[2], ee, bound * bound)
    if not lo <= hi:
        return math.inf, -math.inf
    lo, hi = max(lo, s_lo), min(hi, s_hi)
    if lo > hi:
        return math.inf, -math.inf
    return lo, hi


@numba.njit(cache=True)
def sweep_entry(p: FloatArray, d: FloatArray, c0: FloatArray, chord: FloatArray,
                axis: FloatArray, height: float, core_radius: float, corner_radius: float,
                lo: float, hi: float) -> float:
    """Entry ``lam_in`` of one line into one swept cutter, from its bounds ``lo, hi``.

    ``lo, hi`` are :func:`sweep_bound`'s; ``+inf`` where the line misses. The Newton
    steps approach from the left: the value returned is at most the true entry.
    """
    return sweep_entry_normal(p, d, c0, chord, axis, height, core_radius, corner_radius, lo,
                              hi)[0]


@numba.njit(cache=True)
def sweep_entry_normal(p: FloatArray, d: FloatArray, c0: FloatArray, chord: FloatArray,
                       axis: FloatArray, height: float, core_radius: float,
                       corner_radius: float, lo: float, hi: float
                       ) -> tuple[float, float, float, float]:
    """:func:`sweep_entry`, and the sweep's outward normal there.

    The gradient of ``F`` at the entry returned (a unit vector: the direction from the
    nearest point of the swept core); where the line misses, ``+inf`` and a gradient of
    no meaning (zeros where nothing was measured).
    """
    if not math.isfinite(lo):
        return math.inf, 0.0, 0.0, 0.0
    return _newton(p, d, c0, chord, axis, height, core_radius, corner_radius, lo, hi, 1.0)


@numba.njit(cache=True)
def sweep_exit(p: FloatArray, d: FloatArray, c0: FloatArray, chord: FloatArray,
               axis: FloatArray, height: float, core_radius: float, corner_radius: float,
               entry: float, hi: float) -> float:
    """Exit ``lam_out`` of one line from one swept cutter it enters at ``entry``.

    ``hi`` is :func:`sweep_bound`'s upper bound. The Newton steps approach from the right:
    the value returned is at least the true exit.
    """
    return _newton(p, d, c0, chord, axis, height, core_radius, corner_radius, hi, entry,
                   -1.0)[0]


@numba.njit(cache=True)
def sweep_interval(p: FloatArray, d: FloatArray, c0: FloatArray, chord: FloatArray,
                   axis: FloatArray, height: float, core_radius: float, corner_radius: float,
                   exit_wanted: bool) -> tuple[float, float]:
    """Entry and exit of one line ``P + lam d`` through one swept cutter (module method).

    Without ``exit_wanted`` the exit only tells whether the sweep reaches ``P``: ``+inf``
    where it does (``lam_out > 0``), else the entry. ``(+inf, -inf)`` where the line
    misses.
    """
    lo, hi = sweep_bound(p, d, c0, chord, axis, height, core_radius, corner_radius)
    entry = sweep_entry(p, d, c0, chord, axis, height, core_radius, corner_radius, lo, hi)
    if not math.isfinite(entry):
        return math.inf, -math.inf
    if exit_wanted:
        return entry, sweep_exit(p, d, c0, chord, axis, height, core_radius, corner_radius,
                                 entry, hi)
    if entry < 0.0:
        f0, _, _, _ = _inner_min(p[0] - c0[0], p[1] - c0[1], p[2] - c0[2], chord, axis,
                                 height, core_radius, corner_radius)
        if not f0 <= 0.0:
            return entry, entry
    return entry, math.inf


@numba.njit(cache=True, parallel=True)
def _rows(kind: int, points: FloatArray, dirs: FloatArray, core0: FloatArray,
          chord: FloatArray, axis: FloatArray, height: FloatArray, core_radius: float,
          corner_radius: float, exit_wanted: BoolArray, first: FloatArray,
          second: FloatArray) -> None:
    """A kernel over rows of pairs: 0 the interval, 1 the bound, 2 ``F`` at the points."""
    for i in numba.prange(points.shape[0]):
        if kind == 0:
            first[i], second[i] = sweep_interval(
                points[i], dirs[i], core0[i], chord[i], axis[i], height[i], core_radius,
                corner_radius, exit_wanted[i])
        elif kind == 1:
            first[i], second[i] = sweep_bound(points[i], dirs[i], core0[i], chord[i],
                                              axis[i], height[i], core_radius, corner_radius)
        else:
            first[i], _, _, _ = _inner_min(
                points[i, 0] - core0[i, 0], points[i, 1] - core0[i, 1],
                points[i, 2] - core0[i, 2], chord[i], axis[i], height[i], core_radius,
                corner_radius)


def _run_rows(kind: int, points: FloatArray, dirs: FloatArray, core0: FloatArray,
              chord: FloatArray, axis: FloatArray, height_mm: FloatArray,
              core_radius_mm: float, corner_radius_mm: float,
              exit_wanted: BoolArray | None = None) -> tuple[FloatArray, FloatArray]:
    m = points.shape[0]
    first, second = np.empty(m), np.empty(m)
    f = np.ascontiguousarray
    want = (np.zeros(m, dtype=np.bool_) if exit_wanted is None
            else f(np.broadcast_to(exit_wanted, (m,)), dtype=np.bool_))
    _rows(kind, f(points, dtype=float), f(dirs, dtype=float), f(core0, dtype=float),
          f(chord, dtype=float), f(axis, dtype=float),
          f(np.broadcast_to(height_mm, (m,)), dtype=float), float(core_radius_mm),
          float(corner_radius_mm), want, first, second)
    return first, second


@numba.njit(cache=True, parallel=True)
def _core_rows(y: FloatArray, axis: FloatArray, height: FloatArray, core_radius: float,
               sd: FloatArray, grad: FloatArray) -> None:
    for i in numba.prange(y.shape[0]):
        sd[i], grad[i, 0], grad[i, 1], grad[i, 2] = _core_sd(
            y[i, 0], y[i, 1], y[i, 2], axis[i, 0], axis[i, 1], axis[i, 2], height[i],
            core_radius)


def core_signed_distance(y: FloatArray, axis: FloatArray, height_mm: FloatArray,
                         core_radius_mm: float) -> tuple[FloatArray, FloatArray]:
    """Signed distance of points to the core cylinder and its gradient (< 0 inside).

    With ``z = y . a``, ``rho = |y - z a|``, ``dx = rho - rho0`` and
    ``dz = max(-z, z - L)``: outside, ``sqrt(max(dx, 0)^2 + max(dz, 0)^2)``; inside,
    ``max(dx, dz)``: the distance to the rectangle ``[0, rho0] x [0, L]`` of the (radial,
    axial) half-plane (the same solid as :meth:`Cutter.signed_distance
    <toolpath.planning.cutters.Cutter.signed_distance>` before its offset by ``r``).

    Parameters
    ----------
    y : ndarray, shape (m, 3)
        Points relative to the core's bottom centre, mm.
    axis : ndarray, shape (m, 3)
        Unit tool axes.
    height_mm : ndarray, shape (m,)
        Core heights ``L``, mm (>= 0).
    core_radius_mm : float
        ``rho0 = R - r``, mm.

    Returns
    -------
    sd : ndarray, shape (m,)
        Signed distance, mm.
    grad : ndarray, shape (m, 3)
        Its gradient (unit outside; a one-sided choice on the axis and the medial
        surfaces, where it has none).
    """
    m = y.shape[0]
    sd, grad = np.empty(m), np.empty((m, 3))
    f = np.ascontiguousarray
    _core_rows(f(y, dtype=float), f(axis, dtype=float),
               f(np.broadcast_to(height_mm, (m,)), dtype=float), float(core_radius_mm), sd,
               grad)
    return sd, grad


def sweep_distance(points: FloatArray, core0: FloatArray, chord: FloatArray, axis: FloatArray,
                   height_mm: FloatArray, *, core_radius_mm: float, corner_radius_mm: float
                   ) -> FloatArray:
    """``F``: signed distance of points to the swept cutters, pairwise (exact outside), mm."""
    f, _ = _run_rows(2, points, points, core0, chord, axis, height_mm, core_radius_mm,
                     corner_radius_mm)
    return f


def line_sweep_interval(points: FloatArray, dirs: FloatArray, core0: FloatArray,
                        chord: FloatArray, axis: FloatArray, height_mm: FloatArray, *,
                        core_radius_mm: float, corner_radius_mm: float,
                        exit_wanted: BoolArray | None = None
                        ) -> tuple[FloatArray, FloatArray]:
    """Entry and exit of lines through swept flat/bull-nose cutters, pairwise.

    Parameters
    ----------
    points, dirs : ndarray, shape (m, 3)
        Line origins ``P`` (mm) and unit directions ``d``.
    core0 : ndarray, shape (m, 3)
        Core bottom centres ``C0 = tip + r a`` at the piece's start, mm.
    chord : ndarray, shape (m, 3)
        Translation ``D`` of the piece, mm.
    axis : ndarray, shape (m, 3)
        Unit tool axes (fixed along the piece).
    height_mm : ndarray, shape (m,)
        Core heights ``L``, mm: the piece is the cutter up to ``L + 2 r`` above its tip.
    core_radius_mm, corner_radius_mm : float
        ``rho0 = R - r`` and ``r``, mm.
    exit_wanted : ndarray of bool, optional
        Pairs whose exact exit is needed. Elsewhere the exit returned only tells whether
        the sweep reaches ``P``: ``+inf`` where it does (``lam_out > 0``), else the entry.

    Returns
    -------
    lam_in, lam_out : ndarray, shape (m,)
        Signed distances along ``d`` from ``P``, mm; ``+inf`` and ``-inf`` where the line
        misses.
    """
    return _run_rows(0, points, dirs, core0, chord, axis, height_mm, core_radius_mm,
                     corner_radius_mm, exit_wanted)


def sweep_entry_bound(points: FloatArray, dirs: FloatArray, core0: FloatArray,
                      chord: FloatArray, axis: FloatArray, height_mm: FloatArray, *,
                      core_radius_mm: float, corner_radius_mm: float
                      ) -> tuple[FloatArray, FloatArray]:
    """Bounds on where lines meet swept cutters (:func:`sweep_bound`), pairwise.

    Parameters
    ----------
    points, dirs, core0, chord, axis, height_mm, core_radius_mm, corner_radius_mm
        As for :func:`line_sweep_interval`.

    Returns
    -------
    lo, hi : ndarray, shape (m,)
        ``lo <= lam_in`` and ``hi >= lam_out``, mm; ``+inf`` and ``-inf`` where the line
        misses the bounds.
    """
    return _run_rows(1, points, dirs, core0, chord, axis, height_mm, core_radius_mm,
                     corner_radius_mm)
