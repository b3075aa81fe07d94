"""Compiled neighbour searches over binned points.

The points (surface samples for the global gouge check, :func:`.gouge.global_clearance`;
the centres of a toolpath's pieces for the measurement, :func:`pairs_within`) are binned
in a uniform grid of cubic cells, sorted by cell (``cell_start[c] .. cell_start[c + 1]``
are the points of cell ``c``). A query sphere is compared with the cells its bounding box
overlaps, those it misses are skipped.

The gouge check's query is a capsule: the points within ``reach`` of a segment of the
tool axis, which holds the whole cutter. Its cells are found column by column (a column:
the cells of one ``x, y``), the segment clipped to each slab it crosses (``y``, then
``x``, then the column's occupied cells in ``z``), so a blade's thin sheet of samples is
met in the few cells it occupies whatever the axis' direction. For every sample inside,
the exact signed distance of the cutter solid (:func:`.cutter_kernel.cutter_distance`) is
taken on the spot, so no list of pairs is ever built; each location keeps its smallest
value among the samples near its contact and among the others.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from ..row_threads import run_in_threads
from .cutter_kernel import cutter_distance

__all__ = ["BLOCK", "Capsule", "Cutter", "SampleCells", "bin_samples",
           "cell_scratch_size", "clearances", "counts_within", "nearest_within",
           "pair_batches", "pairs_within", "points_box"]

#: Cells at most in the grid (the cell grows past the query radius beyond this).
MAX_CELLS = 4_000_000
#: The grid's box grows by this (mm) on each side, so samples on its faces fall inside a
#: cell whatever the round-off of ``(p - origin) / cell``.
_BOX_PAD_MM = 1e-9
#: Least cell size (mm): a reach of 0 would give cells of no size (a division by zero).
_LEAST_CELL_MM = 1e-9


class SampleCells(NamedTuple):
    """Samples sorted by grid cell (a named tuple: the compiled loops take it whole).

    Attributes
    ----------
    points : ndarray, shape (n, 3)
        The samples in cell order, mm.
    index : ndarray of int, shape (n,)
        Their indices in the original sample array.
    cell_start : ndarray of int, shape (n_cells + 1,)
        Where each cell's samples begin in ``points``.
    origin : ndarray, shape (3,)
        Corner of cell ``(0, 0, 0)``, mm.
    shape : ndarray of int, shape (3,)
        Cells along x, y, z.
    cell_mm : float
        Edge of a cell, mm.
    box : ndarray, shape (n_cells, 6)
        The bounding box of each cell's samples (``lo``, ``hi``; ``+inf``, ``-inf`` when
        empty): a sheet of samples fills a thin part of its cells, and a query (sphere
        or capsule) that misses it skips the cell.
    column : ndarray of int, shape (shape[0] * shape[1], 2)
        The lowest and highest ``z`` index of a cell holding samples in each column
        (``x + shape[0] * y``; ``1, 0`` when empty).
    """

    points: NDArray[np.float64]
    index: NDArray[np.int64]
    cell_start: NDArray[np.int64]
    origin: NDArray[np.float64]
    shape: NDArray[np.int64]
    cell_mm: float
    box: NDArray[np.float64]
    column: NDArray[np.int64]


class Capsule(NamedTuple):
    """The gouge check's query around each tool axis (:func:`clearances`).

    The samples within ``sqrt(reach2)`` (mm) of the axis from ``low`` to ``high`` (mm)
    above the tip; near (of the contact) within ``sqrt(near2)``, every one without
    contacts (``has_contacts`` false).
    """

    low: float
    high: float
    reach: float
    reach2: float
    near2: float
    has_contacts: bool


class Cutter(NamedTuple):
    """The cutter of :func:`.cutter_kernel.cutter_distance`: corner radius, radius, flute (mm)."""

    corner: float
    radius: float
    flute: float


def bin_samples(points_mm: NDArray[np.float64], reach_mm: float) -> SampleCells:
    """Bin samples in cells of edge ``reach_mm`` (the largest query radius).

    A query sphere then overlaps at most 3 x 3 x 3 cells, a capsule a few across its axis
    (finer cells, or cells a fifth larger, cost more in cell visits than they save in
    samples on a blade's thin sheet of samples). ValueError naming the first sample that
    is not finite.
    """
    points = np.ascontiguousarray(points_mm, dtype=float).reshape(-1, 3)
    # (checked over the whole array: numpy's ``all(axis=1)`` of an (n, 3) array runs
    # twenty times slower; the sample is looked for only when one is not finite)
    if not np.isfinite(points).all():  # (binned, it would index cells out of bounds)
        bad = int(np.argmin(np.isfinite(points).all(axis=1)))
        raise ValueError(f"sample {bad} of {len(points)} is not finite ({points[bad].tolist()}): "
                         "only finite points can be binned")
    if not len(points):  # nothing to find: one empty cell
        return SampleCells(points=points, index=np.zeros(0, dtype=np.int64),
                           cell_start=np.zeros(2, dtype=np.int64), origin=np.zeros(3),
                           shape=np.ones(3, dtype=np.int64),
                           cell_mm=max(float(reach_mm), _LEAST_CELL_MM),
                           box=np.array([[np.inf] * 3 + [-np.inf] * 3]),
                           column=np.array([[1, 0]], dtype=np.int64))
    lo, hi = points_box(points)
    lo = lo - _BOX_PAD_MM
    extent = hi + _BOX_PAD_MM - lo
    cell = max(float(reach_mm), _LEAST_CELL_MM)
    while np.prod(np.floor(extent / cell) + 1.0) > MAX_CELLS:
        cell *= 1.5
    shape = (np.floor(extent / cell) + 1).astype(np.int64)
    order = np.empty(len(points), dtype=np.int64)
    binned = np.empty_like(points)
    start = np.zeros(int(np.prod(shape)) + 1, dtype=np.int64)
    _counting_sort(points, lo, cell, shape, order, start, binned)
    box = np.empty((start.size - 1, 6))
    _cell_boxes(binned, start, box)
    column = np.empty((int(shape[0] * shape[1]), 2), dtype=np.int64)
    _column_ranges(start, shape, column)
    return SampleCells(points=binned, index=order, cell_start=start, origin=lo, shape=shape,
                       cell_mm=cell, box=box, column=column)


@numba.njit(cache=True)
def _column_ranges(start, shape, column):
    """Each column's lowest and highest occupied ``z`` index (``1, 0``: none)."""
    n_col = shape[0] * shape[1]
    for col in range(n_col):
        column[col, 0], column[col, 1] = 1, 0
        for cz in range(shape[2]):
            cid = col + n_col * cz
            if start[cid + 1] > start[cid]:
                if column[col, 0] > column[col, 1]:
                    column[col, 0] = cz
                column[col, 1] = cz


@numba.njit(cache=True)
def _cell_boxes(points, start, box):
    """Each cell's samples' bounding box (empty: ``+inf``, ``-inf``)."""
    for cid in range(start.size - 1):
        for k in range(3):
            box[cid, k] = np.inf
            box[cid, 3 + k] = -np.inf
        for j in range(start[cid], start[cid + 1]):
            for k in range(3):
                box[cid, k] = min(box[cid, k], points[j, k])
                box[cid, 3 + k] = max(box[cid, 3 + k], points[j, k])


def points_box(points_mm: NDArray[np.float64]) -> tuple[NDArray[np.float64],
                                                        NDArray[np.float64]]:
    """The smallest and largest coordinates of ``(n, 3)`` points (``+-inf`` for none).

    Compiled (:func:`_cell_boxes` over one cell of them all): numpy's ``min(axis=0)`` of
    an ``(n, 3)`` array runs ten times slower.
    """
    points = np.ascontiguousarray(points_mm, dtype=float).reshape(-1, 3)
    box = np.empty((1, 6))
    _cell_boxes(points, np.array([0, len(points)]), box)
    return box[0, :3], box[0, 3:]


@numba.njit(cache=True)
def _counting_sort(points, origin, cell, shape, order, start, binned):
    """``order``: the points sorted by cell (stable); ``start``: where each cell begins.

    ``binned``: the points in that order.
    """
    n = points.shape[0]
    cell_id = np.empty(n, dtype=np.int64)
    for i in range(n):
        c = 0
        for k in range(2, -1, -1):
            j = min(int((points[i, k] - origin[k]) / cell), shape[k] - 1)
            c = c * shape[k] + j
        cell_id[i] = c
        start[c + 1] += 1
    for c in range(1, start.size):
        start[c] += start[c - 1]
    fill = start[:-1].copy()
    for i in range(n):
        at = fill[cell_id[i]]
        order[at] = i
        binned[at, 0], binned[at, 1], binned[at, 2] = points[i, 0], points[i, 1], points[i, 2]
        fill[cell_id[i]] += 1


def clearances(cells: SampleCells, tips_mm: NDArray[np.float64], axes: NDArray[np.float64],
               contacts_mm: NDArray[np.float64] | None, low_mm: float, high_mm: float,
               reach_mm: float, corner_mm: float, radius_mm: float, flute_mm: float,
               near_radius_mm: float
               ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64],
                          NDArray[np.int64]]:
    """Smallest signed distance per location: ``near, far`` (``inf`` if none) and samples.

    The samples within ``reach_mm`` of the axis segment from ``low_mm`` to ``high_mm``
    above each tip (a capsule) get the cutter's signed distance (corner radius, radius and
    flute length ``corner_mm, radius_mm, flute_mm``); a sample within ``near_radius_mm``
    of the location's contact (every sample without contacts) counts as near. ``cells``
    binned for ``reach_mm``: the capsule meets a few cells across.
    """
    n = len(tips_mm)
    near = np.full(n, np.inf)
    far = np.full(n, np.inf)
    near_i = np.full(n, -1, dtype=np.int64)
    far_i = np.full(n, -1, dtype=np.int64)
    has_contacts = contacts_mm is not None
    contacts = np.ascontiguousarray(tips_mm if contacts_mm is None else contacts_mm,
                                    dtype=float)
    capsule = Capsule(float(low_mm), float(max(high_mm, low_mm)), float(reach_mm),
                      float(reach_mm) * float(reach_mm), float(near_radius_mm * near_radius_mm),
                      has_contacts)
    run_in_threads(_clearance_rows, n, cells, np.ascontiguousarray(tips_mm, dtype=float),
                   np.ascontiguousarray(axes, dtype=float), contacts, capsule,
                   Cutter(float(corner_mm), float(radius_mm), float(flute_mm)), near, far,
                   near_i, far_i)
    return near, far, near_i, far_i


