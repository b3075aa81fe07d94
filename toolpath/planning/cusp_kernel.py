"""Where two passes' ball tubes meet near a seed: the compiled part of the cusp estimate.

For each seed (a ball centre ``P`` over a contact, its pass, the surface's ``X_s``) and the
pieces near it (centre segments whose midpoints lie within a reach of ``P``, met on the spot
in the cells of a grid that reach meets, as :func:`~.clearance_kernel.pairs_within` finds
them, no list of pairs built), :func:`ridges` takes
the nearest segment of the seed's own pass and the nearest of another pass on the ``+s``
side, and returns where their tubes of radius ``R`` meet nearest the surface, and how deep
that point lies inside the tubes of a third pass's pieces and of the two passes' other
pieces (see
:func:`toolpath.planning.cusp_estimates.ball_cusp_estimates` for the geometry).
:func:`next_pieces` finds the next pass's piece for a flat or bull-nose cutter, whose
ring-centre segments stand aside from the contact (:mod:`.torus_profile` meets them).
:func:`path_curving` gives how tightly the centre path curves round pieces (the estimate's
sink rule).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from ..row_threads import run_in_threads
from .clearance_kernel import BLOCK, SampleCells, cell_scratch_size, cells_near

__all__ = ["RIDGE_FOUND", "RIDGE_NO_LENGTH", "RIDGE_NO_PASS", "RIDGE_OPEN", "next_pieces",
           "path_curving", "ridges"]

RIDGE_FOUND = 1  #: the tubes meet: ``point`` and ``inside`` hold the ridge
RIDGE_NO_PASS = 0  #: no other pass on the ``+s`` side among the pieces given
RIDGE_NO_LENGTH = -1  #: the own segment has no length (no direction across)
RIDGE_OPEN = 2  #: the tubes do not meet: material between the passes


class Seeds(NamedTuple):
    """The seeds of :func:`ridges` as its compiled loop takes them (see there)."""

    centre: NDArray[np.float64]
    normal: NDArray[np.float64]
    x_s: NDArray[np.float64]
    own: NDArray[np.int64]


class Pieces(NamedTuple):
    """The pieces of :func:`ridges`: starts ``a``, vectors ``e`` (mm) and their passes."""

    a: NDArray[np.float64]
    e: NDArray[np.float64]
    pass_of: NDArray[np.int64]


class Ridges(NamedTuple):
    """What :func:`ridges` returns, filled in place by its compiled loop (see there)."""

    point: NDArray[np.float64]
    inside: NDArray[np.float64]
    state: NDArray[np.int64]
    pieces: NDArray[np.int64]


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _foot(px, py, pz, a, e, j):
    """The point of piece ``j`` (``a[j] + f e[j]``, ``0 <= f <= 1``) nearest to ``P``.

    (This and :func:`_near` are compiled once each, not inlined by numba: numba compiled
    an inlined copy at each of their call sites, slower to compile on a cold start.)
    """
    ee = e[j, 0] * e[j, 0] + e[j, 1] * e[j, 1] + e[j, 2] * e[j, 2]
    f = ((px - a[j, 0]) * e[j, 0] + (py - a[j, 1]) * e[j, 1] + (pz - a[j, 2]) * e[j, 2])
    f = min(max(f / ee, 0.0), 1.0) if ee > 0.0 else 0.0
    return a[j, 0] + f * e[j, 0], a[j, 1] + f * e[j, 1], a[j, 2] + f * e[j, 2]


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _near(points, jj, px, py, pz, reach):
    """Whether binned midpoint ``jj`` lies within ``reach`` of ``P``."""
    d0, d1, d2 = points[jj, 0] - px, points[jj, 1] - py, points[jj, 2] - pz
    return d0 * d0 + d1 * d1 + d2 * d2 <= reach * reach


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _near_pieces(px, py, pz, reach, binned, cells, n_cells, near):
    """The pieces whose binned midpoints lie within ``reach`` of ``P``, into ``near``; how many.

    In the order :func:`_near` meets them cell by cell (the first of equally near pieces
    wins in :func:`_ridges`). Each visited piece is written, and the count steps on only
    where it lies within reach: no branch a seed's visited midpoints (about 4 in 5 out of
    reach on the dev blade) would mispredict. ``near`` holds room for every piece the
    cells hold.
    """
    points, index, cell_start = binned[0], binned[1], binned[2]
    n_near = 0
    for m in range(n_cells):
        for jj in range(cell_start[cells[m]], cell_start[cells[m] + 1]):
            near[n_near] = index[jj]
            n_near += _near(points, jj, px, py, pz, reach)
    return n_near


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _gather(near, n_near, a, e, seg):
    """Rows ``a_x, a_y, a_z, e_x, e_y, e_z`` of the pieces ``near[:n_near]``, into ``seg``."""
    for k in range(n_near):
        j = near[k]
        seg[0, k], seg[1, k], seg[2, k] = a[j, 0], a[j, 1], a[j, 2]
        seg[3, k], seg[4, k], seg[5, k] = e[j, 0], e[j, 1], e[j, 2]


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _distances(px, py, pz, seg, n_near, s0, s1, s2, dist, ahead):
    """Distance from ``P`` to each gathered piece and how far its foot lies along ``s``.

    ``dist[k] = |F - P|``, ``ahead[k] = (F - P) . s`` for the foot ``F`` of :func:`_foot`
    on piece ``k`` of ``seg`` (:func:`_gather`): the same arithmetic, so the same values
    (IEEE division and square root, no fused multiply-add). A straight loop over
    contiguous rows, which the compiler takes several pieces at a time.
    """
    for k in range(n_near):
        a0, a1, a2 = seg[0, k], seg[1, k], seg[2, k]
        e0, e1, e2 = seg[3, k], seg[4, k], seg[5, k]
        ee = e0 * e0 + e1 * e1 + e2 * e2
        f = ((px - a0) * e0 + (py - a1) * e1 + (pz - a2) * e2)
        f = min(max(f / ee, 0.0), 1.0) if ee > 0.0 else 0.0
        w0, w1, w2 = (a0 + f * e0) - px, (a1 + f * e1) - py, (a2 + f * e2) - pz
        dist[k] = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        ahead[k] = w0 * s0 + w1 * s1 + w2 * s2


@numba.njit(cache=True, nogil=True)
def _ridges(seeds, binned, reach, scratch_size, room, pieces, radius, out, lo, hi):
    """The loop of :func:`ridges` for seeds ``lo .. hi - 1`` (slices of them in threads).

    ``seeds`` (:class:`Seeds`), the pieces' midpoints binned
    (:class:`~.clearance_kernel.SampleCells`), ``pieces`` (:class:`Pieces`), into ``out``
    (:class:`Ridges`). One pass over the cells near a seed lists the pieces within
    ``reach`` (at most ``room``, :func:`_near_pieces`) and gathers them
    (:func:`_gather`); their distances from ``P`` (:func:`_distances`) give the nearest of
    each side (the first met of equally near ones), their distances from the ridge the
    depths. (Met one at a time, the pieces' feet computed as each was found, the loop took
    about 30% more CPU on the dev blade's 5-axis seeds, the same results.)
    """
    centre, normal, x_s, own = seeds
    _, _, _, origin, shape, cell, box, _ = binned
    a, e, pass_of = pieces
    point, inside, state, found = out
    cells = np.empty(scratch_size, dtype=np.int64)
    near = np.empty(room, dtype=np.int64)
    seg = np.empty((6, room))
    dist = np.empty(room)
    ahead = np.empty(room)
    for i in range(lo, hi):
        px, py, pz = centre[i, 0], centre[i, 1], centre[i, 2]
        n_cells = cells_near(px, py, pz, reach, origin, shape, cell, box, cells)
        n_near = _near_pieces(px, py, pz, reach, binned, cells, n_cells, near)
        _gather(near, n_near, a, e, seg)
        _distances(px, py, pz, seg, n_near, x_s[i, 0], x_s[i, 1], x_s[i, 2], dist, ahead)
        d_own, d_other = math.inf, math.inf
        j_own, j_other = -1, -1
        for k in range(n_near):
            if pass_of[near[k]] == own[i]:
                if dist[k] < d_own:
                    d_own, j_own = dist[k], near[k]
            elif ahead[k] > 0.0 and dist[k] < d_other:
                d_other, j_other = dist[k], near[k]
        found[i, 0] = j_own
        found[i, 1] = j_other
        if j_own < 0 or j_other < 0:
            state[i] = RIDGE_NO_PASS
            continue
        o0, o1, o2 = _foot(px, py, pz, a, e, j_own)
        q0, q1, q2 = _foot(px, py, pz, a, e, j_other)
        u0, u1, u2 = e[j_own, 0], e[j_own, 1], e[j_own, 2]
        length = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
        if length <= 0.0:
            state[i] = RIDGE_NO_LENGTH
            continue
        u0, u1, u2 = u0 / length, u1 / length, u2 / length
        d0, d1, d2 = q0 - o0, q1 - o1, q2 - o2
        along = d0 * u0 + d1 * u1 + d2 * u2
        c0, c1, c2 = d0 - along * u0, d1 - along * u1, d2 - along * u2  # across
        half = 0.5 * math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        v0, v1, v2 = u1 * c2 - u2 * c1, u2 * c0 - u0 * c2, u0 * c1 - u1 * c0
        v_len = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        if v_len <= 0.0:
            state[i] = RIDGE_NO_LENGTH
            continue
        if half >= radius:
            state[i] = RIDGE_OPEN
            continue
        up = v0 * normal[i, 0] + v1 * normal[i, 1] + v2 * normal[i, 2]
        drop = math.sqrt(radius * radius - half * half) * (1.0 if up >= 0.0 else -1.0) / v_len
        x0 = o0 + 0.5 * c0 - drop * v0
        x1 = o1 + 0.5 * c1 - drop * v1
        x2 = o2 + 0.5 * c2 - drop * v2
        third = 0.0
        two = 0.0
        _distances(x0, x1, x2, seg, n_near, 0.0, 0.0, 0.0, dist, ahead)
        for k in range(n_near):
            j = near[k]
            depth = radius - dist[k]
            if pass_of[j] == own[i] or pass_of[j] == pass_of[j_other]:
                two = max(two, depth)
            else:
                third = max(third, depth)
        point[i, 0], point[i, 1], point[i, 2] = x0, x1, x2
        inside[i, 0] = third
        inside[i, 1] = two
        state[i] = RIDGE_FOUND


def ridges(centre: NDArray[np.float64], normal: NDArray[np.float64], x_s: NDArray[np.float64],
           own: NDArray[np.int64], cells: SampleCells, reach_mm: float, a: NDArray[np.float64],
           e: NDArray[np.float64], pass_of: NDArray[np.int64], radius_mm: float
           ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64],
                      NDArray[np.int64]]:
    """Ridge points, their depth inside other tubes (mm, >= 0), a state and the two pieces.

    Parameters
    ----------
    centre, normal, x_s : ndarray, shape (m, 3)
        ``P = Q + R n`` (mm), the unit normal ``n`` and ``X_s`` at each seed.
    own : ndarray of int64, shape (m,)
        The seed's pass.
    cells : SampleCells
        The pieces' midpoints, binned (:func:`~.clearance_kernel.bin_samples`).
    reach_mm : float
        The pieces whose midpoints lie within this distance of ``P`` are met.
    a, e : ndarray, shape (p, 3)
        Piece starts and vectors (ball centres), mm.
    pass_of : ndarray of int64, shape (p,)
        Pass of each piece.
    radius_mm : float
        Ball radius ``R``, mm.

    Returns
    -------
    point : ndarray, shape (m, 3)
        Where the tubes meet nearest the surface (valid where ``state`` is
        :data:`RIDGE_FOUND`), mm.
    inside : ndarray, shape (m, 2)
        How deep it lies inside the deepest tube of the met pieces of other passes than
        the two, and of the two passes' other pieces, mm (>= 0).
    state : ndarray of int64, shape (m,)
        :data:`RIDGE_FOUND`, :data:`RIDGE_NO_PASS`, :data:`RIDGE_NO_LENGTH` or
        :data:`RIDGE_OPEN`.
    pieces : ndarray of int64, shape (m, 2)
        The nearest piece of the own pass and of the other pass on the ``+s`` side whose
        tubes meet there (-1: none met).
    """
    m = centre.shape[0]
    point = np.zeros((m, 3))
    inside = np.zeros((m, 2))
    state = np.zeros(m, dtype=np.int64)
    found = np.full((m, 2), -1, dtype=np.int64)
    if m:
        f = np.ascontiguousarray
        seeds = Seeds(f(centre, dtype=float), f(normal, dtype=float), f(x_s, dtype=float),
                      f(own, dtype=np.int64))
        pieces = Pieces(f(a, dtype=float), f(e, dtype=float), f(pass_of, dtype=np.int64))
        scratch = cell_scratch_size(reach_mm, cells.cell_mm)
        # room for the pieces of the fullest cells a seed can meet
        room = min(len(cells.index), scratch * int(np.diff(cells.cell_start).max()))
        run_in_threads(_ridges, m, seeds, cells, float(reach_mm), scratch, room, pieces,
                       float(radius_mm), Ridges(point, inside, state, found))
    return point, inside, state, found


@numba.njit(cache=True, parallel=True)
def _next_pieces(foot, x_s, own, binned, reach, apart, scratch_size, pieces, found):
    """The loop of :func:`next_pieces`, blocks of seeds in parallel (see there)."""
    points, index, cell_start, origin, shape, cell, box, _ = binned
    a, e, pass_of = pieces
    for block in numba.prange((foot.shape[0] + BLOCK - 1) // BLOCK):
        cells = np.empty(scratch_size, dtype=np.int64)
        for i in range(block * BLOCK, min((block + 1) * BLOCK, foot.shape[0])):
            o0, o1, o2 = foot[i, 0], foot[i, 1], foot[i, 2]
            n_cells = cells_near(o0, o1, o2, reach, origin, shape, cell, box, cells)
            d_other = apart
            for m in range(n_cells):
                for jj in range(cell_start[cells[m]], cell_start[cells[m] + 1]):
                    j = index[jj]
                    if pass_of[j] == own[i] or not _near(points, jj, o0, o1, o2, reach):
                        continue
                    f0, f1, f2 = _foot(o0, o1, o2, a, e, j)
                    w0, w1, w2 = f0 - o0, f1 - o1, f2 - o2
                    dist = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
                    if (w0 * x_s[i, 0] + w1 * x_s[i, 1] + w2 * x_s[i, 2] > 0.0
                            and dist <= d_other):
                        d_other, found[i] = dist, j


def next_pieces(foot: NDArray[np.float64], x_s: NDArray[np.float64], own: NDArray[np.int64],
                cells: SampleCells, apart_mm: float, a: NDArray[np.float64],
                e: NDArray[np.float64], pass_of: NDArray[np.int64]) -> NDArray[np.int64]:
    """The next pass's piece per seed, for a flat or bull-nose cutter.

    A piece is the segment ``a + f e`` (``0 <= f <= 1``) its ring centre (the axis point
    ``r`` above the tip) sweeps. ``foot`` is ``C1``, the point of the seed's own pass's
    piece nearest its ring centre (:func:`~.cusp_estimates.torus_cusp_bounds`): the next
    pass's is the piece of another pass nearest to ``C1`` (within ``apart_mm``) on the
    ``+s`` side (``(C2 - C1) . X_s > 0``): the ring centres of two neighbouring poses
    stand as far apart as their contacts.

    Parameters
    ----------
    foot, x_s : ndarray, shape (m, 3)
        ``C1`` (mm) and ``X_s`` at each seed.
    own : ndarray of int64, shape (m,)
        The seed's pass.
    cells : SampleCells
        The pieces' midpoints, binned (:func:`~.clearance_kernel.bin_samples`).
    apart_mm : float
        How far the pieces are sought, mm.
    a, e : ndarray, shape (p, 3)
        Piece starts and vectors, mm.
    pass_of : ndarray of int64, shape (p,)
        Pass of each piece.

    Returns
    -------
    ndarray of int64, shape (m,)
        The next pass's piece (-1: none within reach).
    """
    m = foot.shape[0]
    found = np.full(m, -1, dtype=np.int64)
    if m and len(cells.index):
        f = np.ascontiguousarray
        pieces = Pieces(f(a, dtype=float), f(e, dtype=float), f(pass_of, dtype=np.int64))
        # midpoints within half a piece of the segments
        reach = float(apart_mm) + 0.5 * float(np.sqrt((e * e).sum(axis=1)).max())
        scratch = cell_scratch_size(reach, cells.cell_mm)
        _next_pieces(f(foot, dtype=float), f(x_s, dtype=float), f(own, dtype=np.int64),
                     cells, reach, float(apart_mm), scratch, pieces, found)
    return found


@numba.njit(cache=True)
def _path_curving(piece, e, length, mid, first, last, half_span, tiny, out):
    """The loop of :func:`path_curving`.

    The neighbours are walked to from the piece (``mid`` rises along the path: the first
    piece whose midpoint lies at or beyond ``mid[i] -+ half_span``, as an ordered search
    over all of them finds it, kept within the pass): a few pieces each way.
    """
    for k in range(piece.size):
        i = piece[k]
        run = np.searchsorted(first, i, side="right") - 1
        lo, hi = first[run], last[run]
        safe_i = length[i] if length[i] > 0.0 else 1.0
        w0, w1, w2 = e[i, 0] / safe_i, e[i, 1] / safe_i, e[i, 2] / safe_i
        at = mid[i]
        curving = 0.0
        for side in range(2):
            near = i
            if side == 0:  # the first at or beyond at - half_span, at least lo
                value = at - half_span
                while near > lo and mid[near - 1] >= value:
                    near -= 1
            else:  # the first at or beyond at + half_span (past i), at most hi
                value = at + half_span
                near = i + 1
                while near <= hi and mid[near] < value:
                    near += 1
                near = min(near, hi)
            if near == i:  # (a pass's end: no neighbour that side, no turn)
                continue
            safe = length[near] if length[near] > 0.0 else 1.0
            cos = (w0 * e[near, 0] + w1 * e[near, 1] + w2 * e[near, 2]) / safe
            turn = math.acos(min(max(cos, -1.0), 1.0))
            curving = max(curving, turn / max(abs(mid[near] - at), tiny))
        out[k] = curving


def path_curving(piece: NDArray[np.int64], e: NDArray[np.float64],
                 pass_of: NDArray[np.int64], span_mm: float, tiny: float
                 ) -> NDArray[np.float64]:
    """Mean curvature of the centre path over ``span_mm`` round each of the pieces ``piece``, 1/mm.

    Pieces of vectors ``e`` (mm) run on in order, pass after pass (``pass_of``). From a
    piece to its pass's piece whose midpoint lies ``span_mm / 2`` before and after its own
    along the path (the first at or beyond it, the pass's first or last piece at most):
    the turn between the two pieces' directions over the length between their midpoints
    (``tiny`` at least), the larger of the two sides; a pass's end piece has no neighbour
    beyond the end (no turn that side). (A zero-length piece has no direction: its turn
    reads 90 degrees.)

    A piece asked more than once (the cusp estimate asks each seed's two pieces: about
    half of them twice or more, neighbouring seeds meeting the same pieces) is walked
    from once, the pieces asked in path order; each answer is that piece's.
    """
    if not span_mm > 0.0:
        raise ValueError(f"the span of the path's curving must be > 0 mm, got {span_mm!r}")
    piece = np.asarray(piece, dtype=np.int64)
    if not piece.size:
        return np.empty(0)
    length = np.sqrt(np.einsum("ij,ij->i", e, e))
    # each pass's first and last piece
    new_pass = np.flatnonzero(np.diff(pass_of)) + 1
    first = np.concatenate([[0], new_pass]).astype(np.int64)
    last = (np.concatenate([new_pass, [len(e)]]) - 1).astype(np.int64)
    mid = np.cumsum(length) - 0.5 * length  # along the path, mm
    asked = np.zeros(len(e), dtype=bool)
    asked[piece] = True
    each = np.flatnonzero(asked)  # every piece asked, once, in path order
    curving = np.empty(len(each))
    _path_curving(each, np.ascontiguousarray(e, dtype=float), length, mid, first, last,
                  0.5 * float(span_mm), float(tiny), curving)
    by_piece = np.empty(len(e))  # (read only at the pieces asked)
    by_piece[each] = curving
    return by_piece[piece]
