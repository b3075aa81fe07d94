"""Compiled queries of the material a toolpath's feed moves remove (the measurement).

**Flat and bull-nose.** A piece of a feed move places the cutter at ``u in [0, 1]`` with
its tip ``p(u) = p0 + u (p1 - p0)`` and its axis ``a(u) = normalize(a0 + u (a1 - a0))``
(a 5-axis control's tool-centre-point interpolation). The material it removes is the
union over ``u`` of the cutter solid (:func:`.cutter_kernel.cutter_distance`). Along a ray
``q + l n`` (``l >= 0``) the entry into the solid at one pose is the first root of the
signed distance ``g(l)``, convex in ``l`` (the solid is convex): from ``l = 0`` steps of
the larger of ``g`` (sphere tracing) and the secant through the last two values (below the
convex ``g`` ahead), neither passing the root; a step on which ``g`` stops falling has
passed the closest approach of a ray that misses. Rays that converge slowly anyway get a
ternary search for the minimum and a bisection for the root. The entry into the union is the
smallest entry over ``u``: :data:`POSES` equally spaced poses, then a golden-section search
between the neighbours of the best one.

Unlike a cross-section of the cutter swept straight along the piece, this holds when the
axis turns fast (a bull-nose rolling round a leading edge tighter than the cutter): there
the cutter's points ahead of and behind the contact never pass under ``q`` at the height
a straight sweep would carry them to.

**Ball.** A piece sweeps the ball's centre along a segment: the removed material is a
capsule, and the ray's entry is the first non-negative root among the cylinder's side
(foot inside the segment) and the two end spheres (:func:`capsule_entries`).

Each ray comes with its pieces (``item[lo:hi]``, :func:`ray_ranges`); rays are computed in
parallel and keep only their first entry. :func:`nearest_entries` tries first the piece
whose start pose stands nearest the ray's origin (with a stop above 0, every piece nearest
first), and skips those it cannot enter before the best entry so far ``L``: the ones whose
tip plane it meets after ``L``, or leaves behind
before it starts (:func:`_tip_plane_bound`), and the ones whose tip segment stays farther
from the ray's segment than the part of the cutter within ``L`` of the tip plane reaches
(:func:`_tip_reach`), and the ones whose end poses stand farther from the ray's origin than
``L`` and how far a pose within the piece of its start, then within half the piece of an
end, moves the cutter past the ray's points (:func:`_end_floor`, :func:`_pose_floor`).
Within a piece (:func:`_pair_entry`): where the ray's origin
stands farther from every sampled pose than ``L`` and how far the poses within half a
sample's spacing move the cutter past the ray's points (:func:`_pose_shift`), no entry is
sought; a sampled pose entered within the ray's stop ends the piece; a piece entered no
earlier than ``L`` at its samples gets no golden-section search where no pose it would try
can hold a point of the ray before ``L``; a sampled pose, or a pose the search tries, whose
distance from the ray's origin already says its entry cannot be kept (not below the best
sample's; on the losing side of the search's next comparison, :func:`_entry_unless`) gets
no entry sought, its distance standing in. All are lower bounds of the exact entry: skipped
pieces and searches could not have lowered the result, which stays the same (with a stop
above 0, the ray's entry is one within the stop, not the lowest).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from ..tolerances import LENGTH_SLACK_MM, ROUND_OFF, TINY
from .clearance_kernel import Cutter
from .cutter_kernel import cutter_distance

__all__ = ["POSES", "Motions", "Poses", "RayPieces", "Rays", "Segments", "capsule_entries",
           "centre_pieces", "nearest_entries", "piece_ends", "piece_motions", "ray_ranges",
           "segment_distances", "tip_plane_floors"]

#: Poses sampled along a piece before the golden-section search.
POSES = 9
#: Golden-section steps between the best sample's neighbours (to 0.618^14 = 1.2e-3 of it).
GOLDEN_STEPS = 14
#: A ray whose distance to the solid is below this has entered it, mm.
TOUCH_MM = 1e-8
SPHERE_STEPS = 48
TERNARY_STEPS = 60
BISECTION_STEPS = 50


class Rays(NamedTuple):
    """Rays ``q + l n`` (``l >= 0``): origins ``q`` (mm) and unit directions ``n``, (m, 3)."""

    q: NDArray[np.float64]
    n: NDArray[np.float64]


class RayPieces(NamedTuple):
    """Ray ``i`` meets the pieces ``item[lo[i]:hi[i]]`` (:func:`ray_ranges`)."""

    lo: NDArray[np.int64]
    hi: NDArray[np.int64]
    item: NDArray[np.int64]


class Poses(NamedTuple):
    """Pieces of feed moves: the cutter's tips (mm) and unit axes at their ends, (p, 3)."""

    tip0: NDArray[np.float64]
    tip1: NDArray[np.float64]
    axis0: NDArray[np.float64]
    axis1: NDArray[np.float64]


class Motions(NamedTuple):
    """How fast pieces' poses move, and how far their tip planes may bow, (p,) each.

    The tip's travel (mm) and the axis's turn rate (rad) per unit of ``u``
    (:func:`_piece_motion`), and the slack of the tip-plane bound (mm,
    :func:`_tip_plane_bound`).
    """

    travel: NDArray[np.float64]
    turn_rate: NDArray[np.float64]
    slack: NDArray[np.float64]


class Segments(NamedTuple):
    """Segments from ``a`` to ``b`` (mm), (p, 3)."""

    a: NDArray[np.float64]
    b: NDArray[np.float64]


def _floats(a: NDArray) -> NDArray[np.float64]:
    return np.ascontiguousarray(a, dtype=float)


