"""Compiled entry of rays into the material a flat or bull-nose cutter removes along a piece.

A piece of a feed move places the cutter at ``u in [0, 1]`` with its tip
``p(u) = p0 + u (p1 - p0)`` and its axis ``a(u) = normalize(a0 + u (a1 - a0))`` (a 5-axis
control's tool-centre-point interpolation). The material it removes is the union over
``u`` of the cutter solid (:func:`.cutter_kernel.cutter_distance`). Along a ray
``q + l n`` (``l >= 0``) the entry into the solid at one pose is the first root of the
signed distance ``g(l)``, convex in ``l`` (the solid is convex): sphere tracing (each step
the exact distance, never past the root), then, for rays that only graze it, a ternary
search for the minimum and a bisection for the root. The entry into the union is the
smallest entry over ``u``: :data:`POSES` equally spaced poses, then a golden-section search
between the neighbours of the best one.

Unlike a cross-section of the cutter swept straight along the piece, this holds when the
axis turns fast (a bull-nose rolling round a leading edge tighter than the cutter): there
the cutter's points ahead of and behind the contact never pass under ``q`` at the height
a straight sweep would carry them to.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from .cutter_kernel import cutter_distance

__all__ = ["POSES", "ray_entries"]

#: Poses sampled along a piece before the golden-section search.
POSES = 9
#: Golden-section steps between the best sample's neighbours (to 0.618^14 = 1.2e-3 of it).
GOLDEN_STEPS = 14
#: A ray whose distance to the solid is below this has entered it, mm.
TOUCH_MM = 1e-8
SPHERE_STEPS = 48
TERNARY_STEPS = 60
BISECTION_STEPS = 50


@numba.njit(cache=True, inline="always")
def _distance(q, n, lam, tip, axis, r, big, h):
    return cutter_distance(q[0] + lam * n[0] - tip[0], q[1] + lam * n[1] - tip[1],
                           q[2] + lam * n[2] - tip[2], axis[0], axis[1], axis[2], r, big, h)


@numba.njit(cache=True)
def _entry(q, n, tip, axis, r, big, h, horizon):
    """First ``l`` in ``[0, horizon]`` with ``q + l n`` in the cutter at one pose; inf if none."""
    g = _distance(q, n, 0.0, tip, axis, r, big, h)
    if g <= TOUCH_MM:
        return 0.0
    lam = 0.0
    for _ in range(SPHERE_STEPS):
        lam += g
        if lam > horizon:
            return np.inf
        g = _distance(q, n, lam, tip, axis, r, big, h)
        if g <= TOUCH_MM:
            return lam
    # grazing: the minimum of the convex g on [lam, horizon], then the root before it
    lo, hi = lam, horizon
    for _ in range(TERNARY_STEPS):
        m1 = lo + (hi - lo) / 3.0
        m2 = hi - (hi - lo) / 3.0
        if _distance(q, n, m1, tip, axis, r, big, h) <= _distance(q, n, m2, tip, axis, r,
                                                                    big, h):
            hi = m2
        else:
            lo = m1
    if _distance(q, n, lo, tip, axis, r, big, h) > TOUCH_MM:
        return np.inf
    root_lo, root_hi = lam, lo
    for _ in range(BISECTION_STEPS):
        mid = 0.5 * (root_lo + root_hi)
        if _distance(q, n, mid, tip, axis, r, big, h) <= TOUCH_MM:
            root_hi = mid
        else:
            root_lo = mid
    return root_hi


@numba.njit(cache=True)
def _entry_at(u, q, n, p0, p1, a0, a1, r, big, h, horizon, tip, axis):
    """:func:`_entry` with the piece at ``u`` (``tip``, ``axis``: scratch arrays)."""
    size = 0.0
    for k in range(3):
        tip[k] = p0[k] + u * (p1[k] - p0[k])
        axis[k] = a0[k] + u * (a1[k] - a0[k])
        size += axis[k] * axis[k]
    size = math.sqrt(size)
    for k in range(3):
        axis[k] /= size
    return _entry(q, n, tip, axis, r, big, h, horizon)


#: Pairs per block of the parallel loop (each block its own scratch).
BLOCK = 256


@numba.njit(cache=True, parallel=True)
def _ray_entries(q, n, owner, item, p0, p1, a0, a1, r, big, h, horizon, out):
    for block in numba.prange((owner.size + BLOCK - 1) // BLOCK):
        tip = np.empty(3)
        axis = np.empty(3)
        values = np.empty(POSES)
        for k in range(block * BLOCK, min((block + 1) * BLOCK, owner.size)):
            out[k] = _pair_entry(q, n, owner[k], item[k], p0, p1, a0, a1, r, big, h,
                                 horizon, tip, axis, values)


@numba.njit(cache=True)
def _pair_entry(q, n, i, j, p0, p1, a0, a1, r, big, h, horizon, tip, axis, values):
    """The entry of ray ``i`` into piece ``j`` (the last three: scratch arrays)."""
    inv_phi = (math.sqrt(5.0) - 1.0) / 2.0
    best = 0
    for m in range(POSES):
        values[m] = _entry_at(m / (POSES - 1), q[i], n[i], p0[j], p1[j], a0[j], a1[j],
                              r, big, h, horizon, tip, axis)
        if values[m] < values[best]:
            best = m
    found = values[best]
    if found > 0.0 and found < np.inf:
        lo = max(best - 1, 0) / (POSES - 1)
        hi = min(best + 1, POSES - 1) / (POSES - 1)
        x1 = hi - inv_phi * (hi - lo)
        x2 = lo + inv_phi * (hi - lo)
        f1 = _entry_at(x1, q[i], n[i], p0[j], p1[j], a0[j], a1[j], r, big, h, horizon,
                       tip, axis)
        f2 = _entry_at(x2, q[i], n[i], p0[j], p1[j], a0[j], a1[j], r, big, h, horizon,
                       tip, axis)
        for _ in range(GOLDEN_STEPS):
            if f1 <= f2:
                hi, x2, f2 = x2, x1, f1
                x1 = hi - inv_phi * (hi - lo)
                f1 = _entry_at(x1, q[i], n[i], p0[j], p1[j], a0[j], a1[j], r, big, h,
                               horizon, tip, axis)
            else:
                lo, x1, f1 = x1, x2, f2
                x2 = lo + inv_phi * (hi - lo)
                f2 = _entry_at(x2, q[i], n[i], p0[j], p1[j], a0[j], a1[j], r, big, h,
                               horizon, tip, axis)
        found = min(found, f1, f2)
    return found


def ray_entries(q: NDArray[np.float64], n: NDArray[np.float64], owner: NDArray[np.int64],
                item: NDArray[np.int64], tips0: NDArray[np.float64], tips1: NDArray[np.float64],
                axes0: NDArray[np.float64], axes1: NDArray[np.float64], *,
                corner_radius_mm: float, radius_mm: float, flute_length_mm: float,
                horizon_mm: float) -> NDArray[np.float64]:
    """Entry distance of ray ``owner[k]`` into the material removed by piece ``item[k]``.

    Parameters
    ----------
    q, n : ndarray, shape (m, 3)
        Ray origins (mm) and unit directions.
    owner, item : ndarray of int, shape (k,)
        The pairs: a ray and a piece.
    tips0, tips1, axes0, axes1 : ndarray, shape (p, 3)
        The pieces: tips (mm) and unit axes at their ends.
    corner_radius_mm, radius_mm, flute_length_mm : float
        The cutter.
    horizon_mm : float
        Entries farther than this are ``inf``.

    Returns
    -------
    ndarray, shape (k,)
        ``l >= 0`` (0: ``q`` itself inside the cutter), mm; ``inf`` when the ray does not
        enter within the horizon.
    """
    out = np.empty(owner.size)
    if owner.size:
        def c(a: NDArray) -> NDArray:
            return np.ascontiguousarray(a, dtype=float)
        _ray_entries(c(q), c(n), np.ascontiguousarray(owner, dtype=np.int64),
                     np.ascontiguousarray(item, dtype=np.int64), c(tips0), c(tips1), c(axes0),
                     c(axes1), float(corner_radius_mm), float(radius_mm),
                     float(flute_length_mm), float(horizon_mm), out)
    return out
