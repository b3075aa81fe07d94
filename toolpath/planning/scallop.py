"""Spacing between passes from the requested scallop height, exact for circular sections.

**Ball.** Across the passes, the surface's normal section is a circle of signed curvature
``k`` (positive concave, :mod:`toolpath.surface`) and the ball's section a circle of
radius ``rho``. The ball centres then lie on the circle of radius ``1/|k| +/- rho`` and the
cusp between two passes at height ``h`` above the surface (convex surfaces fall away under
the cusp, so they need a smaller stepover than a plane; concave ones allow a larger one).
In the triangle (centre of curvature, cutter centre, cusp) the law of cosines gives, for
convex and concave alike,

``sin(alpha / 4) = z = |k| sqrt(h (2 rho - h)) / (2 sqrt((1 - h k)(1 - rho k)))``

with ``alpha`` the angle between the two contacts, so the stepover along the surface is

``w = 4 asin(z) / |k| = 2 sqrt(h (2 rho - h)) / sqrt((1 - h k)(1 - rho k)) * asin(z) / z``,

which tends to the flat-surface ``2 sqrt(h (2 rho - h))`` as ``k -> 0``. It needs
``rho k < 1`` (a concave radius larger than the cutter's; otherwise the cutter gouges,
see :mod:`toolpath.planning.gouge`).

**Flat and bull-nose.** Their section across the pass is no circle: the core disc seen
along the feed (an ellipse, a segment when seen edge-on) grown by the corner radius. Its
osculating circle at the contact (the effective radius) holds only for small ``h``, so
:func:`shadow_stepover_mm` walks the true section on each side of the contact to the
height ``h`` over the same surface circle. In 5-axis, where the axis turns round a convex
edge (:func:`turn_radius_mm`), the section's sides are lifted: the cutter's points beside
the contact turn away from the surface instead of sweeping straight under the cusp.

Pass levels are placed greedily in ``s``: from a level ``s_k`` the next is ``s_k + ds``
with ``ds = min A(s')`` over ``s' in [s_k, s_k + lookahead * ds]``, where
``A(s) = min_t w(t, s) / q(t, s)`` is the allowed parameter step over the whole pass
(``q`` is the distance across passes per unit ``s``), so the worst scallop along every
pass is within the request.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..tolerances import FLAT_PER_MM, LIMIT_SLACK, ROUND_OFF, TINY
from .cutter_kernel import shadow_point
from .cutters import CutterShadow
from .errors import PlanningError

__all__ = ["TURNING_UNDERCUT_SHARE", "cusp_allowance_mm", "pass_levels", "scallop_height_mm",
           "shadow_stepover_mm", "stepover_mm", "turn_radius_mm", "undercut_limit_mm"]

TURNING_UNDERCUT_SHARE = 0.05
"""Share of the planned scallop a move may stand above a convex pass where the tool axis
turns along it (5-axis).