def _ints(a: NDArray) -> NDArray[np.int64]:
    return np.ascontiguousarray(a, dtype=np.int64)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _distance(q, n, lam, tip, axis, cutter):
    """Signed distance (mm) of the ray's point ``q + lam n`` to the cutter at one pose.

    (Compiled once, not inlined by numba: numba compiled an inlined copy at each of the
    six call sites of :func:`_entry`, seconds on a cold start.)
    """
    return cutter_distance(q[0] + lam * n[0] - tip[0], q[1] + lam * n[1] - tip[1],
                           q[2] + lam * n[2] - tip[2], axis[0], axis[1], axis[2],
                           cutter.corner, cutter.radius, cutter.flute)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _entry(q, n, tip, axis, cutter, horizon):
    """First ``l`` in ``[0, horizon]`` with ``q + l n`` in the cutter at one pose; inf if none.

    ``cutter``: :class:`~.clearance_kernel.Cutter`.
    """
    return _entry_from(q, n, tip, axis, cutter, horizon, _distance(q, n, 0.0, tip, axis, cutter))


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _entry_from(q, n, tip, axis, cutter, horizon, g):
    """:func:`_entry` given ``g``, the distance of the ray's origin to the cutter there."""
    if g <= TOUCH_MM:
        return 0.0
    lam = 0.0
    step = g
    for _ in range(SPHERE_STEPS):
        lam += step
        if lam > horizon:
            return np.inf
        before, g = g, _distance(q, n, lam, tip, axis, cutter)
        if g <= TOUCH_MM:
            return lam
        if g >= before:
            # no root behind (no step passes one) and, g being convex, none ahead: the
            # ray passes the cutter by
            return np.inf
        # the sphere step, or the secant's (below the convex g ahead: short of the root)
        step = max(g, g * step / (before - g))
    # grazing: the minimum of the convex g on [lam, horizon], then the root before it
    lo, hi = lam, horizon
    for _ in range(TERNARY_STEPS):
        m1 = lo + (hi - lo) / 3.0
        m2 = hi - (hi - lo) / 3.0
        if _distance(q, n, m1, tip, axis, cutter) <= _distance(q, n, m2, tip, axis, cutter):
            hi = m2
        else:
            lo = m1
    if _distance(q, n, lo, tip, axis, cutter) > TOUCH_MM:
        return np.inf
    root_lo, root_hi = lam, lo
    for _ in range(BISECTION_STEPS):
        mid = 0.5 * (root_lo + root_hi)
        if _distance(q, n, mid, tip, axis, cutter) <= TOUCH_MM:
            root_hi = mid
        else:
            root_lo = mid
    return root_hi


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _pose_at(u, poses, j, tip, axis):
    """Piece ``j`` of ``poses`` at ``u``: its tip and unit axis into ``tip``, ``axis``."""
    tip0, tip1, axis0, axis1 = poses
    size = 0.0
    for k in range(3):
        tip[k] = tip0[j, k] + u * (tip1[j, k] - tip0[j, k])
        axis[k] = axis0[j, k] + u * (axis1[j, k] - axis0[j, k])
        size += axis[k] * axis[k]
    size = math.sqrt(size)
    for k in range(3):
        axis[k] /= size


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _entry_at(u, q, n, poses, j, cutter, horizon, tip, axis):
    """:func:`_entry` with piece ``j`` of ``poses`` at ``u`` (``tip``, ``axis``: scratch)."""
    _pose_at(u, poses, j, tip, axis)
    return _entry(q, n, tip, axis, cutter, horizon)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _entry_unless(u, other, at_least, q, n, poses, j, cutter, horizon, tip, axis):
    """:func:`_entry_at`, or a lower bound of it where that decides its comparison.

    The golden-section search (:func:`_pair_entry`) next compares a new value ``f`` with
    ``other`` (``f <= other`` for the search's left value, ``other <= f`` for its right)
    and keeps only the smaller. The entry is at least ``g - TOUCH_MM`` (``g`` the ray
    origin's distance to the cutter at that pose; the distance is 1-Lipschitz along the
    ray): where that bound already stands above ``other`` (``at_least``: at or above),
    the comparison, the value kept and the final minimum are the same with the bound in
    place of the entry, and the entry's steps are saved.
    """
    _pose_at(u, poses, j, tip, axis)
    g = _distance(q, n, 0.0, tip, axis, cutter)
    low = g - TOUCH_MM
    if low > other or (at_least and low >= other):
        return low
    return _entry_from(q, n, tip, axis, cutter, horizon, g)


#: Axes turning by more than this across a piece (rad) get no pose bound
#: (:func:`_piece_motion`): its turn rate grows without bound as the turn nears pi.
LARGEST_BOUNDED_TURN = 0.98 * math.pi


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _piece_motion(tip0, tip1, axis0, axis1):
    """How fast piece's poses move: the tip's travel (mm) and the axis's turn rate (rad).

    Both per unit of ``u``. The tip moves linearly, ``|p1 - p0|``; the axis
    ``normalize(a0 + u (a1 - a0))`` runs along the great circle from ``a0`` to ``a1`` (the
    angle ``T`` apart) at ``d phi / du = sin T / |a0 + u (a1 - a0)|^2``, at most
    ``sin T / cos^2(T / 2) = 2 tan(T / 2)`` (the norm is least at ``u = 1/2``); ``inf``
    beyond :data:`LARGEST_BOUNDED_TURN`.
    """
    travel = math.sqrt((tip1[0] - tip0[0]) ** 2 + (tip1[1] - tip0[1]) ** 2
                       + (tip1[2] - tip0[2]) ** 2)
    chord = math.sqrt((axis1[0] - axis0[0]) ** 2 + (axis1[1] - axis0[1]) ** 2
                      + (axis1[2] - axis0[2]) ** 2)
    half_turn = math.asin(min(0.5 * chord, 1.0))
    if 2.0 * half_turn > LARGEST_BOUNDED_TURN:
        return travel, np.inf
    return travel, 2.0 * math.tan(half_turn) * (1.0 + ROUND_OFF)