# (the kernel-only helpers here are calls, not inlined by numba (``inline="always"``):
# inlined, _clearance_rows and the points search took about 1 CPU s more to compile, issue 27)
@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _gap(x, lo, size):
    """Distance from ``x`` to the interval ``[lo, lo + size]``."""
    if x < lo:
        return lo - x
    if x > lo + size:
        return x - lo - size
    return 0.0


# (kernel-only, not exported: no Python wrapper, so a call from Python crashes the process)
@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def cells_near(c0, c1, c2, radius, origin, shape, cell, box, out):
    """The cells a sphere meets, into ``out``; how many.

    The cells its bounding box overlaps, less those farther than ``radius`` from ``c``
    and those whose samples' box is (so empty ones too).
    """
    nx, ny, nz = shape[0], shape[1], shape[2]
    x_lo = max(math.floor((c0 - radius - origin[0]) / cell), 0)
    x_hi = min(math.floor((c0 + radius - origin[0]) / cell) + 1, nx)
    y_lo = max(math.floor((c1 - radius - origin[1]) / cell), 0)
    y_hi = min(math.floor((c1 + radius - origin[1]) / cell) + 1, ny)
    z_lo = max(math.floor((c2 - radius - origin[2]) / cell), 0)
    z_hi = min(math.floor((c2 + radius - origin[2]) / cell) + 1, nz)
    count = 0
    for cz in range(z_lo, z_hi):
        gz = _gap(c2, origin[2] + cz * cell, cell)
        for cy in range(y_lo, y_hi):
            gy = _gap(c1, origin[1] + cy * cell, cell)
            for cx in range(x_lo, x_hi):
                gx = _gap(c0, origin[0] + cx * cell, cell)
                if gx * gx + gy * gy + gz * gz > radius * radius:
                    continue
                cid = cx + nx * (cy + ny * cz)
                bx = _span_gap(c0, box[cid, 0], box[cid, 3])
                by = _span_gap(c1, box[cid, 1], box[cid, 4])
                bz = _span_gap(c2, box[cid, 2], box[cid, 5])
                if bx * bx + by * by + bz * bz <= radius * radius:
                    out[count] = cid
                    count += 1
    return count


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _span_gap(x, lo, hi):
    """Distance from ``x`` to ``[lo, hi]`` (``inf`` for an empty span, ``lo > hi``)."""
    if lo > hi:
        return np.inf
    if x < lo:
        return lo - x
    if x > hi:
        return x - hi
    return 0.0


