"""The lowest entry of flat and bull-nose pieces along each dexel, walked in compiled code.

The same search as the candidate pairs of :class:`~verification.grid.PieceGrid` measured by
:class:`~verification.dexels.SweepIndex` (the exact path, kept as the oracle of the
tests), without storing a pair. Expanded as numpy pairs, every candidate's bound is stored
and the pairs it cannot rule out are measured in numpy: on a 5-axis program, whose pieces
are short (cut where the axis turns), that is tens of millions of pairs and minutes of a
verification. Here each dexel walks the runs of consecutive pieces
(:mod:`verification.piece_runs`: each inside its reference piece dilated by ``delta``)
whose midpoints lie within the search radius plus their spread of its centre, over the
cells of :func:`~verification.capsule_search.candidate_slots` (walked for a few
neighbouring dexels at once over a ball holding theirs, then sorted out per dexel, as the
ball walk does: the same runs for ~8 % less of the search's time on the bull-nose blade),
after the piece that left least on the previous dexel (next in the task) is measured, where
a candidate, as the best so far (its pieces seldom change from one dexel to the next):

1. every such run whose cheap lower bound on the entry (:func:`~verification.torus.sweep_bound`
   of its dilated reference: a bounding capsule cut by a slab) lies below the best so far;
2. best first: the run of lowest bound has its *floor* measured, the dilated reference's
   exact entry (``inf`` where the dilated sweep leaves the dexel at or below the design
   point: no piece inside it reaches there, the other side of a thin blade), raised to
   the pieces' least support plane at its normal there
   (:func:`~verification.piece_runs.run_floor`, a block's one plane for its pieces where
   that is not below the best: the same decisions as every piece's); the run of
   lowest floor, when no cheap bound lies lower, is opened: halved, each half's own
   reference and dilation measured, while a half's floor lies below the best, down to
   single pieces, which are the candidates (midpoint within the search radius) and are
   measured exactly (:func:`~verification.torus.sweep_interval`) where their own bound
   lies below the best.

A floor is a lower bound on what every piece of its run leaves, so a run or half skipped
holds no piece below the best (a piece that leaves ``p`` leaves it from within ``delta``
of the reference, see :mod:`verification.piece_runs`): the same minimum as every
candidate measured, whatever the best it starts from (a seed is a candidate's value; the
least ``(value, piece)`` of a total order does not depend on which is met first). On
the bull-nose 5-axis blade (16,000 candidate pieces per dexel, thousands of them
measured) a dexel measures some tens of floors and a handful of pieces.

The value of a pair is the one of :mod:`verification.dexels`: ``lam_in`` when the sweep
reaches the design point (``lam_out > 0``), ``max(lam_in, -lam_out)`` when it comes from
behind (``a . d < BEHIND_COSINE`` and ``lam_in < 0``), else nothing
(:func:`~verification.capsule_search.pair_value`). Of equal values the piece of smallest
index, ball pieces in path order, then shank pieces (the tie rule of
:mod:`verification.capsule_search`, :func:`~verification.capsule_search.ranks_before`):
a run, half or piece is dropped when its bound is not below the best, or, when it holds a
piece before the best one, not below :func:`~verification.capsule_search.tie_limit`.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from toolpath.row_threads import run_in_threads

from .capsule_search import (
    ROUNDING_SLACK_MM,
    TIE_SLACK_MM,
    WALK_BLOCK,
    enters_before,
    group_slots,
    is_candidate,
    pair_value,
    ranks_before,
    tie_limit,
    walk_shape,
)
from .grid import PieceGrid
from .piece_runs import PieceRuns, reaches, run_floor, span_reference
from .torus import sweep_bound, sweep_bound_within, sweep_interval

__all__ = ["lowest_sweep_entries", "piece_outer_mm"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Entries of a run's halving stack: each level of halving leaves at most one half
#: waiting, and a run of ``n`` pieces is halved ``ceil(log2 n)`` times.
_STACK = 64


@numba.njit(cache=True)
def _value(p: FloatArray, d: FloatArray, c0: FloatArray, chord: FloatArray,
           axis: FloatArray, height: float, core_radius: float, corner_radius: float,
           behind_cosine: float) -> tuple[float, bool]:
    """Material one piece leaves on one dexel (``inf``: none), and whether from behind."""
    cosine = d[0] * axis[0] + d[1] * axis[1] + d[2] * axis[2]
    lam_in, lam_out = sweep_interval(p, d, c0, chord, axis, height, core_radius,
                                     corner_radius, cosine < behind_cosine)
    return pair_value(lam_in, lam_out, cosine, behind_cosine)


#: Dexels one task of the bull-nose walk takes (:func:`~toolpath.row_threads.run_in_threads`,
#: the tasks handed to the threads as they free): whole blocks of
#: :data:`~.capsule_search.WALK_BLOCK`, fewer than the ball walk's task
#: (:data:`~.capsule_search.WALK_TASK`) as a dexel costs many times more here (a swept
#: bull-nose's bounds and intervals against a capsule's), so that the last tasks leave no
#: core idle for long. (A ``prange`` loop over the blocks did the same for about 5 s more
#: CPU of compiling on a cold kernel cache.)
SWEEP_WALK_TASK = 4 * WALK_BLOCK


@numba.njit(cache=True, nogil=True)
def _walk(points: FloatArray, dirs: FloatArray, centres: FloatArray, reach: FloatArray,
          wide2: FloatArray, grouped: bool, seeded: bool, spans: IntArray, dims: IntArray,
          origin: FloatArray, cell: float, starts: IntArray, run_mid: FloatArray,
          run_half: FloatArray,
          run_spread: FloatArray, run_start: IntArray, run_stop: IntArray, run_c0: FloatArray,
          run_chord: FloatArray, run_axis: FloatArray, run_height: FloatArray,
          run_dilation: FloatArray, mid: FloatArray, half: FloatArray, a: FloatArray,
          e: FloatArray, axis: FloatArray, height: FloatArray, along: FloatArray,
          turned: FloatArray, block_of: IntArray, block_span: IntArray,
          block_slack: FloatArray, core_radius: float, corner_radius: float,
          behind_cosine: float,
          outer: float, lam: FloatArray, piece: IntArray,
          behind: NDArray[np.bool_], pairs: IntArray, row_lo: int, row_hi: int) -> None:
    # dexels row_lo .. row_hi - 1 (a slice of them in each thread, run_in_threads)
    # ``piece`` holds on entry the piece of a value given (``-1``: none), on exit the one
    # found; a bound is compared with tie_limit(best, its run's or half's first piece)
    # ``outer``: every piece's cutter lies within this plus its half length of its
    # midpoint, a run's within this plus its own half (:func:`piece_outer_mm`);
    # ``wide2``: each dexel's squared radius of runs met, ``(reach + widest)^2`` for the
    # largest run spread ``widest`` (both taken outside: a reduction here would be a
    # parallel loop chunked by the walk's chunk size of 1, a task per element, over every
    # piece); ``grouped``: WALK_GROUP neighbouring dexels walk the grid once over a ball
    # holding their balls of runs met (group_ball), each then sorting out its own
    # (own_slots: the very runs, in the same order, of its walk alone), as the ball walk
    # does; ``seeded``: each dexel first measures the piece that left least on the
    # task's previous one, where a candidate (tests turn both off to compare)
    buf = np.empty(WALK_BLOCK, dtype=np.int64)
    shared = np.empty(WALK_BLOCK, dtype=np.int64)
    kept = np.empty(WALK_BLOCK, dtype=np.int64)
    bounds = np.empty(WALK_BLOCK)
    tops = np.empty(WALK_BLOCK)
    pending = np.empty(WALK_BLOCK, dtype=np.int64)
    floors_of = np.empty(WALK_BLOCK)
    # the halving's stack (depth at most twice log2 of a run's pieces) and scratch
    lows = np.empty(_STACK, dtype=np.int64)
    highs = np.empty(_STACK, dtype=np.int64)
    floors = np.empty(_STACK)
    halves = np.empty(2)
    chord = np.empty(3)
    for block_start in range(row_lo, row_hi, WALK_BLOCK):
        n_shared = -1
        seed = -1
        stop = min(row_hi, block_start + WALK_BLOCK)
        for q in range(block_start, stop):
            shared, n_shared, buf, n = group_slots(q, block_start, stop, grouped, centres,
                                                   wide2, spans, dims, origin, cell, starts,
                                                   run_mid, shared, n_shared, buf)
            p, d = points[q], dirs[q]
            cx, cy, cz = centres[q, 0], centres[q, 1], centres[q, 2]
            lim2 = reach[q] * reach[q]
            if bounds.shape[0] < n:
                kept = np.empty(buf.shape[0], dtype=np.int64)
                bounds = np.empty(buf.shape[0])
                tops = np.empty(buf.shape[0])
                pending = np.empty(buf.shape[0], dtype=np.int64)
                floors_of = np.empty(buf.shape[0])
            best = lam[q]
            best_piece = piece[q]
            found = -1
            best_behind = False
            met = 0
            # the piece that left least on the task's previous dexel, measured first when
            # a candidate here: a value some candidate leaves, so a best to prune by from
            # the start (the least of (value, piece) is the same whatever is met first)
            if seeded and seed >= 0 and is_candidate(seed, mid, cx, cy, cz, lim2):
                met += 1
                value, back = _value(p, d, a[seed], e[seed], axis[seed], height[seed],
                                     core_radius, corner_radius, behind_cosine)
                if ranks_before(value, seed, best, best_piece):
                    best, best_piece, found, best_behind = value, seed, seed, back
            # walk 0: the runs that may hold a candidate and enter below the best so far,
            # with the bounds of their dilated reference pieces
            m = 0
            for c in range(n):
                slot = buf[c]
                own = reach[q] + run_spread[slot]
                if not is_candidate(slot, run_mid, cx, cy, cz, own * own):
                    continue
                limit = tie_limit(best, run_start[slot], best_piece)
                if not enters_before(slot, run_mid, run_half, p[0], p[1], p[2], d[0], d[1],
                                     d[2], outer, limit):
                    continue
                lo, hi = sweep_bound_within(p, d, run_c0[slot], run_chord[slot],
                                            run_axis[slot], run_height[slot], core_radius,
                                            corner_radius + run_dilation[slot], limit,
                                            -ROUNDING_SLACK_MM)
                if not (lo < limit and reaches(hi)):
                    continue
                kept[m], bounds[m], tops[m] = slot, lo, hi
                m += 1
            # walk 1, best first: the runs by their cheap bounds; the next one's dilated
            # reference entered (a lower bound on all its pieces: its floor) unless a run
            # already floored lies lower, which is then opened, halved while a half may
            # still hold a piece below the best (a low best early prunes the rest)
            rank = np.argsort(bounds[:m])
            u = 0
            waiting = 0
            while True:
                w = -1
                for x in range(waiting):
                    if w < 0 or floors_of[x] < floors_of[w]:
                        w = x
                cheap = bounds[rank[u]] if u < m else math.inf
                # no bound below this, none below any run's tie limit: done
                if not min(cheap, floors_of[w] if w >= 0 else math.inf) < (
                        best + (TIE_SLACK_MM if best_piece > 0 else ROUNDING_SLACK_MM)):
                    break
                if w >= 0 and floors_of[w] <= cheap:
                    v = pending[w]
                    waiting -= 1
                    pending[w], floors_of[w] = pending[waiting], floors_of[waiting]
                    if not bounds[v] < tie_limit(best, run_start[kept[v]], best_piece):
                        continue
                else:
                    v = rank[u]
                    u += 1
                    slot = kept[v]
                    limit = tie_limit(best, run_start[slot], best_piece)
                    if not bounds[v] < limit:
                        continue
                    if run_stop[slot] - run_start[slot] > 1:
                        met += 1
                        floor = run_floor(p, d, run_c0[slot], run_chord[slot], run_axis[slot],
                                          run_height[slot], core_radius, corner_radius,
                                          run_dilation[slot], bounds[v], tops[v], limit,
                                          run_start[slot], run_stop[slot], a, e, axis, height,
                                          block_of, block_span, block_slack)
                        if floor < limit:
                            bounds[v] = floor
                            pending[waiting], floors_of[waiting] = v, floor
                            waiting += 1
                        continue
                slot = kept[v]
                lows[0], highs[0], floors[0] = run_start[slot], run_stop[slot], bounds[v]
                depth = 1
                while depth > 0:
                    depth -= 1
                    i, j = lows[depth], highs[depth]
                    limit = tie_limit(best, i, best_piece)
                    if not floors[depth] < limit:
                        continue
                    if j - i == 1:
                        if not is_candidate(i, mid, cx, cy, cz, lim2):
                            continue
                        met += 1
                        if not enters_before(i, mid, half, p[0], p[1], p[2], d[0], d[1],
                                             d[2], outer, limit):
                            continue
                        # (no reaches(hi) here: a lone piece's value decides lam_out > 0
                        # from its distance to the point, not from hi, whose slab exit
                        # divides a rounding by d . a, tiny for a dexel in its bottom's
                        # plane: tests/verification/test_sweep_prunes.py)
                        lo, _ = sweep_bound_within(p, d, a[i], e[i], axis[i], height[i],
                                                   core_radius, corner_radius, limit,
                                                   -math.inf)
                        if not lo < limit:
                            continue
                        value, back = _value(p, d, a[i], e[i], axis[i], height[i],
                                             core_radius, corner_radius, behind_cosine)
                        if ranks_before(value, i, best, best_piece):
                            best, best_piece, found, best_behind = value, i, i, back
                        continue
                    # the two halves, the one entered lower on top of the stack
                    h = (i + j) // 2
                    for side in range(2):
                        lo_i, hi_j = (i, h) if side == 0 else (h, j)
                        entry = -math.inf
                        if hi_j - lo_i > 1:
                            met += 1
                            ref, grow = span_reference(lo_i, hi_j - 1, a, e, axis, height,
                                                       along, turned, core_radius,
                                                       corner_radius, chord)
                            lo, hi = sweep_bound(p, d, a[lo_i], chord, axis[ref], height[ref],
                                                 core_radius, corner_radius + grow)
                            entry = math.inf
                            if reaches(hi):
                                entry = run_floor(p, d, a[lo_i], chord, axis[ref],
                                                  height[ref], core_radius, corner_radius,
                                                  grow, lo, hi,
                                                  tie_limit(best, lo_i, best_piece), lo_i,
                                                  hi_j, a, e, axis, height, block_of,
                                                  block_span, block_slack)
                        halves[side] = entry
                    for side in (1, 0) if halves[0] <= halves[1] else (0, 1):
                        if halves[side] < tie_limit(best, i if side == 0 else h, best_piece):
                            lows[depth] = i if side == 0 else h
                            highs[depth] = h if side == 0 else j
                            floors[depth] = halves[side]
                            depth += 1
            if found >= 0:
                seed = found
            lam[q] = best
            piece[q] = found
            behind[q] = best_behind
            pairs[q] = met


def piece_outer_mm(height_mm: FloatArray, core_radius_mm: float, corner_radius_mm: float
                   ) -> float:
    """Every piece's cutter lies within this plus its half length of its midpoint, mm.

    The bound of :func:`~verification.torus.sweep_bound` about the core's mid-height
    path, which stands ``L / 2`` above the midpoint: ``sqrt(rho0^2 + (L/2)^2) + r + L/2``
    for the tallest core ``L``.
    """
    top = 0.5 * float(height_mm.max()) if height_mm.shape[0] else 0.0
    return math.sqrt(core_radius_mm * core_radius_mm + top * top) + corner_radius_mm + top


def lowest_sweep_entries(grid: PieceGrid, span: IntArray, points: FloatArray,
                         dirs: FloatArray, centres: FloatArray, reach_mm: FloatArray,
                         runs: PieceRuns, mid: FloatArray, half_mm: FloatArray, a: FloatArray,
                         e: FloatArray, axis: FloatArray, height_mm: FloatArray, *,
                         core_radius_mm: float, corner_radius_mm: float,
                         behind_cosine: float,
                         below_mm: FloatArray | None = None,
                         below_piece: IntArray | None = None, grouped: bool = True,
                         seeded: bool = True
                         ) -> tuple[FloatArray, IntArray, NDArray[np.bool_], int]:
    """Per dexel the lowest value among flat/bull-nose pieces within ``reach_mm``.

    Of equal values the piece of smallest index
    (:func:`~verification.capsule_search.ranks_before`). Neighbouring dexels (next in
    ``points``) gather their runs in one walk of the grid
    (:data:`~verification.capsule_search.WALK_GROUP` at a time, as the ball walk), then
    each its own: the very runs, in the grid's order, its walk alone meets, so the same
    values, pieces and pair counts (``grouped=False``: each walks alone, the tests'
    reference).

    Parameters
    ----------
    grid : PieceGrid
        The runs by the cell of their midpoints (:attr:`PieceRuns.mid`).
    span : ndarray of int64, shape (q,)
        Cells searched on each side of a centre's cell (covers ``reach_mm`` plus the
        widest run's spread).
    points, dirs : ndarray, shape (q, 3)
        Dexel origins (mm) and unit directions.
    centres : ndarray, shape (q, 3)
        Search centres, mm.
    reach_mm : ndarray, shape (q,)
        A piece is a candidate when its midpoint lies within this of the centre, mm.
    runs : PieceRuns
        The pieces' runs (:func:`~verification.piece_runs.piece_runs`) in the grid's order
        (:meth:`PieceRuns.taken` of ``grid.order``).
    mid, half_mm, a, e, axis, height_mm : ndarray
        The pieces' midpoints, half lengths, core bottom centres at their starts, chords,
        axes and core heights (:class:`~verification.pieces.Pieces`), in their own order.
    core_radius_mm, corner_radius_mm : float
        ``rho0 = R - r`` and ``r``, mm.
    behind_cosine : float
        ``a . d`` below which a piece comes from behind.
    below_mm : ndarray, shape (q,), optional
        Seek only values below these, mm (default: all).
    below_piece : ndarray of int64, shape (q,), optional
        The pieces of ``below_mm`` (``-1``: none): an equal value of a piece before it
        is sought too.
    grouped : bool
        Walk the grid for groups of neighbouring dexels (default), or for each alone.
    seeded : bool
        Measure first, where a candidate, the piece found on the previous dexel
        (default): the same values and pieces; the pairs count moves (the seed is one
        more pair measured, and it prunes others: on a 3,000-line bull-nose prefix 1.3 %
        fewer).

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
        Runs and candidate pieces met.
    """
    q = points.shape[0]
    lam = np.full(q, np.inf) if below_mm is None else np.array(below_mm, dtype=float)
    piece = np.full(q, -1, dtype=np.int64)
    if below_mm is not None and below_piece is not None:
        piece[:] = below_piece
    behind = np.zeros(q, dtype=np.bool_)
    pairs = np.zeros(q, dtype=np.int64)
    if q == 0 or grid.n_pieces == 0:
        return np.full(q, np.inf), np.full(q, -1, dtype=np.int64), behind, 0
    spans, dims = walk_shape(grid, span, q)
    f = np.ascontiguousarray
    height_mm = f(height_mm, dtype=float)
    reach_mm = f(reach_mm, dtype=float)
    wide_mm = reach_mm + runs.max_spread_mm
    run_in_threads(_walk, q, f(points, dtype=float), f(dirs, dtype=float),
                   f(centres, dtype=float), reach_mm, wide_mm * wide_mm, bool(grouped),
                   bool(seeded), spans, dims, f(grid.origin_mm, dtype=float),
                   float(grid.cell_mm), grid.starts, runs.mid, runs.half_mm, runs.spread_mm,
                   runs.start, runs.stop, runs.c0, runs.chord, runs.axis, runs.height_mm,
                   runs.dilation_mm, f(mid, dtype=float), f(half_mm, dtype=float),
                   f(a, dtype=float), f(e, dtype=float), f(axis, dtype=float),
                   height_mm, runs.along_mm, runs.turned, runs.block_of, runs.block_span,
                   runs.block_slack, float(core_radius_mm),
                   float(corner_radius_mm), float(behind_cosine),
                   piece_outer_mm(height_mm, core_radius_mm, corner_radius_mm), lam, piece,
                   behind, pairs, min_rows=SWEEP_WALK_TASK, dynamic=True)
    lam[piece < 0] = np.inf
    return lam, piece, behind, int(pairs.sum())