@numba.njit(cache=True)
def _piece_motions(tip0, tip1, axis0, axis1, big, travel, turn_rate, slack):
    """:func:`_piece_motion` of every piece, and its tip-plane slack (:func:`_tip_plane_bound`).

    Into ``travel``, ``turn_rate`` and ``slack``: ``(TURN_SLACK_RADII R + TURN_SLACK_PER_MM
    |p1 - p0|) |a1 - a0|``.
    """
    for j in range(len(tip0)):
        travel[j], turn_rate[j] = _piece_motion(tip0[j], tip1[j], axis0[j], axis1[j])
        turn = math.sqrt((axis1[j, 0] - axis0[j, 0]) ** 2 + (axis1[j, 1] - axis0[j, 1]) ** 2
                         + (axis1[j, 2] - axis0[j, 2]) ** 2)
        slack[j] = (TURN_SLACK_RADII * big + TURN_SLACK_PER_MM * travel[j]) * turn


def piece_motions(tips0: NDArray[np.float64], tips1: NDArray[np.float64],
                  axes0: NDArray[np.float64], axes1: NDArray[np.float64], radius_mm: float
                  ) -> Motions:
    """How fast each piece's poses move and how far its tip plane may bow (:class:`Motions`).

    Worked out once per toolpath (:class:`~.cut_volume.CutVolume`), not per ray: every ray
    meeting a piece reads them.
    """
    m = len(tips0)
    out = Motions(np.empty(m), np.empty(m), np.empty(m))
    if m:
        _piece_motions(_floats(tips0), _floats(tips1), _floats(axes0), _floats(axes1),
                       float(radius_mm), *out)
    return out


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _pose_shift(travel, turn_rate, du, arm):
    """How far a piece's cutter moves past a point over ``du`` of ``u``, at most, mm.

    From the pose at ``u`` to one at ``v`` (``|v - u| <= du``) the cutter turns about its
    tip by at most ``theta = turn_rate du`` (:func:`_piece_motion`; its axial symmetry
    leaves no other turn) and the tip moves by ``d = travel du``: seen from the cutter, a
    point ``arm`` from the tip at ``u`` moves by at most ``d + theta (arm + d)`` (a turn by
    ``theta`` moves a point ``rho`` from its centre by ``2 rho sin(theta / 2)``), and its
    distance to the cutter (1-Lipschitz outside it) changes by no more
    (plus :data:`~toolpath.tolerances.LENGTH_SLACK_MM` for round-off).
    """
    shift = du * travel
    return shift + du * turn_rate * (arm + shift) + LENGTH_SLACK_MM


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _pair_entry(q, n, poses, j, travel, turn_rate, cutter, horizon, below, stop, tip, axis,
                values):
    """The entry of the ray ``q + l n`` into piece ``j`` (the last three: scratch arrays).

    ``travel``, ``turn_rate``: the piece's :func:`_piece_motion`.

    A sampled pose's entry within ``stop`` is returned at once (the ray stops there,
    :func:`_nearest_entries`: with ``stop`` 0 it is the piece's entry, 0; with the
    horizon, an entry within it, all the ray is asked).

    Where the samples' best entry lies beyond ``below`` (the ray's best entry so far), the
    golden-section search is skipped if it cannot find an entry up to ``below``: the ray's
    distance ``g_b`` to the cutter at the best sample's pose is convex and positive up to
    that pose's entry, so non-increasing, at least ``g_b(below)`` before ``below``; the
    poses the search tries lie within one sample's spacing of that pose, moving the cutter
    past the ray's points by at most :func:`_pose_shift`: where ``g_b(below)`` exceeds that
    (and :data:`TOUCH_MM`), none of them holds a point of the ray up to ``below`` (the
    result, the smallest entry over the ray's pieces, stays the same).

    Before any entry is sought, the distances ``g_k`` of the ray's origin to the cutter
    at the sampled poses: every pose of the piece lies within half a sample's spacing of
    one, moving the cutter past the ray's points (``arm_k + below`` from that pose's tip
    at most) by at most :func:`_pose_shift`, and a point ``l`` up the ray stands at least
    ``g_k - l`` from that pose (1-Lipschitz). Where ``min_k (g_k - shift_k) - below``
    exceeds :data:`TOUCH_MM`, the ray enters no pose up to ``below``: ``inf`` (the ray's
    smallest entry stays the same), without the entries (on the standing dev blade,
    bull:8:1, 63 % of the pieces tried).

    A sample whose distance less :data:`TOUCH_MM` is at or above the best sample's entry
    so far gets no entry (it is at least that: never the best, nor the first within
    ``stop``), nor does a pose of the golden-section search whose bound already loses its
    next comparison (:func:`_entry_unless`): the same result, the entries' steps saved
    (the ray cast of every seed 9 % less CPU on the standing dev blade, bull:8:1, 20 %
    flat:8).
    """
    inv_phi = (math.sqrt(5.0) - 1.0) / 2.0
    # the samples' distances from the ray's origin first: every pose lies within half a
    # sample's spacing of one of them
    floor = np.inf
    for m in range(POSES):
        _pose_at(m / (POSES - 1), poses, j, tip, axis)
        values[m] = _distance(q, n, 0.0, tip, axis, cutter)
        arm = math.sqrt((q[0] - tip[0]) ** 2 + (q[1] - tip[1]) ** 2 + (q[2] - tip[2]) ** 2)
        floor = min(floor, values[m] - _pose_shift(travel, turn_rate, 0.5 / (POSES - 1),
                                                   arm + below))
    if floor - below > TOUCH_MM:
        return np.inf
    best = 0
    for m in range(POSES):
        if m > best and values[m] - TOUCH_MM >= values[best]:
            # its entry, at least its distance less TOUCH_MM, cannot beat the best one
            values[m] = np.inf
            continue
        _pose_at(m / (POSES - 1), poses, j, tip, axis)
        values[m] = _entry_from(q, n, tip, axis, cutter, horizon, values[m])
        if values[m] <= stop:
            return values[m]
        if values[m] < values[best]:
            best = m
    found = values[best]
    if below < found < np.inf:
        _pose_at(best / (POSES - 1), poses, j, tip, axis)
        arm = math.sqrt((q[0] - tip[0]) ** 2 + (q[1] - tip[1]) ** 2 + (q[2] - tip[2]) ** 2)
        shift = _pose_shift(travel, turn_rate, 1.0 / (POSES - 1), arm + below)
        if _distance(q, n, below, tip, axis, cutter) > shift + TOUCH_MM:
            return found
    if found > 0.0 and found < np.inf:
        lo = max(best - 1, 0) / (POSES - 1)
        hi = min(best + 1, POSES - 1) / (POSES - 1)
        x1 = hi - inv_phi * (hi - lo)
        x2 = lo + inv_phi * (hi - lo)
        f1 = _entry_at(x1, q, n, poses, j, cutter, horizon, tip, axis)
        # f2 is next compared as f1 <= f2: only where f1 <= f2 cannot be told without it
        f2 = _entry_unless(x2, f1, True, q, n, poses, j, cutter, horizon, tip, axis)
        for _ in range(GOLDEN_STEPS):
            if f1 <= f2:
                hi, x2, f2 = x2, x1, f1
                x1 = hi - inv_phi * (hi - lo)
                f1 = _entry_unless(x1, f2, False, q, n, poses, j, cutter, horizon, tip,
                                   axis)
            else:
                lo, x1, f1 = x1, x2, f2
                x2 = lo + inv_phi * (hi - lo)
                f2 = _entry_unless(x2, f1, True, q, n, poses, j, cutter, horizon, tip,
                                   axis)
        found = min(found, f1, f2)
    return found


