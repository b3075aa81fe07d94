"""Compiled neighbour searches over binned points.

The points (surface samples for the global gouge check, :func:`.gouge.global_clearance`;
the centres of a toolpath's pieces for the measurement, :func:`pairs_within`) are binned
in a uniform grid of cubic cells, sorted by cell (``cell_start[c] .. cell_start[c + 1]``
are the points of cell ``c``). A query sphere is compared with the cells its bounding box
overlaps, those it misses are skipped. For the gouge check, for every sample inside it
the exact signed distance of the cutter solid (:func:`.cutter_kernel.cutter_distance`) is
taken on the spot, so no list of pairs is ever built; each location keeps its smallest
value among the samples near its contact and among the others.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from .cutter_kernel import cutter_distance

__all__ = ["SampleCells", "bin_samples", "clearances", "pairs_within"]

#: Cells at most in the grid (the cell grows past the query radius beyond this).
MAX_CELLS = 4_000_000


@dataclass(frozen=True, eq=False)
class SampleCells:
    """Samples sorted by grid cell.

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
    """

    points: NDArray[np.float64]
    index: NDArray[np.int64]
    cell_start: NDArray[np.int64]
    origin: NDArray[np.float64]
    shape: NDArray[np.int64]
    cell_mm: float


def bin_samples(points_mm: NDArray[np.float64], reach_mm: float) -> SampleCells:
    """Bin samples in cells of edge ``reach_mm`` (the largest query radius).

    A query sphere then overlaps at most 3 x 3 x 3 cells (finer cells cost more in cell
    visits than they save in samples on a blade's thin sheet of samples).
    """
    lo = points_mm.min(axis=0) - 1e-9
    extent = points_mm.max(axis=0) + 1e-9 - lo
    cell = max(float(reach_mm), 1e-9)
    while np.prod(np.floor(extent / cell) + 1.0) > MAX_CELLS:
        cell *= 1.5
    shape = (np.floor(extent / cell) + 1).astype(np.int64)
    ijk = np.minimum(((points_mm - lo) / cell).astype(np.int64), shape - 1)
    cell_id = ijk[:, 0] + shape[0] * (ijk[:, 1] + shape[1] * ijk[:, 2])
    order = np.argsort(cell_id, kind="stable")
    start = np.searchsorted(cell_id[order], np.arange(int(np.prod(shape)) + 1))
    return SampleCells(points=np.ascontiguousarray(points_mm[order]), index=order,
                       cell_start=start.astype(np.int64), origin=lo, shape=shape,
                       cell_mm=cell)


def clearances(cells: SampleCells, tips_mm: NDArray[np.float64], axes: NDArray[np.float64],
               contacts_mm: NDArray[np.float64] | None, heights_mm: NDArray[np.float64],
               radii_mm: NDArray[np.float64], corner_mm: float, radius_mm: float,
               flute_mm: float, near_radius_mm: float
               ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64],
                          NDArray[np.int64]]:
    """Smallest signed distance per location: ``near, far`` (``inf`` if none) and samples.

    Query spheres of ``radii_mm`` at ``heights_mm`` along each axis from its tip; a
    sample within ``near_radius_mm`` of the location's contact (every sample without
    contacts) counts as near.
    """
    n = len(tips_mm)
    near = np.full(n, np.inf)
    far = np.full(n, np.inf)
    near_i = np.full(n, -1, dtype=np.int64)
    far_i = np.full(n, -1, dtype=np.int64)
    has_contacts = contacts_mm is not None
    contacts = np.ascontiguousarray(tips_mm if contacts_mm is None else contacts_mm,
                                    dtype=float)
    _clearances(cells.points, cells.index, cells.cell_start, cells.origin, cells.shape,
                cells.cell_mm, np.ascontiguousarray(tips_mm, dtype=float),
                np.ascontiguousarray(axes, dtype=float), contacts, has_contacts,
                np.ascontiguousarray(heights_mm, dtype=float),
                np.ascontiguousarray(radii_mm, dtype=float), corner_mm, radius_mm, flute_mm,
                near_radius_mm * near_radius_mm, near, far, near_i, far_i,
                _cell_scratch_size(float(np.max(radii_mm, initial=0.0)), cells.cell_mm))
    return near, far, near_i, far_i


@numba.njit(cache=True, inline="always")
def _gap(x, lo, size):
    """Distance from ``x`` to the interval ``[lo, lo + size]``."""
    if x < lo:
        return lo - x
    if x > lo + size:
        return x - lo - size
    return 0.0


@numba.njit(cache=True)
def _cells_near(c0, c1, c2, radius, origin, shape, cell, out):
    """The cells a sphere meets, into ``out``; how many.

    The cells its bounding box overlaps, less those farther than ``radius`` from ``c``.
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
                if gx * gx + gy * gy + gz * gz <= radius * radius:
                    out[count] = cx + nx * (cy + ny * cz)
                    count += 1
    return count