A straight move stands above the surface where the pass is concave (the chord above the
arc: :data:`~toolpath.planning.options.CONCAVE_UNDERCUT_SHARE`, a quarter). On a convex
pass it only cuts in, unless the tool axis turns along it: that bows the cutter off the
chord, outwards as well (joint interpolation, the normalized mean axis). On a convex
40 mm stretch of the dev blade (``S11`` -0.0085 to -0.0199/mm) 5-axis ball moves stood
up to 0.0037 mm above the surface, within the quarter the chord check then allowed
everywhere, and lifted the cusps from the planned 0.018 mm to 0.021 mm, over the 0.02 mm
asked (issue 28). A twentieth keeps the passes' spacing within 2.5 % of what it was
(stepover ~ sqrt(h)) and splits the few moves that stand up more (a bow shrinks fourfold
per halving); the quarter would cost 15 % more passes on a sphere cap whose moves do not
stand up at all."""


def _stand_up_mm(undercut_mm: float, scallop_mm: float, concave: NDArray[np.bool_],
                 turning: ArrayLike) -> NDArray[np.float64]:
    """How far a move may stand above the surface: the one rule of the two functions below."""
    small = min(undercut_mm, TURNING_UNDERCUT_SHARE * scallop_mm)
    return np.where(concave, undercut_mm, np.where(turning, small, 0.0))


def cusp_allowance_mm(scallop_mm: float, undercut_mm: float,
                      curvature_along_per_mm: ArrayLike, axis_turns: bool
                      ) -> NDArray[np.float64]:
    """Cusp height the passes are spaced for: the scallop less what the moves may stand up.

    A move along a pass standing above the surface lifts the cusps beside it by as much,
    so the passes are spaced for the scallop less :func:`undercut_limit_mm`: the whole
    undercut allowance where the pass is concave, :data:`TURNING_UNDERCUT_SHARE` of the
    scallop where it is convex and the axis turns (``axis_turns``: lead/tilt), nothing
    where it is convex under a fixed axis (the moves only cut in).

    Parameters
    ----------
    scallop_mm, undercut_mm : float
        Planned cusp height and the concave passes' undercut allowance, mm.
    curvature_along_per_mm : array_like
        ``S11`` at the probe points, 1/mm (positive concave).
    axis_turns : bool
        The tool axis turns along the passes (lead/tilt).

    Returns
    -------
    ndarray
        Cusp height per point, mm.
    """
    concave = np.asarray(curvature_along_per_mm, dtype=float) > FLAT_PER_MM
    return scallop_mm - _stand_up_mm(undercut_mm, scallop_mm, concave, axis_turns)


def undercut_limit_mm(undercut_mm: float, scallop_mm: float, s11_start: ArrayLike,
                      s11_end: ArrayLike, axes_start: ArrayLike, axes_end: ArrayLike
                      ) -> NDArray[np.float64]:
    """How far each move may stand above the surface (the chord check's limit), mm.

    The passes' spacing keeps room for it (:func:`cusp_allowance_mm`): the concave
    allowance ``undercut_mm`` where the pass is concave at either end of the move, or the
    axis does not turn along it (a convex pass's fixed-axis move never stands up: the
    limit is never met there); :data:`TURNING_UNDERCUT_SHARE` of ``scallop_mm`` on a
    convex pass where the axis turns.

    Parameters
    ----------
    undercut_mm, scallop_mm : float
        The concave allowance and the planned scallop, mm.
    s11_start, s11_end : array_like, shape (m,)
        ``S11`` at the moves' ends, 1/mm.
    axes_start, axes_end : array_like, shape (m, 3)
        Unit tool axes at the moves' ends.

    Returns
    -------
    ndarray, shape (m,)
    """
    concave = ((np.asarray(s11_start, dtype=float) > FLAT_PER_MM)
               | (np.asarray(s11_end, dtype=float) > FLAT_PER_MM))
    turning = np.any(np.asarray(axes_start) != np.asarray(axes_end), axis=-1)
    return _stand_up_mm(undercut_mm, scallop_mm, concave | ~turning, True)


def stepover_mm(scallop_mm: ArrayLike, radius_mm: ArrayLike, curvature_per_mm: ArrayLike
                ) -> NDArray[np.float64]:
    """Stepover along the surface that leaves cusps of height ``scallop_mm`` (formula above).

    Parameters
    ----------
    scallop_mm : float or array_like
        Cusp height ``h``, mm (``0 < h < 2 rho``).
    radius_mm : array_like
        Cutter section radius ``rho`` across the feed, mm (``inf`` allowed: flat face).
    curvature_per_mm : array_like
        Surface normal curvature across the passes, 1/mm, positive concave.

    Returns
    -------
    ndarray
        Stepover ``w``, mm; ``0`` where ``rho k >= 1`` (the cutter does not fit). An
        infinite ``rho`` (a flat face) gives the limit: point contacts, whose cusp is the
        bulge of a convex surface between them; ``inf`` on a plane, ``0`` when concave.
    """
    return _stepover(np.asarray(scallop_mm, dtype=float), np.asarray(radius_mm, dtype=float),
                     np.asarray(curvature_per_mm, dtype=float))


#: Below this ``z``, ``asin(z) / z`` is its series ``1 + z^2 / 6`` (the next term, ``3 z^4
#: / 40``, is under 1e-17 there), and ``0 / 0`` at ``z = 0`` is avoided.
_ASIN_SERIES_Z = 1e-4


@numba.vectorize(["float64(float64, float64, float64)"], cache=True)
def _stepover(h, rho, k):
    """:func:`stepover_mm` at one point (a compiled ufunc: it broadcasts)."""
    if math.isnan(k):
        return 0.0  # (as where the cutter does not fit)
    if not abs(rho) < math.inf:  # (not math.isfinite: it flags an invalid operation)
        # a flat profile (rho -> inf): point contacts; on a convex surface the cusp is the
        # surface's own bulge, z -> sqrt(2 h |k|) / (2 sqrt(1 + h |k|)); on a plane unbounded
        if k < 0.0:
            z = math.sqrt(2.0 * h * abs(k)) / (2.0 * math.sqrt(max(1.0 - h * k, TINY)))
            angle = math.pi if z >= 1.0 else 4.0 * math.asin(min(z, 1.0))
            return angle / max(abs(k), TINY)
        return math.inf if k == 0.0 else 0.0
    chord = math.sqrt(max(h * (2.0 * rho - h), 0.0))
    denom = (1.0 - h * k) * (1.0 - rho * k)
    if not denom > 0.0:
        return 0.0  # the cutter does not fit
    root = math.sqrt(denom)
    z = abs(k) * chord / (2.0 * root)
    if z >= 1.0:
        # only in a hollow the cutter nearly fills (rho k -> 1) under a tall cusp: there
        # the cusp never reaches h and the stepover is half the hollow's circle
        return math.pi / max(abs(k), TINY)
    # asin(z) / z, with its limit 1 at 0
    ratio = 1.0 + z * z / 6.0 if z < _ASIN_SERIES_Z else math.asin(z) / z
    return 2.0 * chord / root * ratio


def scallop_height_mm(stepover: ArrayLike, radius_mm: ArrayLike, curvature_per_mm: ArrayLike
                      ) -> NDArray[np.float64]:
    """Cusp height for a given stepover (the inverse of :func:`stepover_mm`), mm.

    From the same triangle: ``x`` (distance of the cusp from the centre of curvature)
    solves ``x^2 - 2 x D cos(alpha/2) + D^2 - rho^2 = 0`` with ``D = 1/|k| +/- rho`` and
    ``alpha = w |k|`` (the smaller root when convex, the larger when concave);
    ``h = x - 1/|k|`` (convex) or ``1/|k| - x`` (concave); on a plane
    ``h = rho - sqrt(rho^2 - w^2 / 4)``.
    """
    w = np.asarray(stepover, dtype=float)
    rho = np.asarray(radius_mm, dtype=float)
    k = np.asarray(curvature_per_mm, dtype=float)
    w, rho, k = np.broadcast_arrays(w, rho, k)
    flat = np.abs(k) < FLAT_PER_MM
    radius = 1.0 / np.where(flat, 1.0, np.abs(k))
    half = 0.5 * w * np.where(flat, 0.0, np.abs(k))
    convex = k < 0.0
    d = np.where(convex, radius + rho, radius - rho)
    disc = np.maximum(rho**2 - (d * np.sin(half)) ** 2, 0.0)
    # the cusp lies between the surface and the cutter centres: the nearer root when
    # convex (centres outside the cusp), the farther when concave
    x = d * np.cos(half) + np.where(convex, -1.0, 1.0) * np.sqrt(disc)
    curved = np.where(convex, x - radius, radius - x)
    plane = rho - np.sqrt(np.maximum(rho**2 - 0.25 * w**2, 0.0))
    return np.where(flat, plane, curved)


#: Halvings of the boundary-normal angle in :func:`shadow_stepover_mm` (to 1.5e-6 rad), then
#: of the final bracket's chord (to 1e-9 of it: the chord may be a whole flat face, over
#: which a convex surface's height grows quadratically).
SHADOW_HALVINGS = 20
CHORD_HALVINGS = 30


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _section_height(y, z, x, k, lever):
    """Height of the cutter point ``(y, z)`` (``x`` along the pass) above the section circle.

    The section through the contact (origin, normal ``+z``) has curvature ``k`` (positive
    concave: centre at ``z = 1/k``). The point is first lifted by the turn,
    ``x^2 / (sqrt(d^2 + x^2) + d)`` with ``d = lever + z`` (0 for an infinite lever);
    then ``h = (2 z - k (y^2 + z^2)) / (1 + sqrt(k^2 y^2 + (1 - k z)^2))`` (the difference
    of radii, written without cancellation, ``z`` on a plane).
    """
    z = _lifted(z, x, lever)
    return (2.0 * z - k * (y * y + z * z)) / (1.0 + math.sqrt((k * y) ** 2 + (1.0 - k * z) ** 2))


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _section_arc(y, z, x, k, lever):
    """Arc from the contact to the foot of the (lifted) point.

    ``atan2(k y, 1 - k z) / k`` (``y`` on a plane).
    """
    z = _lifted(z, x, lever)
    if abs(k) > FLAT_PER_MM:
        return math.atan2(k * y, 1.0 - k * z) / k
    return y


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _lifted(z, x, lever):
    d = lever + max(z, 0.0)
    if d < math.inf:
        return z + x * x / (math.sqrt(d * d + x * x) + d)
    return z


def shadow_stepover_mm(scallop_mm: ArrayLike, radius_mm: float, corner_radius_mm: float,
                       normals: ArrayLike, axes: ArrayLike, e2: ArrayLike,
                       curvature_per_mm: ArrayLike, *, mirrored: bool = False,
                       turn_radius_mm: ArrayLike | None = None,
                       cutter_curvature_along_per_mm: ArrayLike = 0.0
                       ) -> NDArray[np.float64]:
    """Stepover from the cutter's true section across the pass (flat and bull-nose).

    Moving along the pass ``e1``, the cutter sweeps its shadow along ``e1``: in the plane
    ``(e2, n)`` the projection of the core disc (an ellipse; radius ``R - r``, normal along
    the axis ``a``) grown by the corner radius ``r``
    (:class:`~toolpath.planning.cutters.CutterShadow`); its boundary point with outward
    normal ``sin(b) e2 - cos(b) n`` is known exactly, and ``b = 0`` is the contact. On each
    side the angle ``b`` where that point stands ``scallop_mm`` above the surface's
    cross-section circle (curvature ``S22``) is found by bisection (then along the chord of
    the final bracket, which may span a straight piece: a disc seen edge-on). The cusp
    between two passes stands there when each pass reaches it: the stepover is the sum of
    the two sides' arcs when the neighbour's section is the same (seen along the pass, a
    lead leaning either way casts the same shadow), twice the smaller one when it is
    mirrored (a tilt on zig-zag passes). A flat face on a slope thus gets its staircase,
    ``h / tan(slope)``, from its one rising side.

    Away from the contact the section curves more than its osculating circle (the
    ellipse's ends), so at coarse scallops this is smaller than :func:`stepover_mm` with
    the effective radius, which it equals in the limit of small ``h``.

    **A turning axis.** The shadow is the section of a cutter swept straight. When the
    axis turns as the cutter moves round a convex edge, the motion is, to first order, a
    rotation about an axis along ``e2`` at the turn radius ``rho_t`` below the contact
    (:func:`turn_radius_mm`; the cutter's point at the contact moves along the pass). A
    cutter point ``x`` along the pass from the contact and ``z`` above it reaches the
    section's plane on its circle, higher by ``x^2 / (2 (rho_t + z))``; the cutter's
    neighbouring points (radius of curvature ``rho_c`` along the pass) let the lowest swept
    point come from nearer ``x = 0``: with both curves quadratic the lift is
    ``x^2 / (2 (rho_t + z + rho_c))`` (taken in the circle form
    ``x^2 / (sqrt(d^2 + x^2) + d)``, ``d = rho_t + z + rho_c``). Round a leading edge
    tighter than the cutter the straight shadow's cusp is far too low. A turn the other
    way (concave) only lowers the swept points: the straight shadow is kept.

    Parameters
    ----------
    scallop_mm : float or array_like
        Cusp height ``h``, mm.
    radius_mm, corner_radius_mm : float
        Cutter radius ``R`` and corner radius ``r``.
    normals, axes, e2 : array_like, shape (n, 3)
        Unit surface normals, tool axes and across directions at the contacts (the pass
        runs along ``e2 x normals``).
    curvature_per_mm : array_like, shape (n,)
        Surface normal curvature across the passes, 1/mm, positive concave.
    mirrored : bool
        The neighbouring pass's section is this one mirrored across the pass.
    turn_radius_mm : array_like, shape (n,), optional
        ``rho_t``: the radius of the axis' convex turn along the pass, mm (``inf``: none).
        Default: a straight sweep.
    cutter_curvature_along_per_mm : float or array_like
        The cutter's curvature along the pass at the contact (``rho_c = 1 / it``), 1/mm.

    Returns
    -------
    ndarray, shape (n,)
        Stepover along the surface, mm; where the whole side stays below ``h`` (a scallop
        near the corner radius) the arc to the side's extreme point.
    """
    n = np.asarray(normals, dtype=float)
    k = np.broadcast_to(np.asarray(curvature_per_mm, dtype=float), n.shape[:1])
    h = np.broadcast_to(np.asarray(scallop_mm, dtype=float), n.shape[:1])
    # heights are taken from the contact, the boundary point at angle 0
    shadow = CutterShadow.seen_along(radius_mm - corner_radius_mm, corner_radius_mm,
                                     np.zeros_like(n), np.asarray(axes, dtype=float),
                                     np.asarray(e2, dtype=float), n)
    # the turn radius and the cutter's own radius along the pass, summed: the lift's lever
    lever = np.full(len(n), np.inf)
    if turn_radius_mm is not None:
        c11 = np.broadcast_to(np.asarray(cutter_curvature_along_per_mm, dtype=float), lever.shape)
        with np.errstate(divide="ignore"):
            rho_c = np.where(c11 > 0.0, 1.0 / np.where(c11 > 0.0, c11, 1.0), np.inf)
        lever = np.broadcast_to(np.asarray(turn_radius_mm, dtype=float), lever.shape) + rho_c
    arcs = np.empty((2, len(n)))
    _shadow_arcs(*(np.ascontiguousarray(v, dtype=float) for v in (
        *shadow.matrix, *shadow.depth_matrix, h, k, lever)), float(corner_radius_mm), arcs)
    if mirrored:
        return 2.0 * np.minimum(arcs[0], arcs[1])
    return arcs[0] + arcs[1]


@numba.njit(cache=True, parallel=True)
def _shadow_arcs(a11, a12, a21, a22, d1, d2, h, k, lever, r, out):
    """Each side's arc of :func:`shadow_stepover_mm` at each point, into ``out[side]``."""
    for i in numba.prange(h.size):
        shadow = (a11[i], a12[i], a21[i], a22[i], d1[i], d2[i], r)
        origin = shadow_point(a11[i], a12[i], a21[i], a22[i], d1[i], d2[i], r, 0.0)
        for side in range(2):
            lo, hi = 0.0, (0.5 if side == 0 else -0.5) * math.pi
            y, z, x = _cast(shadow, origin, hi)
            if _section_height(y, z, x, k[i], lever[i]) < h[i]:  # the whole side is below
                out[side, i] = abs(_section_arc(y, z, x, k[i], lever[i]))
                continue
            for _ in range(SHADOW_HALVINGS):
                mid = 0.5 * (lo + hi)
                y, z, x = _cast(shadow, origin, mid)
                if _section_height(y, z, x, k[i], lever[i]) < h[i]:
                    lo = mid
                else:
                    hi = mid
            # the bracket is tiny, or straddles a straight piece of the boundary (a disc
            # seen edge-on jumps from one end to the other): find the height along the
            # chord, whose points are cutter points too (of the flat bottom)
            ya, za, xa = _cast(shadow, origin, lo)
            yb, zb, xb = _cast(shadow, origin, hi)
            u_lo, u_hi = 0.0, 1.0
            for _ in range(CHORD_HALVINGS):
                u = 0.5 * (u_lo + u_hi)
                if _section_height(ya + u * (yb - ya), za + u * (zb - za), xa + u * (xb - xa),
                                   k[i], lever[i]) < h[i]:
                    u_lo = u
                else:
                    u_hi = u
            # the side still below h: conservative
            out[side, i] = abs(_section_arc(ya + u_lo * (yb - ya), za + u_lo * (zb - za),
                                            xa + u_lo * (xb - xa), k[i], lever[i]))


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _cast(shadow, origin, theta):
    """The cutter point casting boundary point ``theta``, from the contact: ``y, z, x``."""
    a11, a12, a21, a22, d1, d2, r = shadow
    y, z, x = shadow_point(a11, a12, a21, a22, d1, d2, r, theta)
    return y - origin[0], z - origin[1], x - origin[2]


#: A turn of the tool axis slower than this (rad per mm of pass: a radius over 1e9 mm) is
#: none: the turn radius is infinite there rather than the inverse of round-off.
_STILL_TURN_PER_MM = 1e-9


def turn_radius_mm(contacts: ArrayLike, normals: ArrayLike, e1: ArrayLike, axes: ArrayLike
                   ) -> NDArray[np.float64]:
    """Radius of the axis' convex turn along passes, mm (``inf`` where it turns concave or not).

    Arrays of shape ``(m, p, 3)``: ``m`` points along each of ``p`` passes, in pass order,
    ``e1`` along the pass. With ``'`` the derivative along the pass (central differences),
    the axis turns at ``w = (a x a') . (n x e1) / |c'|`` per mm of contact path, positive
    in the sense the normal of a convex surface turns (``n' = -S11 e1`` with ``S11 < 0``);
    the cutter's point at the contact moves along the pass, so the turn is about the line
    ``1 / w`` below the contact.
    """
    c, n, e1, a = (np.asarray(v, dtype=float) for v in (contacts, normals, e1, axes))
    if a.shape[0] < 2:
        return np.full(a.shape[:2], np.inf)
    arc = np.linalg.norm(np.gradient(c, axis=0), axis=-1)
    turn = np.einsum("ijk,ijk->ij", np.cross(a, np.gradient(a, axis=0)), np.cross(n, e1))
    rate = turn / np.maximum(arc, TINY)
    with np.errstate(divide="ignore"):
        return np.where(rate > _STILL_TURN_PER_MM,
                        1.0 / np.where(rate > _STILL_TURN_PER_MM, rate, 1.0), np.inf)


@numba.njit(cache=True, inline="always")
def _count_at_most(grid, x, j):
    """``searchsorted(grid, x, side="right")``, walking forward from ``j`` (at most that)."""
    while j < grid.size and grid[j] <= x:
        j += 1
    return j


@numba.njit(cache=True, inline="always")
def _count_below(grid, x, j):
    """``searchsorted(grid, x, side="left")``, walking forward from ``j`` (at most that)."""
    while j < grid.size and grid[j] < x:
        j += 1
    return j


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _least(values, lo, hi):
    """``values[lo:hi + 1].min()`` (the first NaN if there is one), by a loop.

    (numba's ``min`` of an array view compiles its general iteration: about 0.5 CPU s
    of a cold start, issue 27.)
    """
    least = values[lo]
    j = lo + 1
    while j <= hi and not math.isnan(least):
        if values[j] < least or math.isnan(values[j]):
            least = values[j]
        j += 1
    return least


@numba.njit(cache=True)
def _greedy(grid, allowed, lower, scale, lookahead, levels):
    """The greedy walk of :func:`pass_levels` into ``levels``; the count, -1 if too many.

    At ``s``: ``A(s)`` (the probe's value on a probe level, else the smaller neighbour's),
    shrunk to the least ``A`` over the window ``[s, s + lookahead ds]`` until it holds.
    The probe levels are found walking forward (``s`` only grows), as a search would.
    """
    last = lower.size - 1
    levels[0] = 0.0
    count = 1
    s = 0.0
    at_most = 0  # probe levels <= s
    while s < 1.0:
        at_most = _count_at_most(grid, s, at_most)
        j0 = min(max(at_most - 1, 0), last)
        ds = scale * (allowed[j0] if s == grid[j0] else lower[j0])
        for _ in range(60):
            hi = min(s + lookahead * ds, 1.0)  # (> s: the window's last level from s's)
            j1 = min(max(_count_below(grid, hi, max(at_most - 1, 0)) - 1, 0), last)
            new = min(ds, scale * _least(lower, j0, j1))
            if new >= ds * (1.0 - ROUND_OFF):
                break
            ds = new
        s = 1.0 if s + ds >= 1.0 - LIMIT_SLACK else s + ds
        if count == levels.size:
            return -1
        levels[count] = s
        count += 1
    return count


def pass_levels(s_grid: ArrayLike, allowed_ds: ArrayLike, *, lookahead: float = 1.0,
                balance: bool = True, max_passes: int = 200_000) -> NDArray[np.float64]:
    """Greedy pass levels ``0 = s_0 < s_1 < ... < s_n = 1`` (see the module docstring).

    Parameters
    ----------
    s_grid : array_like, shape (m,)
        Increasing probe levels covering [0, 1].
    allowed_ds : array_like, shape (m,)
        ``A(s)``: the largest parameter step at each probe level (> 0; ``inf`` where
        nothing constrains it). Between two levels the smaller value holds.
    lookahead : float
        Window factor: ``ds <= min A`` over ``[s_k, s_k + lookahead * ds]`` (2 for a
        spiral, whose gap at ``t`` spans two consecutive level gaps).
    balance : bool
        The pass count is the greedy one, rounded up; with ``balance`` every step is then
        scaled by the smallest common factor that keeps that count, so the slack is shared
        by all gaps instead of left in the last one.
    max_passes : int
        Refuse plans with more passes than this.

    Returns
    -------
    ndarray
        The levels, first 0 and last 1.

    Raises
    ------
    PlanningError
        If some ``A(s)`` is not positive or the plan needs more than `max_passes`.
    """
    grid = np.asarray(s_grid, dtype=float)
    allowed = np.asarray(allowed_ds, dtype=float)
    if grid.ndim != 1 or grid.size < 2 or allowed.shape != grid.shape:
        raise ValueError(f"pass levels need at least two probe levels and one allowed step "
                         f"per level, got {grid.size} levels and {allowed.size} steps")
    if (allowed <= 0.0).any() or np.isnan(allowed).any():
        i = int(np.argmax(~(allowed > 0.0)))
        raise PlanningError(f"no positive stepover at s={grid[i]:.6g}: the cutter cannot "
                            "keep the scallop there")
    allowed = np.minimum(allowed, 1.0)

    # conservative between probes: the smaller of the two neighbouring values (a probe
    # row that is singular, e.g. a flat face lying exactly flat, must not inflate its
    # neighbours' intervals)
    lower = np.minimum(allowed[:-1], allowed[1:])

    levels_buffer = np.empty(max(max_passes, 2))

    def greedy(scale: float) -> int:
        """The walk at ``scale`` into ``levels_buffer``; how many levels."""
        levels = levels_buffer
        count = _greedy(grid, allowed, lower, scale, lookahead, levels)
        if count < 0:
            s, ds = levels[-1], levels[-1] - levels[-2]
            raise PlanningError(
                f"the scallop request needs more than max_passes={max_passes} passes "
                f"(step {ds:.3g} in s near s={s:.4g}); raise scallop_mm or max_passes")
        return count

    count = greedy(1.0)
    if balance and count > 2:
        # the count is rounded up: spread the slack over every gap by the smallest uniform
        # scale that still needs no more passes
        lo, hi = 0.5, 1.0
        for _ in range(20):  # scale to 5e-7
            mid = 0.5 * (lo + hi)
            if greedy(mid) <= count:
                hi = mid
            else:
                lo = mid
        count = greedy(hi)
    return levels_buffer[:count].copy()