#: Rays climbing (or falling) less steeply than this towards the spindle (``|n . axis|``,
#: the cosine of the angle to the axis, below 0.1: within 6 deg of the tip's plane) get
#: no tip-plane bound: the plane is met ``1 / rise`` times as far along the ray as the tip
#: moves off it, so a turning axis moves the bound by up to ``2 R / rise`` per unit of
#: change, which :data:`TURN_SLACK_RADII` covers only down to this rise.
LEAST_RISE = 0.1
#: Slack of the tip-plane bound per unit of axis change across a piece, in cutter radii
#: (a turning axis moves the cutting end by at most 2 R times the change; over a rise of
#: at least :data:`LEAST_RISE`, 10 times that).
TURN_SLACK_RADII = 20.0
#: Slack of the tip-plane bound per unit of axis change and mm of tip travel across a
#: piece: with both the tip and the axis moving, the tip plane's offset along the ray is
#: quadratic in the pose, off the line through its ends by up to a quarter of the tip's
#: travel times the axis change, met ``1 / rise`` as far along the ray (``1 / (4 *
#: LEAST_RISE)``): long turning pieces.
TURN_SLACK_PER_MM = 0.25 / LEAST_RISE


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _tip_plane_bound(q, n, p0, p1, a0, a1, slack):
    """A lower bound of the ray's entry into the piece: where it meets the tip's plane.

    The cutter lies on the spindle side of the plane through its tip perpendicular to its
    axis; along the ray ``q + l n`` that plane is at ``l = (tip - q).a / (n.a)``, linear in
    the tip along a piece with a fixed axis, so the smaller of the two ends bounds the
    piece; a turning axis moves it by at most :data:`TURN_SLACK_RADII` ``R`` plus
    :data:`TURN_SLACK_PER_MM` times the tip's travel, times the axis change (``slack``,
    :func:`piece_motions`). A ray falling
    away from the spindle by more than :data:`LEAST_RISE` at both ends is on the spindle
    side only up to that ``l``: where even the larger, with the slack, lies behind its
    origin it never enters (``inf``). Other rays get no bound (``-inf``).
    """
    bound = np.inf
    latest = -np.inf
    climbs = 0
    for end in range(2):
        tip, axis = (p0, a0) if end == 0 else (p1, a1)
        rise = n[0] * axis[0] + n[1] * axis[1] + n[2] * axis[2]
        if rise > LEAST_RISE:
            climbs += 1
        elif rise < -LEAST_RISE:
            climbs -= 1
        else:
            return -np.inf
        at = ((tip[0] - q[0]) * axis[0] + (tip[1] - q[1]) * axis[1]
              + (tip[2] - q[2]) * axis[2]) / rise
        bound = min(bound, at)
        latest = max(latest, at)
    if climbs == 2:
        return bound - slack
    if climbs == -2 and latest + slack < -TOUCH_MM / LEAST_RISE:
        return np.inf
    return -np.inf


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _tip_reach(cutter, height):
    """How far from its tip the cutter's points up to ``height`` above the tip plane lie, mm.

    A point ``h`` above the tip plane (``0 <= h <= height``) lies within the profile's
    radius of the axis, ``R - r + sqrt(r^2 - (r - h)^2)`` below the corner's top
    (``h < r``), ``R`` above it; both grow with ``h``, so the point is within
    ``sqrt(height^2 + radius(height)^2)`` of the tip (plus :data:`TOUCH_MM`, how far
    outside an entry may be found).
    """
    r = cutter.corner
    if height >= r:
        radius = cutter.radius
    else:
        radius = cutter.radius - r + math.sqrt(max(r * r - (r - height) ** 2, 0.0))
    return math.sqrt(height * height + radius * radius) + TOUCH_MM


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _end_floor(q, near, tip, travel, turn_rate, du, horizon):
    """A lower bound of the ray's distance to the cutter at poses within ``du`` of an end.

    Take ``l`` off it for the bound at ``q + l n`` (``l <= horizon``). ``near``: the signed
    distance of the ray's origin ``q`` to the cutter at the end pose of tip ``tip``; seen
    from the cutter there, the ray's point ``q + l n`` (at least ``near - l`` from it, the
    distance being 1-Lipschitz) moves by at most :func:`_pose_shift` over ``du``, ``arm`` at
    most ``|q - tip| + horizon``.
    """
    arm = math.sqrt((q[0] - tip[0]) ** 2 + (q[1] - tip[1]) ** 2 + (q[2] - tip[2]) ** 2)
    return near - _pose_shift(travel, turn_rate, du, arm + horizon)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _pose_floor(q, near0, near1, tip0, tip1, travel, turn_rate, horizon):
    """A lower bound of the ray's distance to the cutter at any pose of a piece, up to ``l``.

    Every pose lies within half the piece of an end (:func:`_end_floor` over ``du = 1/2``,
    ``near0``, ``near1`` at the piece's end poses): the smaller of the two ends' bounds.
    """
    return min(_end_floor(q, near0, tip0, travel, turn_rate, 0.5, horizon),
               _end_floor(q, near1, tip1, travel, turn_rate, 0.5, horizon))