def cell_scratch_size(radius_mm: float, cell_mm: float) -> int:
    """Room for the cells a sphere of ``radius_mm`` can meet."""
    side = int(2.0 * radius_mm / cell_mm) + 3
    return side * side * side


#: Locations per block of the parallel loops.
BLOCK = 256


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _clip(start, step, lo, hi, u0, u1):
    """``[u0, u1]`` narrowed to where ``start + u step`` lies in ``[lo, hi]``.

    An empty range comes back with ``u0 > u1``.
    """
    if step == 0.0:
        if start < lo or start > hi:
            return 1.0, 0.0
        return u0, u1
    a = (lo - start) / step
    b = (hi - start) / step
    if a > b:
        a, b = b, a
    return max(u0, a), min(u1, b)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _box_distance(p0, p1, p2, d0, d1, d2, u, box, cid):
    """Distance from ``p + u d`` to cell ``cid``'s box, and its derivative in ``u``."""
    e0 = p0 + u * d0
    e1 = p1 + u * d1
    e2 = p2 + u * d2
    e0 -= min(max(e0, box[cid, 0]), box[cid, 3])
    e1 -= min(max(e1, box[cid, 1]), box[cid, 4])
    e2 -= min(max(e2, box[cid, 2]), box[cid, 5])
    size = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    if size == 0.0:
        return 0.0, 0.0
    return size, (e0 * d0 + e1 * d1 + e2 * d2) / size


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _box_bound(p0, p1, p2, d0, d1, d2, w0, w1, box, cid):
    """A lower bound of the distance from cell ``cid``'s box to ``p + u d``, ``w0 <= u <= w1``.

    The distance to a convex set is convex along a line and lies above its tangents: the
    bound is ``f(w0)`` where ``f`` rises from ``w0``, ``f(w1)`` where it falls to ``w1``,
    else where the tangents at both ends meet.
    """
    f0, g0 = _box_distance(p0, p1, p2, d0, d1, d2, w0, box, cid)
    if g0 >= 0.0:
        return f0
    f1, g1 = _box_distance(p0, p1, p2, d0, d1, d2, w1, box, cid)
    if g1 <= 0.0:
        return f1
    return f0 + g0 * ((f1 - f0 + g0 * w0 - g1 * w1) / (g0 - g1) - w0)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _index_range(x0, x1, pad, origin, cell, n):
    """The cells ``lo .. hi - 1`` (within ``0 .. n``) meeting ``[x0, x1]`` widened by ``pad``.

    ``x0, x1`` in either order.
    """
    lo, hi = min(x0, x1) - pad, max(x0, x1) + pad
    return (max(math.floor((lo - origin) / cell), 0),
            min(math.floor((hi - origin) / cell) + 1, n))


