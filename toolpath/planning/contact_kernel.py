"""Which of a pass's pieces lies nearest a point, over a window of them (compiled).

The flat and bull-nose cusp estimate seeks the pose of a pass whose contact lies nearest a
seed's (:func:`~.cusp_estimates.torus_cusp_estimates`): over the pieces within a window of
a start piece along the pass, the piece whose segment ``a + f e`` (``0 <= f <= 1``) comes
nearest a target point. :func:`window_nearest` does that row by row in one compiled loop
(the same sums, in the same order, as the numpy it replaces: the same pieces), without
the ``(rows, window, 3)`` arrays of candidates.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from ..tolerances import TINY

__all__ = ["window_nearest"]


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
