"""The lowest entry of flat and bull-nose pieces along each dexel, walked in compiled code.

The same search as the candidate pairs of :class:`~verification.grid.PieceGrid` measured by
:class:`~verification.dexels.SweepIndex` (the exact path, kept as the oracle of the
tests), without storing a pair. Expanded as numpy pairs, every candidate's bound is stored
and the pairs it cannot rule out are measured in numpy: on a 5-axis program, whose pieces
are short (cut where the axis turns), that is tens of millions of pairs and minutes of a
verification. Here each dexel walks its candidates (every piece whose midpoint lies within
the search radius of its centre, over the cells of
:func:`~verification.capsule_search.candidate_slots`, listed once) twice:

1. the piece whose cheap lower bound on the entry (:func:`~verification.torus.sweep_bound`:
   a bounding capsule cut by a slab) is lowest, measured exactly
   (:func:`~verification.torus.sweep_interval`): usually the piece that leaves the least;
2. every other piece whose bound lies below the best value found so far, measured.

The value of a pair is the one of :mod:`verification.dexels`: ``lam_in`` when the sweep
reaches the design point (``lam_out > 0``), ``max(lam_in, -lam_out)`` when it comes from
behind (``a . d < BEHIND_COSINE`` and ``lam_in < 0``), else nothing
(:func:`~verification.capsule_search.pair_value`). Of equal values the
one measured first is kept: the piece of lowest bound (of equal bounds the first in the
grid's order), then the others in the grid's order.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from .capsule_search import WALK_BLOCK, candidate_slots, enters_before, pair_value, walk_shape
from .grid import PieceGrid
from .torus import sweep_bound, sweep_interval

__all__ = ["lowest_sweep_entries"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@numba.njit(cache=True)
def _value(p: FloatArray, d: FloatArray, c0: FloatArray, chord: FloatArray,
           axis: FloatArray, height: float, core_radius: float, corner_radius: float,
           behind_cosine: float) -> tuple[float, bool]:
    """Material one piece leaves on one dexel (``inf``: none), and whether from behind."""
    cosine = d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2]
    lam_in, lam_out = sweep_interval(p, d, c0, chord, axis, height, core_radius,
                                     corner_radius, cosine < behind_cosine)
    return pair_value(lam_in, lam_out, cosine, behind_cosine)


@numba.njit(cache=True, parallel=True)
def _walk(points: FloatArray, dirs: FloatArray, centres: FloatArray, lim2: FloatArray,
          spans: IntArray, dims: IntArray, origin: FloatArray, cell: float,
          starts: IntArray, order: IntArray, mid: FloatArray, half: FloatArray, a: FloatArray,
          e: FloatArray, axis: FloatArray, height: FloatArray, core_radius: float,
          corner_radius: float, behind_cosine: float, lam: FloatArray, piece: IntArray,
          behind: NDArray[np.bool_], pairs: IntArray) -> None:
    # every piece's cutter lies within this plus its half length of its midpoint (the
    # bound of :func:`~verification.torus.sweep_bound` about the core's mid-height path,
    # which stands L / 2 above the midpoint)
    top = 0.5 * height.max()
    outer = math.sqrt(core_radius * core_radius + top * top) + corner_radius + top
    n_q = points.shape[0]
    for b in numba.prange((n_q + WALK_BLOCK - 1) // WALK_BLOCK):
        buf = np.empty(WALK_BLOCK, dtype=np.int64)
        bounds = np.empty(WALK_BLOCK)
        for q in range(b * WALK_BLOCK, min(n_q, (b + 1) * WALK_BLOCK)):
            p, d = points[q], dirs[q]
            cx, cy, cz = centres[q, 0], centres[q, 1], centres[q, 2]
            buf, n = candidate_slots(cx, cy, cz, lim2[q], spans[q], dims, origin, cell,
                                     starts, mid, buf)
            if bounds.shape[0] < buf.shape[0]:
                bounds = np.empty(buf.shape[0])
            best = lam[q]
            best_slot = -1
            best_behind = False
            # walk 0: every candidate's bound (NaN where the bounding ball already puts
            # it no lower than the lowest so far), the piece of lowest bound measured
            lowest, lowest_slot = best, -1
            for c in range(n):
                slot = buf[c]
                bounds[c] = np.nan
                if not enters_before(slot, mid, half, p[0], p[1], p[2], d[0], d[1], d[2],
                                     outer, lowest):
                    continue
                lo, _ = sweep_bound(p, d, a[slot], e[slot], axis[slot], height[slot],
                                    core_radius, corner_radius)
                bounds[c] = lo
                if lo < lowest:
                    lowest, lowest_slot = lo, slot
            if lowest_slot >= 0:
                value, back = _value(p, d, a[lowest_slot], e[lowest_slot], axis[lowest_slot],
                                     height[lowest_slot], core_radius, corner_radius,
                                     behind_cosine)
                if value < best:
                    best, best_slot, best_behind = value, lowest_slot, back
                # walk 1: the others whose bound lies below the best, in the grid's order
                for c in range(n):
                    slot = buf[c]
                    if slot == lowest_slot:
                        continue
                    lo = bounds[c]
                    if np.isnan(lo):
                        if not enters_before(slot, mid, half, p[0], p[1], p[2], d[0], d[1],
                                             d[2], outer, best):
                            continue
                        lo, _ = sweep_bound(p, d, a[slot], e[slot], axis[slot], height[slot],
                                            core_radius, corner_radius)
                    if not lo < best:
                        continue
                    value, back = _value(p, d, a[slot], e[slot], axis[slot], height[slot],
                                         core_radius, corner_radius, behind_cosine)
                    if value < best:
                        best, best_slot, best_behind = value, slot, back
            lam[q] = best
            piece[q] = order[best_slot] if best_slot >= 0 else -1
            behind[q] = best_behind
            pairs[q] = n


def lowest_sweep_entries(grid: PieceGrid, span: IntArray, points: FloatArray,
                         dirs: FloatArray, centres: FloatArray, reach_mm: FloatArray,
                         sorted_mid: FloatArray, sorted_half_mm: FloatArray,
                         a: FloatArray, e: FloatArray, axis: FloatArray, height_mm: FloatArray,
                         *, core_radius_mm: float, corner_radius_mm: float,
                         behind_cosine: float,
                         below_mm: FloatArray | None = None
                         ) -> tuple[FloatArray, IntArray, NDArray[np.bool_], int]:
    """Per dexel the lowest value among flat/bull-nose pieces within ``reach_mm``.

    Parameters
    ----------
    grid : PieceGrid
        The pieces by cell.
    span : ndarray of int64, shape (q,)
        Cells searched on each side of a centre's cell (covers ``reach_mm``).
    points, dirs : ndarray, shape (q, 3)
        Dexel origins (mm) and unit directions.
    centres : ndarray, shape (q, 3)
        Search centres, mm.
    reach_mm : ndarray, shape (q,)
        A piece is a candidate when its midpoint lies within this of the centre, mm.
    sorted_mid, sorted_half_mm : ndarray, shapes (n, 3), (n,)
        The pieces' midpoints and half lengths in the grid's order (``mid[grid.order]``),
        mm.
    a, e, axis, height_mm : ndarray
        The pieces' core bottom centres at their starts, chords, axes and core heights
        (:class:`~verification.pieces.Pieces`), in the grid's order too.
    core_radius_mm, corner_radius_mm : float
        ``rho0 = R - r`` and ``r``, mm.
    behind_cosine : float
        ``a . d`` below which a piece comes from behind.
    below_mm : ndarray, shape (q,), optional
        Seek only values below these, mm (default: all).

    Returns
    -------
    lam : ndarray, shape (q,)
        Lowest value, mm (``inf``: none reached the design point, or none below
        ``below_mm``).
    piece : ndarray of int64
        Its piece (``-1`` where none).
    behind : ndarray of bool
        It came from behind.
    pairs : int
        Candidate pairs met.
    """
    q = points.shape[0]
    lam = np.full(q, np.inf) if below_mm is None else np.array(below_mm, dtype=float)
    piece = np.full(q, -1, dtype=np.int64)
    behind = np.zeros(q, dtype=np.bool_)
    pairs = np.zeros(q, dtype=np.int64)
    if q == 0 or grid.n_pieces == 0:
        return np.full(q, np.inf), piece, behind, 0
    spans, dims = walk_shape(grid, span, q)
    f = np.ascontiguousarray
    with numba.parallel_chunksize(1):  # one WALK_BLOCK of dexels at a time
        _walk(f(points, dtype=float), f(dirs, dtype=float), f(centres, dtype=float),
              f(reach_mm * reach_mm, dtype=float), spans, dims,
              f(grid.origin_mm, dtype=float), float(grid.cell_mm), grid.starts, grid.order,
              f(sorted_mid), f(sorted_half_mm), f(a, dtype=float), f(e, dtype=float),
              f(axis, dtype=float), f(height_mm, dtype=float), float(core_radius_mm),
              float(corner_radius_mm), float(behind_cosine), lam, piece, behind, pairs)
    lam[piece < 0] = np.inf
    return lam, piece, behind, int(pairs.sum())