@numba.njit(cache=True, nogil=True)
def _clearance_rows(binned, tips, axes, contacts, capsule, cutter, near, far, near_i, far_i,
                    lo, hi):
    """The loop of :func:`clearances` for locations ``lo .. hi - 1`` (slices in threads).

    The segment ``p0 + u d`` (``u`` in ``[0, 1]``) is clipped to each row of cells (in
    ``y``, widened by ``reach``), the piece left to each column of the row (in ``x``),
    and what is left of that gives the column's cells to visit (in ``z``, among the
    occupied ones); a cell is skipped where the piece misses its samples' box widened by
    ``reach`` (as a cube), or where a lower bound of the box's distance to the piece
    (:func:`_box_bound`) exceeds ``reach``; the samples of the others are each tested
    (:func:`_cell_clearances`).
    """
    points, index, cell_start, origin, shape, cell, box, column = binned
    low, high, reach = capsule.low, capsule.high, capsule.reach
    nx, ny = shape[0], shape[1]
    span = high - low
    for i in range(lo, hi):
        a0, a1, a2 = axes[i, 0], axes[i, 1], axes[i, 2]
        t0, t1, t2 = tips[i, 0], tips[i, 1], tips[i, 2]
        k0, k1, k2 = contacts[i, 0], contacts[i, 1], contacts[i, 2]
        p0, p1, p2 = t0 + low * a0, t1 + low * a1, t2 + low * a2
        d0, d1, d2 = span * a0, span * a1, span * a2
        near_mm, far_mm, near_at, far_at = near[i], far[i], near_i[i], far_i[i]
        y_lo, y_hi = _index_range(p1, p1 + d1, reach, origin[1], cell, ny)
        for cy in range(y_lo, y_hi):
            y0 = origin[1] + cy * cell
            u0, u1 = _clip(p1, d1, y0 - reach, y0 + cell + reach, 0.0, 1.0)
            if u0 > u1:
                continue
            x_lo, x_hi = _index_range(p0 + u0 * d0, p0 + u1 * d0, reach, origin[0],
                                      cell, nx)
            for cx in range(x_lo, x_hi):
                col = cx + nx * cy
                if column[col, 0] > column[col, 1]:
                    continue
                x0 = origin[0] + cx * cell
                v0, v1 = _clip(p0, d0, x0 - reach, x0 + cell + reach, u0, u1)
                if v0 > v1:
                    continue
                z_lo, z_hi = _index_range(p2 + v0 * d2, p2 + v1 * d2, reach, origin[2],
                                          cell, shape[2])
                for cz in range(max(z_lo, column[col, 0]), min(z_hi, column[col, 1] + 1)):
                    cid = col + nx * ny * cz
                    if cell_start[cid + 1] == cell_start[cid]:
                        continue
                    w0, w1 = _clip(p0, d0, box[cid, 0] - reach, box[cid, 3] + reach, v0,
                                   v1)
                    w0, w1 = _clip(p1, d1, box[cid, 1] - reach, box[cid, 4] + reach, w0,
                                   w1)
                    w0, w1 = _clip(p2, d2, box[cid, 2] - reach, box[cid, 5] + reach, w0,
                                   w1)
                    if w0 > w1 or _box_bound(p0, p1, p2, d0, d1, d2, w0, w1, box,
                                              cid) > reach:
                        continue
                    near_mm, near_at, far_mm, far_at = _cell_clearances(
                        points, index, cell_start[cid], cell_start[cid + 1], (t0, t1, t2),
                        (a0, a1, a2), (k0, k1, k2), capsule, cutter,
                        (near_mm, near_at, far_mm, far_at))
        near[i], far[i], near_i[i], far_i[i] = near_mm, far_mm, near_at, far_at


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _cell_clearances(points, index, first, stop, tip, axis, contact, capsule, cutter, best):
    """The smallest clearances so far, near and far, with samples ``first .. stop - 1``.

    ``best``: those so far, ``near_mm, near_at, far_mm, far_at`` (returned updated). A
    sample in the ``capsule`` (:class:`Capsule`: within ``sqrt(reach2)`` of the axis from
    ``low`` to ``high`` above the tip ``t``, axis ``a``) gets the cutter's signed distance
    (:class:`Cutter`); it is near within ``sqrt(near2)`` of the contact ``k`` (every sample
    without contacts).
    """
    t0, t1, t2 = tip
    a0, a1, a2 = axis
    k0, k1, k2 = contact
    low, high, reach2 = capsule.low, capsule.high, capsule.reach2
    near2, has_contacts = capsule.near2, capsule.has_contacts
    r, big, h = cutter
    near_mm, near_at, far_mm, far_at = best
    for j in range(first, stop):
        e0, e1, e2 = points[j, 0] - t0, points[j, 1] - t1, points[j, 2] - t2
        z = e0 * a0 + e1 * a1 + e2 * a2
        zc = min(max(z, low), high)
        if e0 * e0 + e1 * e1 + e2 * e2 - (2.0 * z - zc) * zc > reach2:
            continue  # outside the capsule
        dist = cutter_distance(e0, e1, e2, a0, a1, a2, r, big, h)
        q0, q1, q2 = points[j, 0] - k0, points[j, 1] - k1, points[j, 2] - k2
        if not has_contacts or q0 * q0 + q1 * q1 + q2 * q2 <= near2:
            if dist < near_mm:
                near_mm, near_at = dist, index[j]
        elif dist < far_mm:
            far_mm, far_at = dist, index[j]
    return near_mm, near_at, far_mm, far_at


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _distance_sq(points, j, c0, c1, c2):
    """Squared distance from point ``j`` of ``points`` to ``(c0, c1, c2)``."""
    e0 = points[j, 0] - c0
    e1 = points[j, 1] - c1
    e2 = points[j, 2] - c2
    return e0 * e0 + e1 * e1 + e2 * e2