@numba.njit(cache=True, parallel=True)
def _nearest_entries(rays, pieces, poses, motions, cutter, horizon, stop, out):
    """The loop of :func:`nearest_entries`, rays in parallel.

    ``rays`` (:class:`Rays`) meet ``pieces`` (:class:`RayPieces`) of ``poses``
    (:class:`Poses`, moving as :class:`Motions` says) of the ``cutter``
    (:class:`~.clearance_kernel.Cutter`), into ``out``; a ray stops at an entry within
    ``stop``.

    Before the best entry so far ``L`` (or the horizon), the ray's point ``x = q + l n``
    lies at most ``L - b`` above the tip plane of any pose (``b``: the tip-plane bound,
    ``n.a <= 1``), so it can be inside only within :func:`_tip_reach` of ``L - b`` of the
    pose's tip, on the tip segment: a piece whose tip segment stays farther than that from
    the ray's segment up to the horizon is skipped, as one whose tip plane the ray meets
    after ``L``, and one whose poses all stand farther than ``L`` from the ray's origin
    (:func:`_end_floor`, :func:`_pose_floor`). The first two tests hold at ``L`` = the
    horizon already for most of a ray's pieces (the other passes' within a bracket's
    reach): those are set aside before the distances to their end poses are worked out
    (``L`` only falls, :func:`_tip_reach` rises with it).

    With ``stop`` 0 the result is the smallest entry, whatever the order the pieces are
    tried in: the piece whose start pose stands nearest the ray's origin first (its entry
    sets ``L`` low at once), then the others in their order in ``item``, each tried only
    where the floor from its start pose over the whole piece (``du = 1``), then the floor
    from both ends, does not rule it out (the distance to its end pose is worked out only
    then: on a 5-axis flat:6 job on the bundled DCA rotor, a ray met some 1,200 pieces
    past the first tests, and some 70 past the floors). With ``stop`` above 0 (whether a
    ray enters within it, as soon as one sampled pose of a piece says so) the pieces are
    tried nearest first: by the distance of the ray's origin to the cutter at the nearer of
    the piece's end poses, ties in their order in ``item`` (pieces of a move share their
    end poses: the entry returned is the first one found within the stop).
    """
    q, n = rays
    lo_k, hi_k, item = pieces
    tip0, tip1, axis0, axis1 = poses
    travel, turn_rate, slack = motions
    for i in numba.prange(lo_k.size):
        lo, hi = lo_k[i], hi_k[i]
        best = np.inf
        if hi > lo:
            tip = np.empty(3)
            axis = np.empty(3)
            values = np.empty(POSES)
            # the pieces not set aside: their bounds, distances and floors, by position
            bounds = np.empty(hi - lo)
            apart = np.empty(hi - lo)
            nearness = np.empty(hi - lo)
            floors = np.empty(hi - lo)
            kept = np.empty(hi - lo, dtype=np.int64)
            far = np.empty(3)
            for k in range(3):
                far[k] = q[i, k] + horizon * n[i, k]
            count = 0
            for k in range(lo, hi):
                j = item[k]
                bound = _tip_plane_bound(q[i], n[i], tip0[j], tip1[j], axis0[j], axis1[j],
                                         slack[j])
                gap = _segment_distance(q[i], far, tip0[j], tip1[j])
                if bound > horizon or gap > _tip_reach(cutter, horizon - bound):
                    # skipped below whatever the best entry (reach <= horizon): no
                    # distances to its end poses, nor a place in the order
                    continue
                near0 = _distance(q[i], n[i], 0.0, tip0[j], axis0[j], cutter)
                if stop > 0.0:  # (the order by the nearer end: both ends now)
                    near1 = _distance(q[i], n[i], 0.0, tip1[j], axis1[j], cutter)
                    nearness[count] = min(near0, near1)
                    floors[count] = _pose_floor(q[i], near0, near1, tip0[j], tip1[j],
                                                travel[j], turn_rate[j], horizon)
                else:  # (the start pose's floor over the whole piece; the end's later)
                    nearness[count] = near0
                    floors[count] = _end_floor(q[i], near0, tip0[j], travel[j], turn_rate[j],
                                               1.0, horizon)
                bounds[count], apart[count], kept[count] = bound, gap, k
                count += 1
            if stop > 0.0:
                order = np.argsort(nearness[:count], kind="mergesort")
            else:
                order = np.arange(count)
                if count:
                    first = np.argmin(nearness[:count])
                    order[0], order[first] = first, 0
            for m in order:
                reach = min(best, horizon)
                if bounds[m] > reach or apart[m] > _tip_reach(cutter, reach - bounds[m]):
                    continue
                if floors[m] - reach > TOUCH_MM:
                    continue
                j = item[kept[m]]
                if stop <= 0.0:  # the floor from both ends
                    near1 = _distance(q[i], n[i], 0.0, tip1[j], axis1[j], cutter)
                    if _pose_floor(q[i], nearness[m], near1, tip0[j], tip1[j], travel[j],
                                   turn_rate[j], horizon) - reach > TOUCH_MM:
                        continue
                best = min(best, _pair_entry(q[i], n[i], poses, j, travel[j], turn_rate[j],
                                             cutter, horizon, reach, stop, tip, axis, values))
                if best <= stop:
                    break
        out[i] = best


