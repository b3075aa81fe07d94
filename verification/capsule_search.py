"""The lowest capsule entry along each dexel, walked over the piece grid in compiled code.

The same search as the candidate pairs of :class:`~verification.grid.PieceGrid` folded by
:class:`~verification.dexels.SweepIndex` (the exact path, kept for flat and bull-nose
pieces and as the oracle of the tests), without storing a pair: for each dexel the
``(2 k + 1)^2`` columns of cells around its search centre are walked in the grid's order
(for a few neighbouring dexels at once, over a ball holding theirs, then sorted out per
dexel: the same candidates for a fraction of the walking), every piece whose midpoint lies
within the search radius is met with
:func:`~verification.capsule.capsule_interval`, and only the lowest value is kept (of
equal ones the smallest piece index: :func:`ranks_before`). Memory is the output; the cost is the
candidate pairs at a few nanoseconds each, spread over the cores.

The value of a pair is the one of :mod:`verification.dexels`: ``lam_in`` when the capsule
reaches the design point (``lam_out > 0``), ``max(lam_in, -lam_out)`` when it comes from
behind (``a . d < BEHIND_COSINE`` and ``lam_in < 0``), else nothing (:func:`pair_value`).

**The tie rule** (every search's, :func:`ranks_before`): of pieces leaving exactly the
same value on a dexel (bit-equal; a flat bottom on a floor, passes overlapping on a plane)
the one of smallest piece index (the near search's pieces are in path order; the
collision search's are the ball pieces in path order, then the shank pieces, so an equal
shank piece of an earlier block loses to a later block's ball piece), gives the dexel its
piece, hence its block. Equal means bit-equal: every search measures a (dexel, piece) pair
with the same compiled kernel (the numpy paths call it row by row), so a pair's value is
the same bits in every search, and the order ``(value, piece)`` is a total order, whose
minimum is the same however the candidates are split (grid cells, levels of the iterative
deepening, batches, searches merged afterwards, an index shared between asks). Within an
epsilon it would not be: "within e of the least" depends on the least, so two partial
results cannot be merged without every near-tie they set aside, and a chain of values each
within e of the next has no first. Values that differ only by rounding (1e-15 mm) are not
tied: the lower keeps the dexel, in every search alike, and the depth reported is the
least value whichever piece is named. A bound may equal the value it bounds, or stand a
rounding above it (see :data:`TIE_SLACK_MM`), so a set of pieces that may hold a tied
piece of smaller index is dropped only when its bound exceeds the best by
:data:`TIE_SLACK_MM` (:func:`tie_limit`): only near-ties are measured more.

The small tests several compiled loops share (:func:`is_candidate`, :func:`centre_cell`,
:func:`enters_before`, :func:`pair_value`, :func:`ranks_before`, :func:`tie_limit`)
compile once each, without the wrappers Python would call them through (Python must not
call them), rather than inlined by numba: numba compiled an inlined copy at every call
site, slower on a cold start (issue 27).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from toolpath.row_threads import run_in_threads

from .capsule import capsule_interval
from .grid import PieceGrid

__all__ = ["ROUNDING_SLACK_MM", "TIE_SLACK_MM", "candidate_slots", "column_slots", "group_ball",
           "lowest_capsule_entries", "own_slots", "pair_values", "walk_shape"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Widening of a grid cell's borders (in cells) when a walk tests whether the search ball
#: meets a column or a cell: the cell a midpoint was filed in comes from a floor of its own
#: rounding, so a ball grazing a border keeps the cell on both sides.
COLUMN_RIM = 1e-6
#: Dexels a compiled walk takes in a block: within it the piece that left least on one
#: dexel is tried first on the next.
WALK_BLOCK = 64
#: Dexels one task of a compiled walk takes (:func:`~toolpath.row_threads.run_in_threads`,
#: the tasks handed to the threads as they free, so a core slowed by other work takes
#: fewer): whole blocks. (A ``prange`` loop over the blocks did the same, for 2.6 s more
#: CPU of compiling, which a job on a cold kernel cache pays: 9.6 s against 7.0 s.)
WALK_TASK = 16 * WALK_BLOCK
#: Neighbouring dexels (next samples along a row of the design grid) whose candidates are
#: gathered in one walk of the grid: over a ball holding all their search balls, then
#: sorted out for each by its own ball (:func:`group_ball`, :func:`own_slots`). On the
#: issue-27 job (1M dexels, 16.5M pairs) 4 takes a third off the near search's CPU time;
#: 3 to 8 do about as well.
WALK_GROUP = 4
#: A group is walked together only while its ball stays within this many times its
#: widest member's radius (a row's end, a far or non-finite centre: each on its own).
GROUP_REACH = 2.0
#: How far above the best value a lower bound may stand and still hold a piece tied with
#: the best, mm: a set of pieces that may hold a tied piece of smaller index is measured
#: unless its bound is farther above. It covers bounds that are exact, not loose: (i) a
#: bound equal to the value it bounds, met by a strict ``<`` test (a flat bottom's lower
#: limit ``zlo`` in :func:`~verification.torus.sweep_bound`, in the sweep walk and the
#: pair search's ``_cutters``); (ii) :func:`capsule_entry_bound` one rounding
#: step above the capsule's entry (measured: 10,175 of 100,000 vertical dexels on a pass
#: line past a piece's end, by at most 4.4e-16 mm). It does NOT cover the Newton floors
#: of runs and halves: a Newton entry stops at ``|F| <= 1e-7`` (a distance), so along a
#: dexel it may stand ~1e-7/slope off (2.2e-6 mm measured on a bull dexel), more than
#: this slack; those floors stay sound by the
#: :data:`~verification.piece_runs.ENTRY_MARGIN_MM` carried in their dilation (and the
#: span reference's), which must not be removed on the strength of this slack.
TIE_SLACK_MM = 1e-6

#: How far above the best value a bound may stand from rounding alone, mm: a set of pieces
#: of any index whose bound is not this far above is measured, so a value below the best
#: by a few rounding steps (4.4e-16 mm measured, two pass pieces ending at one point)
#: keeps the dexel in every search alike, as the pair search, which measures all, finds
#: it; a few units in the last place of coordinates up to a few metres.
ROUNDING_SLACK_MM = 1e-11


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def ranks_before(value: float, piece: int, best: float, best_piece: int) -> bool:
    """Whether ``(value, piece)`` comes before ``(best, best_piece)``: the tie rule.

    Lower values first; of equal (bit-equal) values the smaller piece index. A best of no
    piece (``best_piece < 0``: nothing yet, or a value another search found, which only
    less replaces) is ranked before only by a lower value.
    """
    return value < best or (value == best and 0 <= piece < best_piece)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def tie_limit(best: float, lowest_piece: int, best_piece: int) -> float:
    """A set of pieces whose bound is not below this holds none that ranks before the best.

    ``best`` plus :data:`TIE_SLACK_MM` when its smallest piece index ``lowest_piece`` may
    win a tie (below ``best_piece``: a bound rounded above a tied value must not drop
    it), else plus :data:`ROUNDING_SLACK_MM` (a bound rounded above a value lower by
    rounding must not drop it either).
    """
    if 0 <= lowest_piece < best_piece:
        return best + TIE_SLACK_MM
    return best + ROUNDING_SLACK_MM


@numba.njit(cache=True)
def column_slots(i: int, j: int, k0: int, k1: int, cx: float, cy: float, cz: float,
                 lim2: float, dims: IntArray, origin: FloatArray, cell: float,
                 starts: IntArray) -> tuple[int, int]:
    """Slots of the grid's order a search ball can reach in column ``(i, j)``.

    Cells ``k0..k1`` of the column, the ball centred at ``c`` with squared radius
    ``lim2``; ``(0, 0)`` when none.

    Only the cells the ball meets (a little wider: the cells' borders here and in the
    grid's floor may round apart): a column whose square lies farther than the radius is
    skipped, the others walked over the ball's height above the square. The one cell walk
    of the compiled searches (this module's and :mod:`verification.sweep_search`).
    """
    if i < 0 or i >= dims[0] or j < 0 or j >= dims[1] or k0 > k1:
        return 0, 0
    rim = COLUMN_RIM * cell
    x0 = origin[0] + i * cell
    gx = max(x0 - rim - cx, cx - (x0 + cell + rim), 0.0)
    y0 = origin[1] + j * cell
    gy = max(y0 - rim - cy, cy - (y0 + cell + rim), 0.0)
    across = lim2 - gx * gx - gy * gy
    if not across >= 0.0:
        return 0, 0
    height = math.sqrt(across) + rim
    lo_k = max(k0, math.floor((cz - height - origin[2]) / cell))
    hi_k = min(k1, math.floor((cz + height - origin[2]) / cell))
    if lo_k > hi_k:
        return 0, 0
    column = (i * dims[1] + j) * dims[2]
    return starts[column + lo_k], starts[column + hi_k + 1]


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def is_candidate(slot: int, mid: FloatArray, cx: float, cy: float, cz: float,
                 lim2: float) -> bool:
    """Whether the midpoint in ``slot`` lies within ``sqrt(lim2)`` of the centre ``c``.

    The candidate test of the compiled walks (this module's and
    :mod:`verification.sweep_search`); midpoints in the grid's order.
    """
    mx, my, mz = mid[slot, 0] - cx, mid[slot, 1] - cy, mid[slot, 2] - cz
    return mx * mx + my * my + mz * mz <= lim2


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def enters_before(slot: int, mid: FloatArray, half: FloatArray, px: float, py: float,
                  pz: float, dx: float, dy: float, dz: float, outer: float,
                  limit: float) -> bool:
    """Whether the piece in ``slot`` may enter the line ``p + lam d`` below ``limit``.

    Its solid lies within ``rho = outer + half`` of its midpoint ``m``: a line farther
    than ``rho`` from ``m`` misses it, and enters it no sooner than
    ``t - sqrt(rho^2 - perp^2)`` (``t = (m - p) . d``, ``perp`` the line's distance).
    The prune of the compiled walks; midpoints and half lengths in the grid's order.
    """
    wx, wy, wz = mid[slot, 0] - px, mid[slot, 1] - py, mid[slot, 2] - pz
    t = wx * dx + wy * dy + wz * dz
    rho = outer + half[slot]
    room = rho * rho - (wx * wx + wy * wy + wz * wz - t * t)
    return not (room < 0.0 or t - math.sqrt(room) >= limit)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def pair_value(lam_in: float, lam_out: float, cosine: float, behind_cosine: float
               ) -> tuple[float, bool]:
    """Material a piece met in ``[lam_in, lam_out]`` leaves on a dexel, and whether from behind.

    ``lam_in`` when it reaches the design point (``lam_out > 0``); when it comes from
    behind (its axis makes ``cosine = a . d < behind_cosine``) and ``lam_in < 0``,
    ``max(lam_in, -lam_out)``; ``inf`` (nothing) when ``lam_out <= 0``. The one rule of
    the module docstring of :mod:`verification.dexels`, for every search.
    """
    if not lam_out > 0.0:
        return math.inf, False
    back = lam_in < 0.0 and cosine < behind_cosine
    return (max(lam_in, -lam_out) if back else lam_in), back


@numba.njit(cache=True)
def pair_values(lam_in: FloatArray, lam_out: FloatArray, cosine: FloatArray,
                behind_cosine: float) -> tuple[FloatArray, NDArray[np.bool_]]:
    """:func:`pair_value` of each pair (the candidate-pair path of ``SweepIndex``)."""
    value = np.empty(lam_in.shape[0])
    behind = np.empty(lam_in.shape[0], dtype=np.bool_)
    for k in range(lam_in.shape[0]):
        value[k], behind[k] = pair_value(lam_in[k], lam_out[k], cosine[k], behind_cosine)
    return value, behind


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def centre_cell(c: float, origin: float, cell: float, n_cells: int, span: int) -> int:
    """The cell of a search centre along one axis; a far (or non-finite) one beyond reach.

    ``floor((c - origin) / cell)`` held within ``[-span - 1, n_cells + span]``, NaN to
    ``-span - 1``: cells beyond those hold no piece within ``span`` cells.
    """
    v = (c - origin) / cell
    if not v >= -span - 1.0:
        return -span - 1
    if v > n_cells + span:
        return n_cells + span
    return math.floor(v)


@numba.njit(cache=True)
def candidate_slots(cx: float, cy: float, cz: float, lim2: float, span: int, dims: IntArray,
                    origin: FloatArray, cell: float, starts: IntArray, mid: FloatArray,
                    buf: IntArray) -> tuple[IntArray, int]:
    """Slots of the pieces whose midpoints lie within ``sqrt(lim2)`` of ``c``, in grid order.

    The one loop nest of the compiled walks (this module's and
    :mod:`verification.sweep_search`): the columns ``(i, j)`` within ``span`` cells of the
    centre's cell (:func:`centre_cell`) that the search ball meets (along ``j`` only those
    within the ball's chord at ``i``, one more each side for the rounding of the borders;
    :func:`column_slots` decides), their cells the ball reaches, and of their pieces the
    ones :func:`is_candidate` keeps. Written to ``buf`` (grown when full, so returned) and
    counted: ``buf[:n]``.
    """
    ci = centre_cell(cx, origin[0], cell, dims[0], span)
    cj = centre_cell(cy, origin[1], cell, dims[1], span)
    ck = centre_cell(cz, origin[2], cell, dims[2], span)
    n = 0
    k0 = max(ck - span, 0)
    k1 = min(ck + span, dims[2] - 1)
    rim = COLUMN_RIM * cell
    for i in range(max(ci - span, 0), min(ci + span, dims[0] - 1) + 1):
        x0 = origin[0] + i * cell
        gx = max(x0 - rim - cx, cx - (x0 + cell + rim), 0.0)
        across = lim2 - gx * gx
        if not across >= 0.0:
            continue
        w = math.sqrt(across) + rim
        j0 = max(cj - span, math.floor((cy - w - origin[1]) / cell) - 1, 0)
        j1 = min(cj + span, math.floor((cy + w - origin[1]) / cell) + 1, dims[1] - 1)
        for j in range(j0, j1 + 1):
            first, stop = column_slots(i, j, k0, k1, cx, cy, cz, lim2, dims, origin, cell,
                                       starts)
            for slot in range(first, stop):
                if not is_candidate(slot, mid, cx, cy, cz, lim2):
                    continue
                if n == buf.shape[0]:
                    grown = np.empty(2 * n, dtype=np.int64)
                    grown[:n] = buf
                    buf = grown
                buf[n] = slot
                n += 1
    return buf, n


@numba.njit(cache=True)
def group_ball(centres: FloatArray, lim2: FloatArray, first: int, stop: int
               ) -> tuple[float, float, float, float]:
    """A ball holding the search balls of dexels ``first..stop-1``; radius 0 when unfit.

    Centred at the mean ``g`` of their centres, radius ``max_q (|c_q - g| + r_q)`` (a
    hair wider, 1e-9 relative, so the rounding of the sums keeps every member's ball
    inside): a piece within ``r_q`` of ``c_q`` lies within it. Returns ``g`` and the
    squared radius; ``0`` for a single dexel, or a ball wider than :data:`GROUP_REACH`
    times the widest member's radius or not finite (a row's end, a far or NaN centre):
    those dexels walk the grid each on its own.
    """
    m = stop - first
    gx = gy = gz = 0.0
    for q in range(first, stop):
        gx += centres[q, 0]
        gy += centres[q, 1]
        gz += centres[q, 2]
    gx, gy, gz = gx / m, gy / m, gz / m
    reach = widest = 0.0
    for q in range(first, stop):
        wx, wy, wz = centres[q, 0] - gx, centres[q, 1] - gy, centres[q, 2] - gz
        r = math.sqrt(lim2[q])
        widest = max(widest, r)
        reach = max(reach, math.sqrt(wx * wx + wy * wy + wz * wz) + r)
    if m < 2 or not (reach <= GROUP_REACH * widest and reach < math.inf):
        return gx, gy, gz, 0.0
    reach *= 1.0 + 1e-9
    return gx, gy, gz, reach * reach


@numba.njit(cache=True)
def own_slots(shared: IntArray, n_shared: int, cx: float, cy: float, cz: float,
              lim2: float, mid: FloatArray, buf: IntArray) -> tuple[IntArray, int]:
    """Of a group's candidates ``shared[:n_shared]``, the ones within ``sqrt(lim2)`` of ``c``.

    :func:`is_candidate` on each, in their order (the grid's): the very slots
    :func:`candidate_slots` finds for ``c`` alone, as every one of them lies within the
    group's ball (:func:`group_ball`). Written to ``buf`` (grown when too small).
    """
    if buf.shape[0] < n_shared:
        buf = np.empty(shared.shape[0], dtype=np.int64)
    n = 0
    for u in range(n_shared):
        if is_candidate(shared[u], mid, cx, cy, cz, lim2):
            buf[n] = shared[u]
            n += 1
    return buf, n


@numba.njit(cache=True)
def group_slots(q: int, first: int, stop: int, grouped: bool, centres: FloatArray,
                lim2: FloatArray, spans: IntArray, dims: IntArray, origin: FloatArray,
                cell: float, starts: IntArray, mid: FloatArray, shared: IntArray,
                n_shared: int, buf: IntArray) -> tuple[IntArray, int, IntArray, int]:
    """Dexel ``q``'s candidate slots, its group's grid walked once (:func:`group_ball`).

    Dexels ``first .. stop`` are a walk's task; at every :data:`WALK_GROUP`-th of them
    (``grouped``) the slots of the ball holding the next group's balls are gathered into
    ``shared[:n_shared]`` (``n_shared = -1``: none, each dexel walks alone), and each
    dexel takes its own from them (:func:`own_slots`: the very slots, in the same order,
    :func:`candidate_slots` finds for it alone). Returns ``(shared, n_shared, buf, n)``:
    the group's slots to carry to the next dexel, and this one's in ``buf[:n]``.
    """
    if grouped and (q - first) % WALK_GROUP == 0:
        gx, gy, gz, g2 = group_ball(centres, lim2, q, min(stop, q + WALK_GROUP))
        n_shared = -1
        if g2 > 0.0:
            shared, n_shared = candidate_slots(
                gx, gy, gz, g2, max(1, math.ceil(math.sqrt(g2) / cell)), dims, origin, cell,
                starts, mid, shared)
    cx, cy, cz = centres[q, 0], centres[q, 1], centres[q, 2]
    if n_shared >= 0:
        buf, n = own_slots(shared, n_shared, cx, cy, cz, lim2[q], mid, buf)
    else:
        buf, n = candidate_slots(cx, cy, cz, lim2[q], spans[q], dims, origin, cell, starts,
                                 mid, buf)
    return shared, n_shared, buf, n


@numba.njit(cache=True)
def spread_slots(cx: float, cy: float, cz: float, reach: float, widest: float, span: int,
                 dims: IntArray, origin: FloatArray, cell: float, starts: IntArray,
                 mid: FloatArray, spread: FloatArray, buf: IntArray) -> tuple[IntArray, int]:
    """The slots whose midpoint lies within ``reach`` plus the slot's own ``spread`` of ``c``.

    For runs of pieces (:mod:`verification.piece_runs`: a run's pieces lie within its
    spread of its midpoint): :func:`candidate_slots` over ``reach + widest`` (``widest``
    the largest spread), then :func:`is_candidate` with each slot's own; in the grid's
    order, in ``buf[:n]``.
    """
    wide = reach + widest
    buf, n = candidate_slots(cx, cy, cz, wide * wide, span, dims, origin, cell, starts, mid,
                             buf)
    k = 0
    for c in range(n):
        slot = buf[c]
        own = reach + spread[slot]
        if is_candidate(slot, mid, cx, cy, cz, own * own):
            buf[k] = slot
            k += 1
    return buf, k


@numba.njit(cache=True, inline="always")
def capsule_entry_bound(slot: int, mid: FloatArray, half: FloatArray, e: FloatArray,
                        px: float, py: float, pz: float, dx: float, dy: float, dz: float,
                        radius: float) -> float:
    """A lower bound on where the line ``p + lam d`` enters the capsule in ``slot``.

    Every point ``x`` of the segment lies within ``h`` (its half length) of the midpoint
    ``m``, so its distance from the line is at least ``D = perp(m) - h`` and its ``t = (x -
    p) . d`` at least ``t(m) - |e . d| / 2``; the line enters the ball of radius ``R``
    about ``x`` no sooner than ``t - sqrt(R^2 - perp^2)``, hence no sooner than
    ``t(m) - |e . d| / 2 - sqrt(R^2 - max(D, 0)^2)``; ``inf`` when ``D >= R`` (a miss).
    Pieces (midpoints, half lengths, vectors ``e``) in the grid's order.
    """
    wx, wy, wz = mid[slot, 0] - px, mid[slot, 1] - py, mid[slot, 2] - pz
    t = wx * dx + wy * dy + wz * dz
    gap = math.sqrt(max(wx * wx + wy * wy + wz * wz - t * t, 0.0)) - half[slot]
    if gap >= radius:
        return math.inf
    room = radius * radius - (gap * gap if gap > 0.0 else 0.0)
    along = abs(e[slot, 0] * dx + e[slot, 1] * dy + e[slot, 2] * dz)
    return t - 0.5 * along - math.sqrt(room)


@numba.njit(cache=True, nogil=True)
def _walk(points: FloatArray, dirs: FloatArray, centres: FloatArray, lim2: FloatArray,
          spans: IntArray, dims: IntArray, origin: FloatArray, cell: float,
          starts: IntArray, order: IntArray,
          mid: FloatArray, half: FloatArray, a: FloatArray, e: FloatArray, ee: FloatArray,
          axis: FloatArray, radius: float, behind_cosine: float, lam: FloatArray,
          piece: IntArray, behind: NDArray[np.bool_], pairs: IntArray, row_lo: int,
          row_hi: int) -> None:
    # dexels row_lo .. row_hi - 1 (a slice of them in each thread, run_in_threads)
    # ``piece`` holds on entry the piece of a value given (``-1``: none), on exit the one
    # found
    # pieces (a, e, ee, axis) in the grid's order, read by slot; dexels in blocks, each
    # block's first piece tried the one that left least on the block's previous dexel;
    # within a block, groups of WALK_GROUP dexels walk the grid once (group_ball)
    r2 = radius * radius
    buf = np.empty(WALK_BLOCK, dtype=np.int64)
    shared = np.empty(WALK_BLOCK, dtype=np.int64)
    for block_start in range(row_lo, row_hi, WALK_BLOCK):
        n_shared = -1
        seed = -1
        stop = min(row_hi, block_start + WALK_BLOCK)
        for q in range(block_start, stop):
            shared, n_shared, buf, n = group_slots(q, block_start, stop, True, centres,
                                                   lim2, spans, dims, origin, cell, starts,
                                                   mid, shared, n_shared, buf)
            px, py, pz = points[q, 0], points[q, 1], points[q, 2]
            dx, dy, dz = dirs[q, 0], dirs[q, 1], dirs[q, 2]
            cx, cy, cz = centres[q, 0], centres[q, 1], centres[q, 2]
            best = lam[q]
            best_piece = piece[q]
            best_slot = -1
            best_behind = False
            first = -1
            if seed >= 0 and is_candidate(seed, mid, cx, cy, cz, lim2[q]):
                first = seed
            for c in range(-1, n):
                slot = first if c < 0 else buf[c]
                if slot < 0 or (c >= 0 and slot == first):
                    continue
                # of equal values the smallest piece index (ranks_before); the usual
                # drop (a bound beyond any tie) tested first, without the piece's index
                bound = capsule_entry_bound(slot, mid, half, e, px, py, pz, dx, dy, dz,
                                            radius)
                if bound >= best + ROUNDING_SLACK_MM and (
                        bound >= best + TIE_SLACK_MM or not bound < tie_limit(
                        best, order[slot], best_piece)):
                    continue
                index = order[slot]
                lam_in, lam_out = capsule_interval(
                    px, py, pz, dx, dy, dz, a[slot, 0], a[slot, 1], a[slot, 2], e[slot, 0],
                    e[slot, 1], e[slot, 2], ee[slot], r2)
                value, back = pair_value(lam_in, lam_out,
                                         axis[slot, 0] * dx + axis[slot, 1] * dy
                                         + axis[slot, 2] * dz, behind_cosine)
                if ranks_before(value, index, best, best_piece):
                    best, best_slot, best_piece, best_behind = value, slot, index, back
            seed = best_slot
            lam[q] = best
            piece[q] = order[best_slot] if best_slot >= 0 else -1
            behind[q] = best_behind
            pairs[q] = n


def walk_shape(grid: PieceGrid, span: int | IntArray, q: int) -> tuple[IntArray, IntArray]:
    """The spans of ``q`` dexels (one for all, or one each) and the grid's dims, as walked."""
    spans = np.ascontiguousarray(np.broadcast_to(np.asarray(span, dtype=np.int64), (q,)))
    return spans, np.asarray(grid.dims, dtype=np.int64)


def lowest_capsule_entries(grid: PieceGrid, span: int | IntArray, points: FloatArray,
                           dirs: FloatArray,
                           centres: FloatArray, reach_mm: FloatArray, sorted_mid: FloatArray,
                           sorted_half_mm: FloatArray, a: FloatArray, e: FloatArray, ee: FloatArray,
                           axis: FloatArray, radius_mm: float, behind_cosine: float, *,
                           below_mm: FloatArray | None = None,
                           below_piece: IntArray | None = None
                           ) -> tuple[FloatArray, IntArray, NDArray[np.bool_], int]:
    """Per dexel the lowest value among capsules within ``reach_mm`` of its centre.

    Of equal values the piece of smallest index (:func:`ranks_before`). With ``below_mm``
    (a value already known on each dexel, which the caller keeps where it is lower) only
    values below it are sought (or equal ones of a piece before ``below_piece``, its
    piece in the same numbering): a capsule whose bound on its entry is not below the
    best so far is skipped unmeasured, so a search for what another search missed meets
    few capsules.

    Parameters
    ----------
    grid : PieceGrid
        The pieces by cell.
    span : int or ndarray of int64, shape (q,)
        Cells searched on each side of a centre's cell (covers ``reach_mm``), one for all
        or one per dexel.
    points, dirs : ndarray, shape (q, 3)
        Dexel origins (mm) and unit directions.
    centres : ndarray, shape (q, 3)
        Search centres, mm.
    reach_mm : ndarray, shape (q,)
        A piece is a candidate when its midpoint lies within this of the centre, mm.
    sorted_mid, sorted_half_mm : ndarray, shapes (n, 3), (n,)
        The pieces' midpoints and half lengths (mm) in the grid's order
        (``mid[grid.order]``: read in the order the walk meets them).
    a, e, ee, axis : ndarray
        The pieces' starts, vectors, squared lengths and axes
        (:class:`~verification.pieces.Pieces`), in the grid's order too.
    radius_mm : float
        Capsule radius, mm.
    behind_cosine : float
        ``a . d`` below which a piece comes from behind.
    below_mm : ndarray, shape (q,), optional
        Seek only values below these, mm (default: all).
    below_piece : ndarray of int64, shape (q,), optional
        The pieces of ``below_mm`` (``-1``: none, only less is sought).

    Returns
    -------
    lam : ndarray, shape (q,)
        Lowest value, mm (``inf``: no candidate reached the design point, or none
        ranking before ``below_mm``).
    piece : ndarray of int64
        Its piece (``-1`` where none).
    behind : ndarray of bool
        It came from behind.
    pairs : int
        Candidate pairs met.
    """
    q = points.shape[0]
    lam = np.full(q, np.inf)
    if below_mm is not None:
        lam[:] = below_mm
    piece = np.full(q, -1, dtype=np.int64)
    if below_mm is not None and below_piece is not None:
        piece[:] = below_piece
    behind = np.zeros(q, dtype=np.bool_)
    pairs = np.zeros(q, dtype=np.int64)
    if q == 0 or grid.n_pieces == 0:
        return np.full(q, np.inf), np.full(q, -1, dtype=np.int64), behind, 0
    spans, dims = walk_shape(grid, span, q)
    f = np.ascontiguousarray
    run_in_threads(_walk, q, f(points, dtype=float), f(dirs, dtype=float),
                   f(centres, dtype=float), f(reach_mm * reach_mm, dtype=float), spans, dims,
                   f(grid.origin_mm, dtype=float), float(grid.cell_mm), grid.starts,
                   grid.order, f(sorted_mid), f(sorted_half_mm), f(a), f(e), f(ee), f(axis),
                   float(radius_mm), float(behind_cosine), lam, piece, behind, pairs,
                   min_rows=WALK_TASK, dynamic=True)
    lam[piece < 0] = np.inf
    return lam, piece, behind, int(pairs.sum())