def _cell_scratch_size(radius_mm: float, cell_mm: float) -> int:
    """Room for the cells a sphere of ``radius_mm`` can meet."""
    side = int(2.0 * radius_mm / cell_mm) + 3
    return side * side * side


#: Locations per block of the parallel gouge check (each block its own scratch).
BLOCK = 256


@numba.njit(cache=True, parallel=True)
def _clearances(points, index, cell_start, origin, shape, cell, tips, axes, contacts,
                has_contacts, heights, radii, r, big, h, near2, near, far, near_i, far_i,
                scratch_size):
    for block in numba.prange((tips.shape[0] + BLOCK - 1) // BLOCK):
        cells = np.empty(scratch_size, dtype=np.int64)
        for i in range(block * BLOCK, min((block + 1) * BLOCK, tips.shape[0])):
            for k in range(heights.size):
                c0 = tips[i, 0] + heights[k] * axes[i, 0]
                c1 = tips[i, 1] + heights[k] * axes[i, 1]
                c2 = tips[i, 2] + heights[k] * axes[i, 2]
                rad2 = radii[k] * radii[k]
                for m in range(_cells_near(c0, c1, c2, radii[k], origin, shape, cell, cells)):
                    cid = cells[m]
                    for j in range(cell_start[cid], cell_start[cid + 1]):
                        e0 = points[j, 0] - c0
                        e1 = points[j, 1] - c1
                        e2 = points[j, 2] - c2
                        if e0 * e0 + e1 * e1 + e2 * e2 > rad2:
                            continue
                        dist = cutter_distance(
                            points[j, 0] - tips[i, 0], points[j, 1] - tips[i, 1],
                            points[j, 2] - tips[i, 2], axes[i, 0], axes[i, 1], axes[i, 2],
                            r, big, h)
                        is_near = True
                        if has_contacts:
                            q0 = points[j, 0] - contacts[i, 0]
                            q1 = points[j, 1] - contacts[i, 1]
                            q2 = points[j, 2] - contacts[i, 2]
                            is_near = q0 * q0 + q1 * q1 + q2 * q2 <= near2
                        if is_near:
                            if dist < near[i]:
                                near[i] = dist
                                near_i[i] = index[j]
                        elif dist < far[i]:
                            far[i] = dist
                            far_i[i] = index[j]


@numba.njit(cache=True, parallel=True)
def _pairs_within(points, index, cell_start, origin, shape, cell, queries, radius, counts,
                  starts, items, scratch_size):
    """Count (``items`` empty) or list the points within ``radius`` of each query."""
    for block in numba.prange((queries.shape[0] + BLOCK - 1) // BLOCK):
        cells = np.empty(scratch_size, dtype=np.int64)
        for i in range(block * BLOCK, min((block + 1) * BLOCK, queries.shape[0])):
            c0, c1, c2 = queries[i, 0], queries[i, 1], queries[i, 2]
            found = 0
            for m in range(_cells_near(c0, c1, c2, radius, origin, shape, cell, cells)):
                cid = cells[m]
                for j in range(cell_start[cid], cell_start[cid + 1]):
                    e0 = points[j, 0] - c0
                    e1 = points[j, 1] - c1
                    e2 = points[j, 2] - c2
                    if e0 * e0 + e1 * e1 + e2 * e2 <= radius * radius:
                        if items.size:
                            items[starts[i] + found] = index[j]
                        found += 1
            counts[i] = found


def pairs_within(cells: SampleCells, queries_mm: NDArray[np.float64], radius_mm: float
                 ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Every (query, point) pair closer than ``radius_mm``, grouped by query in order.

    Returns ``owner`` (query indices, ascending) and ``item`` (indices of the binned
    points in the array given to :func:`bin_samples`).
    """
    q = np.ascontiguousarray(queries_mm, dtype=float).reshape(-1, 3)
    counts = np.zeros(len(q), dtype=np.int64)
    starts = np.zeros(len(q), dtype=np.int64)
    args = (cells.points, cells.index, cells.cell_start, cells.origin, cells.shape,
            cells.cell_mm, q, float(radius_mm))
    scratch = _cell_scratch_size(radius_mm, cells.cell_mm)
    _pairs_within(*args, counts, starts, np.zeros(0, dtype=np.int64), scratch)
    starts[1:] = np.cumsum(counts)[:-1]
    items = np.empty(int(counts.sum()), dtype=np.int64)
    if items.size:
        _pairs_within(*args, counts, starts, items, scratch)
    return np.repeat(np.arange(len(q)), counts), items