def ray_ranges(owner: NDArray[np.int64], item: NDArray[np.int64], n_rays: int
               ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """Pairs grouped by ray: ``lo, hi`` per ray (its pieces are ``item[lo:hi]``), ``item``."""
    owner = np.asarray(owner, dtype=np.int64)
    if owner.size and not (owner[1:] >= owner[:-1]).all():
        order = np.argsort(owner, kind="stable")
        owner, item = owner[order], np.asarray(item)[order]
    starts = np.searchsorted(owner, np.arange(n_rays + 1)).astype(np.int64)
    return starts[:-1], starts[1:], _ints(item)


def nearest_entries(q: NDArray[np.float64], n: NDArray[np.float64], lo: NDArray[np.int64],
                    hi: NDArray[np.int64], item: NDArray[np.int64], tips0: NDArray[np.float64],
                    tips1: NDArray[np.float64], axes0: NDArray[np.float64],
                    axes1: NDArray[np.float64], *, corner_radius_mm: float, radius_mm: float,
                    flute_length_mm: float, horizon_mm: float, stop_mm: float = 0.0,
                    motions: Motions | None = None) -> NDArray[np.float64]:
    """Each ray's first entry into the material removed by its pieces, mm.

    The nearest piece first (with ``stop_mm`` above 0, every piece nearest first), skipping
    those that cannot be entered before the best entry found (:func:`_nearest_entries`), or up
    to the first entry within ``stop_mm``
    (0: the first entry, exactly; the horizon: whether the ray enters within it, as soon
    as one sampled pose of a piece says so).

    Parameters
    ----------
    q, n : ndarray, shape (m, 3)
        Ray origins (mm) and unit directions.
    lo, hi, item : ndarray of int
        Ray ``i``'s pieces are ``item[lo[i]:hi[i]]`` (:func:`ray_ranges`).
    tips0, tips1, axes0, axes1 : ndarray, shape (p, 3)
        The pieces: tips (mm) and unit axes at their ends.
    corner_radius_mm, radius_mm, flute_length_mm : float
        The cutter.
    horizon_mm : float
        Entries farther than this need not be found.
    motions : Motions, optional
        The pieces' :func:`piece_motions` (None: worked out here).

    Returns
    -------
    ndarray, shape (m,)
        ``l >= 0`` per ray (0: ``q`` itself inside the cutter), mm; ``inf`` when it enters
        none of its pieces within the horizon.
    """
    out = np.full(len(q), np.inf)
    if len(q):
        if motions is None:
            motions = piece_motions(tips0, tips1, axes0, axes1, radius_mm)
        _nearest_entries(Rays(_floats(q), _floats(n)), RayPieces(_ints(lo), _ints(hi), _ints(item)),
                         Poses(_floats(tips0), _floats(tips1), _floats(axes0), _floats(axes1)),
                         Motions(*(_floats(a) for a in motions)),
                         Cutter(float(corner_radius_mm), float(radius_mm), float(flute_length_mm)),
                         float(horizon_mm), float(stop_mm), out)
    return out


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _capsule_entry(q0, q1, q2, n0, n1, n2, a0, a1, a2, b0, b1, b2, r2):
    """Entry of the ray ``q + l n`` into the capsule round ``ab`` (0 inside, inf: misses).

    (The coordinates as scalars: a row of an array passed in costs its loop three times
    the time, the capsule's own arithmetic included.)
    """
    d0, d1, d2 = b0 - a0, b1 - a1, b2 - a2
    m0, m1, m2 = q0 - a0, q1 - a1, q2 - a2
    dd = d0 * d0 + d1 * d1 + d2 * d2
    md = m0 * d0 + m1 * d1 + m2 * d2
    nd = n0 * d0 + n1 * d1 + n2 * d2
    mn = m0 * n0 + m1 * n1 + m2 * n2
    mm = m0 * m0 + m1 * m1 + m2 * m2
    foot = min(max(md / (dd if dd > 0.0 else 1.0), 0.0), 1.0)
    o0, o1, o2 = m0 - foot * d0, m1 - foot * d1, m2 - foot * d2
    if o0 * o0 + o1 * o1 + o2 * o2 <= r2:
        return 0.0
    best = np.inf
    # the cylinder's side, its foot inside the segment
    ka = dd - nd * nd
    kb = dd * mn - nd * md
    kc = dd * (mm - r2) - md * md
    disc = kb * kb - ka * kc
    if ka > ROUND_OFF * max(dd, TINY) and disc >= 0.0:
        lam = (-kb - math.sqrt(disc)) / ka
        y = md + lam * nd
        if lam >= 0.0 and 0.0 <= y <= dd:
            best = lam
    # the two end spheres
    for end in range(2):
        c0, c1, c2 = (m0, m1, m2) if end == 0 else (q0 - b0, q1 - b1, q2 - b2)
        bc = c0 * n0 + c1 * n1 + c2 * n2
        dsc = bc * bc - (c0 * c0 + c1 * c1 + c2 * c2 - r2)
        if dsc >= 0.0:
            lam = -bc - math.sqrt(dsc)
            if lam >= 0.0:
                best = min(best, lam)
    return best


@numba.njit(cache=True)
def _capsule_entries(rays, pieces, segments, r2, stop, out):
    """The loop of :func:`capsule_entries`: :class:`Rays`, :class:`RayPieces`, :class:`Segments`."""
    q, n = rays
    lo, hi, item = pieces
    a, b = segments
    for i in range(lo.size):
        best = np.inf
        q0, q1, q2, n0, n1, n2 = q[i, 0], q[i, 1], q[i, 2], n[i, 0], n[i, 1], n[i, 2]
        for k in range(lo[i], hi[i]):
            j = item[k]
            best = min(best, _capsule_entry(q0, q1, q2, n0, n1, n2, a[j, 0], a[j, 1], a[j, 2],
                                            b[j, 0], b[j, 1], b[j, 2], r2))
            if best <= stop:
                break
        out[i] = best


def capsule_entries(q: NDArray[np.float64], n: NDArray[np.float64], lo: NDArray[np.int64],
                    hi: NDArray[np.int64], item: NDArray[np.int64], a: NDArray[np.float64],
                    b: NDArray[np.float64], radius_mm: float, stop_mm: float = 0.0
                    ) -> NDArray[np.float64]:
    """Each ray's first entry into the capsules round its segments ``item[lo:hi]``, mm.

    A capsule: every point within ``radius_mm`` of the segment from ``a`` to ``b``. 0
    where the ray starts inside one, ``inf`` where it misses them all. A ray stops at
    the first capsule it enters within ``stop_mm`` (0: the first entry, exactly).
    """
    out = np.full(len(q), np.inf)
    if len(q):
        _capsule_entries(Rays(_floats(q), _floats(n)), RayPieces(_ints(lo), _ints(hi), _ints(item)),
                         Segments(_floats(a), _floats(b)), float(radius_mm) ** 2,
                         float(stop_mm), out)
    return out


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _segment_distance(p0, p1, q0, q1):
    """Distance between segments ``p0 p1`` and ``q0 q1`` (clamped closest points)."""
    return _segment_distance_xyz(p0[0], p0[1], p0[2], p1[0], p1[1], p1[2],
                                 q0[0], q0[1], q0[2], q1[0], q1[1], q1[2])


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _segment_distance_xyz(p00, p01, p02, p10, p11, p12, q00, q01, q02, q10, q11, q12):
    """:func:`_segment_distance` of the ends' coordinates.

    (As scalars: rows of arrays passed in cost a loop of them twice the time.)
    """
    d1 = (p10 - p00, p11 - p01, p12 - p02)
    d2 = (q10 - q00, q11 - q01, q12 - q02)
    r = (p00 - q00, p01 - q01, p02 - q02)
    a = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2]
    e = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2]
    f = d2[0] * r[0] + d2[1] * r[1] + d2[2] * r[2]
    c = d1[0] * r[0] + d1[1] * r[1] + d1[2] * r[2]
    b = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2]
    sc = 0.0
    tc = 0.0
    if a <= TINY and e > TINY:  # the first is a point: its foot on the second
        tc = min(max(f / e, 0.0), 1.0)
    elif a > TINY and e <= TINY:  # the second is a point: its foot on the first
        sc = min(max(-c / a, 0.0), 1.0)
    elif a > TINY:
        den = a * e - b * b
        if den > ROUND_OFF * (a * e + TINY):
            sc = min(max((b * f - c * e) / den, 0.0), 1.0)
        tc = (b * sc + f) / e
        if tc < 0.0:
            sc = min(max(-c / a, 0.0), 1.0)
        elif tc > 1.0:
            sc = min(max((b - c) / a, 0.0), 1.0)
        tc = min(max(tc, 0.0), 1.0)
    total = 0.0
    for k in range(3):
        g = r[k] + sc * d1[k] - tc * d2[k]
        total += g * g
    return math.sqrt(total)


