"""The flat and bull-nose cusp estimate's compiled parts, row by row.

The estimate (:func:`~.cusp_estimates.torus_cusp_estimates`) seeks the pose of a pass whose
contact lies nearest a seed's: over the pieces within a window of a start piece along the
pass, the piece whose segment ``a + f e`` (``0 <= f <= 1``) comes nearest a target point
(:func:`window_nearest`, without the ``(rows, window, 3)`` arrays of candidates). It meets
two passes' sections where the own side first stands at or above the next's
(:func:`side_crossings`, for :mod:`.torus_profile`: the two polylines walked together,
stopping at the crossing, without sorting them together). Both do the numpy's sums in its
order: the same numbers.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from ..tolerances import TINY

__all__ = ["side_crossings", "window_nearest"]


@numba.njit(cache=True)
def _window_nearest(start, target, a, e, pass_of, window, out):
    """The loop of :func:`window_nearest`, into ``out``."""
    last = pass_of.size - 1
    for i in range(start.size):
        own = pass_of[start[i]]
        best = -1
        best_d = np.inf
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
            if d < best_d:
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
        _window_nearest(np.ascontiguousarray(start, dtype=np.int64),
                        np.ascontiguousarray(target, dtype=float),
                        np.ascontiguousarray(a, dtype=float), np.ascontiguousarray(e, dtype=float),
                        np.ascontiguousarray(pass_of, dtype=np.int64), int(window), out)
    return out


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


@numba.njit(cache=True)
def _side_crossings(x1, y1, x2, y2, out_x, out_y):
    """The loop of :func:`side_crossings`, into ``out_x``, ``out_y``."""
    m, k = x1.shape
    for row in range(m):
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
        _side_crossings(x1, y1, x2, y2, out_x, out_y)
    return out_x, out_y