@numba.njit(cache=True, nogil=True)
def _points_within(binned, queries, radius, counts, starts, items, nearest, scratch_size, lo,
                   hi):
    """The points within ``radius`` of queries ``lo .. hi - 1``: counted, listed or the nearest.

    With ``nearest`` empty: counted into ``counts`` (``items`` empty) or listed into
    ``items`` from ``starts``; else the nearest into ``nearest`` (-1: none; of two as near,
    the lower index: the same whatever the cells' order). One kernel for the three (a
    fresh process loads one, not two: ~3 ms each). (Slices of the queries in threads:
    :func:`~toolpath.row_threads.run_in_threads`.)
    """
    points, index, cell_start, origin, shape, cell, box, _ = binned
    cells = np.empty(scratch_size, dtype=np.int64)
    for i in range(lo, hi):
        c0, c1, c2 = queries[i, 0], queries[i, 1], queries[i, 2]
        found = 0
        best, at = radius * radius, -1
        for m in range(cells_near(c0, c1, c2, radius, origin, shape, cell, box, cells)):
            cid = cells[m]
            for j in range(cell_start[cid], cell_start[cid + 1]):
                d = _distance_sq(points, j, c0, c1, c2)
                if nearest.size:
                    if d < best or (d == best and at >= 0 and index[j] < at):
                        best, at = d, index[j]
                elif d <= radius * radius:
                    if items.size:
                        items[starts[i] + found] = index[j]
                    found += 1
        if nearest.size:
            nearest[i] = at
        else:
            counts[i] = found