@numba.njit(cache=True)
def _segment_distances(first, owner, second, item, out):
    """The loop of :func:`segment_distances` (two :class:`Segments`)."""
    p0, p1 = first
    a, b = second
    for k in range(owner.size):
        i, j = owner[k], item[k]
        out[k] = _segment_distance_xyz(p0[i, 0], p0[i, 1], p0[i, 2], p1[i, 0], p1[i, 1],
                                       p1[i, 2], a[j, 0], a[j, 1], a[j, 2], b[j, 0], b[j, 1],
                                       b[j, 2])


def segment_distances(p0: NDArray[np.float64], p1: NDArray[np.float64],
                      owner: NDArray[np.int64], a: NDArray[np.float64],
                      b: NDArray[np.float64], item: NDArray[np.int64]) -> NDArray[np.float64]:
    """Distance between segment ``owner[k]`` (``p0 p1``) and segment ``item[k]`` (``a b``), mm."""
    out = np.empty(len(owner))
    if out.size:
        _segment_distances(Segments(_floats(p0), _floats(p1)), _ints(owner),
                           Segments(_floats(a), _floats(b)), _ints(item), out)
    return out


@numba.njit(cache=True, parallel=True)
def _tip_plane_floors(centre, radius, owner, item, poses, big, out):
    """The loop of :func:`tip_plane_floors` (``poses``: :class:`Poses`)."""
    p0, p1, a0, a1 = poses
    for k in numba.prange(owner.size):
        c, j = owner[k], item[k]
        depth = np.inf
        for end in range(2):
            tip, axis = (p0[j], a0[j]) if end == 0 else (p1[j], a1[j])
            depth = min(depth, (tip[0] - centre[c, 0]) * axis[0]
                        + (tip[1] - centre[c, 1]) * axis[1] + (tip[2] - centre[c, 2]) * axis[2])
        turn = math.sqrt((a1[j, 0] - a0[j, 0]) ** 2 + (a1[j, 1] - a0[j, 1]) ** 2
                         + (a1[j, 2] - a0[j, 2]) ** 2)
        out[k] = depth - radius[c] - 2.0 * big * turn


