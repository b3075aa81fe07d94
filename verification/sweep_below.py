r"""Which flat or bull-nose pieces, widened, may enter each dexel below a bound.

The fine model (:mod:`verification.fine_model`) replays stretches of the path again to a
fine tolerance; of a flat or bull-nose cutter that is millions of pieces wherever the axis
turns (each piece holds its axis fixed). Most of them cannot decide any value asked: a
dexel's value is the lowest entry, and a stretch whose every piece enters well above
another stretch's entry changes nothing. This module answers, per dexel ``q`` with a bound
``U_q``, which of the whole program's (coarse) pieces ``k`` have

    floor_q(k ⊕ w) < U_q

where ``k ⊕ w`` is the piece's sweep widened by ``w`` (its corner radius ``r + w``, every
point within ``w`` of it) and ``floor`` is the lower bound of
:func:`~verification.piece_runs.floor_entry` (the widened sweep's entry, ``inf`` where it
leaves the dexel at or below the design point). Every solid inside ``k ⊕ w`` leaves at
least that floor on the dexel (:mod:`verification.sweep_search`), so a finely replayed
piece lying within ``w`` of ``k`` and of no piece listed enters at ``U_q`` or above: it
cannot lower a value the listed stretches already bring down to ``U_q``.

The walk is the one of :mod:`verification.sweep_search`, with a fixed bound in place of the
best so far: the runs of consecutive pieces (:mod:`verification.piece_runs`) whose
midpoints lie within reach, each whose widened, dilated reference floors below ``U_q``
(:func:`~verification.piece_runs.run_floor`: and so do the widened pieces' support planes
there) opened by halving (each half's own reference and dilation) down to single pieces, each
listed where its own widened floor lies below ``U_q``.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import NDArray

from toolpath.row_threads import run_in_threads

from .capsule_search import WALK_BLOCK, enters_before, is_candidate, spread_slots, walk_shape
from .grid import PieceGrid
from .piece_runs import PieceRuns, floor_entry, run_floor, span_reference
from .sweep_search import piece_outer_mm
from .torus import sweep_bound

__all__ = ["pieces_entering_below"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Entries of a run's halving stack (as :mod:`verification.sweep_search`).
_STACK = 64


@numba.njit(cache=True, nogil=True)
def _mark(points: FloatArray, dirs: FloatArray, centres: FloatArray, reach: FloatArray,
          below: FloatArray, spans: IntArray, dims: IntArray, origin: FloatArray,
          cell: float, starts: IntArray, run_mid: FloatArray, run_half: FloatArray,
          run_spread: FloatArray, run_start: IntArray, run_stop: IntArray,
          run_c0: FloatArray, run_chord: FloatArray, run_axis: FloatArray,
          run_height: FloatArray, run_dilation: FloatArray, mid: FloatArray,
          half: FloatArray, a: FloatArray, e: FloatArray, axis: FloatArray,
          height: FloatArray, along: FloatArray, turned: FloatArray, block_of: IntArray,
          block_span: IntArray, block_slack: FloatArray, core_radius: float,
          corner_radius: float, widen: float, outer: float, widest: float,
          listed: IntArray, marked: NDArray[np.bool_], row_lo: int, row_hi: int) -> None:
    # dexels row_lo .. row_hi - 1 (a slice of them in each thread, run_in_threads: a
    # piece is marked where any dexel marks it, whichever thread that is); ``outer``:
    # every widened piece lies within this plus its half length of its midpoint
    # (:func:`~verification.sweep_search.piece_outer_mm`, the corner radius widened);
    # ``widest``: the largest run spread (taken outside, as the walk of
    # :mod:`verification.sweep_search` does);
    # ``listed``: per piece, how many before it the caller has listed already (prefix
    # sums, ``n + 1``): a run, half or piece of only such pieces is not walked
    buf = np.empty(WALK_BLOCK, dtype=np.int64)
    lows = np.empty(_STACK, dtype=np.int64)
    highs = np.empty(_STACK, dtype=np.int64)
    chord = np.empty(3)
    for q in range(row_lo, row_hi):
        bound = below[q]
        p, d = points[q], dirs[q]
        cx, cy, cz = centres[q, 0], centres[q, 1], centres[q, 2]
        lim2 = reach[q] * reach[q]
        buf, n = spread_slots(cx, cy, cz, reach[q], widest, spans[q], dims, origin, cell,
                              starts, run_mid, run_spread, buf)
        for c in range(n):
            slot = buf[c]
            if (listed[run_stop[slot]] - listed[run_start[slot]]
                    == run_stop[slot] - run_start[slot]):
                continue
            if not enters_before(slot, run_mid, run_half, p[0], p[1], p[2], d[0], d[1],
                                 d[2], outer, bound):
                continue
            grow = corner_radius + widen + run_dilation[slot]
            lo, hi = sweep_bound(p, d, run_c0[slot], run_chord[slot], run_axis[slot],
                                 run_height[slot], core_radius, grow)
            if not run_floor(p, d, run_c0[slot], run_chord[slot], run_axis[slot],
                             run_height[slot], core_radius, corner_radius + widen,
                             run_dilation[slot], lo, hi, bound, run_start[slot],
                             run_stop[slot], a, e, axis, height, block_of, block_span,
                             block_slack) < bound:
                continue
            lows[0], highs[0] = run_start[slot], run_stop[slot]
            depth = 1
            while depth > 0:
                depth -= 1
                i, j = lows[depth], highs[depth]
                if listed[j] - listed[i] == j - i:
                    continue
                if j - i == 1:
                    if marked[i] or not is_candidate(i, mid, cx, cy, cz, lim2):
                        continue
                    if not enters_before(i, mid, half, p[0], p[1], p[2], d[0], d[1],
                                         d[2], outer, bound):
                        continue
                    lo, hi = sweep_bound(p, d, a[i], e[i], axis[i], height[i],
                                         core_radius, corner_radius + widen)
                    if floor_entry(p, d, a[i], e[i], axis[i], height[i], core_radius,
                                   corner_radius + widen, lo, hi, bound) < bound:
                        marked[i] = True
                    continue
                h = (i + j) // 2
                for side in range(2):
                    lo_i, hi_j = (i, h) if side == 0 else (h, j)
                    if hi_j - lo_i > 1:
                        ref, grow = span_reference(lo_i, hi_j - 1, a, e, axis, height,
                                                   along, turned, core_radius,
                                                   corner_radius, chord)
                        lo, hi = sweep_bound(p, d, a[lo_i], chord, axis[ref], height[ref],
                                             core_radius, corner_radius + widen + grow)
                        if not run_floor(p, d, a[lo_i], chord, axis[ref], height[ref],
                                         core_radius, corner_radius + widen, grow, lo, hi,
                                         bound, lo_i, hi_j, a, e, axis, height, block_of,
                                         block_span, block_slack) < bound:
                            continue
                    lows[depth], highs[depth] = lo_i, hi_j
                    depth += 1


def pieces_entering_below(grid: PieceGrid, span: IntArray, points: FloatArray,
                          dirs: FloatArray, centres: FloatArray, reach_mm: FloatArray,
                          below_mm: FloatArray, runs: PieceRuns, mid: FloatArray,
                          half_mm: FloatArray, a: FloatArray, e: FloatArray, axis: FloatArray,
                          height_mm: FloatArray, *, core_radius_mm: float,
                          corner_radius_mm: float, widen_mm: float,
                          listed: IntArray | None = None) -> NDArray[np.bool_]:
    """Pieces whose sweep widened by ``widen_mm`` may enter some dexel below its bound.

    Parameters
    ----------
    grid, span : PieceGrid, ndarray of int64
        The runs by the cell of their midpoints, and the cells searched about each
        centre (as :func:`~verification.sweep_search.lowest_sweep_entries`).
    points, dirs : ndarray, shape (q, 3)
        Dexel origins (mm) and unit directions.
    centres : ndarray, shape (q, 3)
        Search centres, mm.
    reach_mm : ndarray, shape (q,)
        Pieces whose midpoints lie farther than this from the centre are not listed, mm.
    below_mm : ndarray, shape (q,)
        ``U_q``: a piece is listed where its widened floor lies below it, mm (``inf``: any
        that reaches the design point).
    runs : PieceRuns
        The pieces' runs in the grid's order.
    mid, half_mm, a, e, axis, height_mm : ndarray
        The pieces' fields in their own order (:class:`~verification.pieces.Pieces`).
    core_radius_mm, corner_radius_mm : float
        ``rho0 = R - r`` and ``r``, mm.
    widen_mm : float
        ``w``: how far outside a piece the solids it stands for may reach, mm.
    listed : ndarray of int64, shape (pieces + 1,), optional
        Prefix sums of the pieces the caller holds listed already (their segments kept):
        those are never marked, and a run or half of only such pieces is not walked
        (the other pieces are marked as without it). Default: none.

    Returns
    -------
    ndarray of bool, shape (pieces,)
        The pieces listed for some dexel (of those not listed already).
    """
    marked = np.zeros(mid.shape[0], dtype=np.bool_)
    q = points.shape[0]
    if q == 0 or grid.n_pieces == 0:
        return marked
    spans, dims = walk_shape(grid, span, q)
    f = np.ascontiguousarray
    height_mm = f(height_mm, dtype=float)
    if listed is None:
        listed = np.zeros(mid.shape[0] + 1, dtype=np.int64)
    # slices of WALK_BLOCK dexels taken as the threads free, as the parallel loop over
    # blocks under parallel_chunksize(1) it was (whose parfor cost more to compile)
    run_in_threads(_mark, q, f(points, dtype=float), f(dirs, dtype=float),
                   f(centres, dtype=float), f(reach_mm, dtype=float), f(below_mm, dtype=float),
                   spans, dims, f(grid.origin_mm, dtype=float), float(grid.cell_mm),
                   grid.starts, runs.mid, runs.half_mm, runs.spread_mm, runs.start, runs.stop,
                   runs.c0, runs.chord, runs.axis, runs.height_mm, runs.dilation_mm,
                   f(mid, dtype=float), f(half_mm, dtype=float), f(a, dtype=float),
                   f(e, dtype=float), f(axis, dtype=float), height_mm, runs.along_mm,
                   runs.turned, runs.block_of, runs.block_span, runs.block_slack,
                   float(core_radius_mm), float(corner_radius_mm), float(widen_mm),
                   piece_outer_mm(height_mm, core_radius_mm, corner_radius_mm + widen_mm),
                   runs.max_spread_mm, f(listed, dtype=np.int64), marked,
                   min_rows=WALK_BLOCK, dynamic=True)
    return marked