_NONE = np.zeros(0, dtype=np.int64)


def counts_within(cells: SampleCells, queries_mm: NDArray[np.float64], radius_mm: float
                  ) -> NDArray[np.int64]:
    """How many of the binned points lie within ``radius_mm`` of each query.

    The first of :func:`pairs_within`'s two passes (a query with none has no pair: asked
    alone, it needs no second pass).
    """
    q = np.ascontiguousarray(queries_mm, dtype=float).reshape(-1, 3)
    counts = np.zeros(len(q), dtype=np.int64)
    run_in_threads(_points_within, len(q), cells, q, float(radius_mm), counts, _NONE, _NONE,
                   _NONE, cell_scratch_size(radius_mm, cells.cell_mm))
    return counts


def nearest_within(cells: SampleCells, queries_mm: NDArray[np.float64], radius_mm: float
                   ) -> NDArray[np.int64]:
    """The index of the binned point nearest to each query, among those within ``radius_mm``.

    -1 where none lies within it. Of two as near, the lower index. (Every cell the
    sphere meets is searched, :func:`cells_near`: the nearest point within the radius
    is the nearest of all points when there is one.)
    """
    q = np.ascontiguousarray(queries_mm, dtype=float).reshape(-1, 3)
    out = np.full(len(q), -1, dtype=np.int64)
    run_in_threads(_points_within, len(q), cells, q, float(radius_mm), _NONE, _NONE, _NONE,
                   out, cell_scratch_size(radius_mm, cells.cell_mm))
    return out