def tip_plane_floors(centre: NDArray[np.float64], radius: NDArray[np.float64],
                     owner: NDArray[np.int64], item: NDArray[np.int64],
                     tips0: NDArray[np.float64], tips1: NDArray[np.float64],
                     axes0: NDArray[np.float64], axes1: NDArray[np.float64],
                     radius_mm: float) -> NDArray[np.float64]:
    """Per pair ``k``: how far below piece ``item[k]``'s tip planes ``centre[owner[k]]`` lies.

    ``min over its ends of (tip - c).a``, less ``radius[owner[k]]`` and ``2 R`` times the
    axis change (a turning axis moves the cutting end by at most that).
    """
    out = np.empty(len(owner))
    if out.size:
        _tip_plane_floors(_floats(centre), _floats(radius), _ints(owner), _ints(item),
                          Poses(_floats(tips0), _floats(tips1), _floats(axes0), _floats(axes1)),
                          float(radius_mm), out)
    return out


@numba.njit(cache=True)
def _piece_ends(first, last, inner, counts, out0, out1):
    """The loop of :func:`piece_ends`."""
    piece = 0
    k = 0  # the move's first inner pose
    for m in range(counts.size):
        c = counts[m]
        for j in range(c):
            for col in range(first.shape[1]):
                out0[piece, col] = first[m, col] if j == 0 else inner[k + j - 1, col]
                out1[piece, col] = last[m, col] if j == c - 1 else inner[k + j, col]
            piece += 1
        k += c - 1


def piece_ends(first: NDArray[np.float64], last: NDArray[np.float64],
               inner: NDArray[np.float64], counts: NDArray[np.int64]
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Both ends of every piece of moves cut into ``counts[m]`` pieces each, in order.

    Move ``m`` runs from ``first[m]`` to ``last[m]`` through its ``counts[m] - 1`` inner
    poses, which ``inner`` holds move after move: its piece ``j`` starts at the move's first
    pose (``j = 0``) or inner pose ``j - 1`` and ends at inner pose ``j`` or the move's last.
    Returns the starts and the ends, ``(counts.sum(), d)`` each.
    """
    total = int(counts.sum())
    out0, out1 = np.empty((total, first.shape[1])), np.empty((total, first.shape[1]))
    _piece_ends(_floats(first), _floats(last), _floats(inner), _ints(counts), out0, out1)
    return out0, out1


@numba.njit(cache=True)
def _centre_pieces(tip_a, tip_b, axis_a, axis_b, counts, reach, out0, out1):
    """The loop of :func:`centre_pieces`."""
    piece = 0
    for m in range(counts.size):
        c = counts[m]
        # the move's first pose, then each inner pose once (the end of one piece, the
        # start of the next), then the move's last
        s0 = tip_a[m, 0] + reach * axis_a[m, 0]
        s1 = tip_a[m, 1] + reach * axis_a[m, 1]
        s2 = tip_a[m, 2] + reach * axis_a[m, 2]
        for j in range(c):
            out0[piece, 0], out0[piece, 1], out0[piece, 2] = s0, s1, s2
            if j == c - 1:
                s0 = tip_b[m, 0] + reach * axis_b[m, 0]
                s1 = tip_b[m, 1] + reach * axis_b[m, 1]
                s2 = tip_b[m, 2] + reach * axis_b[m, 2]
            else:
                u = (j + 1) / c
                w = 1.0 - u
                x0 = axis_a[m, 0] * w + axis_b[m, 0] * u
                x1 = axis_a[m, 1] * w + axis_b[m, 1] * u
                x2 = axis_a[m, 2] * w + axis_b[m, 2] * u
                norm = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
                if norm > 0.0:
                    x0, x1, x2 = x0 / norm, x1 / norm, x2 / norm
                s0 = tip_a[m, 0] * w + tip_b[m, 0] * u + reach * x0
                s1 = tip_a[m, 1] * w + tip_b[m, 1] * u + reach * x1
                s2 = tip_a[m, 2] * w + tip_b[m, 2] * u + reach * x2
            out1[piece, 0], out1[piece, 1], out1[piece, 2] = s0, s1, s2
            piece += 1


def centre_pieces(tip_a: NDArray[np.float64], tip_b: NDArray[np.float64],
                  axis_a: NDArray[np.float64], axis_b: NDArray[np.float64],
                  counts: NDArray[np.int64], reach_mm: float
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The pieces of the points ``reach_mm`` up the axis of moves cut in ``counts[m]`` pieces.

    Tip-linear moves ``tip_a -> tip_b`` with normalized-linear axes ``axis_a -> axis_b``
    (:func:`~toolpath.vectors.move_poses`): piece ``j`` of move ``m`` runs from the pose at
    ``u = j / c`` to ``(j + 1) / c`` (``c = counts[m]``), the move's own ends at ``u = 0``
    and 1 (a zero axis between opposite ones stays zero). The same points as
    :func:`piece_ends` over those poses' ``tip + reach_mm axis``, each inner pose placed
    once, without the (n, 3) arrays of the inner poses. Returns the starts and the ends,
    ``(counts.sum(), 3)`` each.
    """
    total = int(counts.sum())
    out0, out1 = np.empty((total, 3)), np.empty((total, 3))
    if total:
        _centre_pieces(_floats(tip_a), _floats(tip_b), _floats(axis_a), _floats(axis_b),
                       _ints(counts), float(reach_mm), out0, out1)
    return out0, out1