def pairs_within(cells: SampleCells, queries_mm: NDArray[np.float64], radius_mm: float
                 ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Every (query, point) pair closer than ``radius_mm``, grouped by query in order.

    Returns ``owner`` (query indices, ascending) and ``item`` (indices of the binned
    points in the array given to :func:`bin_samples`).
    """
    q = np.ascontiguousarray(queries_mm, dtype=float).reshape(-1, 3)
    return _pairs_counted(cells, q, radius_mm, counts_within(cells, q, radius_mm))


def pair_batches(cells: SampleCells, queries_mm: NDArray[np.float64], radius_mm: float,
                 most_pairs: int
                 ) -> Iterator[tuple[NDArray[np.int64], NDArray[np.int64]]]:
    """:func:`pairs_within`'s pairs a run of queries at a time, about ``most_pairs`` a run.

    Yields ``owner`` (query indices, ascending, of the whole ``queries_mm``) and ``item``
    per run of consecutive queries whose pairs number at most ``most_pairs`` (a query
    with more, alone): the pairs of all the runs in turn are :func:`pairs_within`'s, and
    a caller that keeps a few of them holds no more than a run's at once.
    """
    q = np.ascontiguousarray(queries_mm, dtype=float).reshape(-1, 3)
    counts = counts_within(cells, q, radius_mm)
    ends = np.cumsum(counts)
    lo = 0
    while lo < len(q):
        # the run's last query: as many as fit in most_pairs after those before it
        hi = max(lo + 1, int(np.searchsorted(ends, ends[lo] - counts[lo] + most_pairs,
                                             side="right")))
        owner, item = _pairs_counted(cells, q[lo:hi], radius_mm, counts[lo:hi])
        yield owner + lo, item
        lo = hi


def _pairs_counted(cells: SampleCells, q: NDArray[np.float64], radius_mm: float,
                   counts: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The pairs of the queries ``q`` (C-ordered), ``counts`` of them each (their first pass)."""
    starts = np.zeros(len(q), dtype=np.int64)
    scratch = cell_scratch_size(radius_mm, cells.cell_mm)
    starts[1:] = np.cumsum(counts)[:-1]
    items = np.empty(int(counts.sum()), dtype=np.int64)
    if items.size:
        run_in_threads(_points_within, len(q), cells, q, float(radius_mm), counts, starts,
                       items, _NONE, scratch)
    return np.repeat(np.arange(len(q)), counts), items
