"""Spatial bucketing of capsule pieces on a uniform grid.

Pieces are registered by their midpoint in cubic cells of side ``cell_mm`` over a box (the
reach of the surface samples; pieces outside it cannot touch a sample and are dropped).
The cells are a dense array of offsets into the pieces sorted by cell (a counting sort, in
compiled code: one pass over the pieces and one over the cells, no temporaries the size of
the grid), so a query is a direct index, not a tree walk. A query ball of radius ``rho``
around a point is covered by the ``(2k + 1)^3`` cells around the point's cell with
``k = ceil(rho / c)``; queries are grouped by ``k`` and expanded into candidate pairs in
bounded batches.

The cost of verification is the number of candidate pairs, about (area of the query disc
on the sheet of ball centres) x (pieces per mm^2 of that sheet), never blocks x samples.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Final

import numba
import numpy as np
from numpy.typing import NDArray

__all__ = ["CELLS_PER_PIECE", "MAX_CELLS", "PieceGrid", "places_within", "span_indices"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

MAX_CELLS: Final[int] = 16_000_000
"""Largest dense grid (cells); the cell grows to stay below it (128 MB of offsets)."""

CELLS_PER_PIECE: Final[int] = 8
"""Cells of a grid per piece given to it (those outside the box too), about at most: the
cell grows by the cube root of the excess, so a box only a few cells thick (or a grid of a
handful of pieces) may keep a few times more.

The pieces lie on a sheet (the swept cutter along the surface) or gather around a few
points (the verifier's fine model), so a grid over their box at the search's cell is
nearly all empty cells, each paid for in the build (8 bytes, the counting sort's pass over
every cell) and in the walk's memory traffic; a coarser cell only gives a query more
pieces to reject by distance, never other pieces within its reach. On the 5-axis blade
program (266 k near pieces, 16 M cells at the search's cell, bench_verify): the
verification's CPU 3.3 -> 3.0 s, 100 MB less, the same from 2 to 8 cells per piece; the
fine model's grid (44 k pieces over the blade's box) 16 M cells -> 0.37 M, its build 0.07
to 0.3 s (page faults) -> 2 ms.
"""


@dataclass(frozen=True, eq=False)
class PieceGrid:
    """Pieces sorted by grid cell, with the dense offset table.

    Attributes
    ----------
    origin_mm : ndarray, shape (3,)
        Corner of cell (0, 0, 0), mm.
    cell_mm : float
        Cell side, mm.
    dims : tuple of int
        Cells along x, y, z.
    starts : ndarray of int64, shape (n_cells + 1,)
        Pieces of cell ``k`` are ``order[starts[k]:starts[k + 1]]``.
    order : ndarray of int64
        Piece indices sorted by cell.
    """

    origin_mm: FloatArray
    cell_mm: float
    dims: tuple[int, int, int]
    starts: IntArray
    order: IntArray

    @classmethod
    def build(cls, midpoints: FloatArray, lo_mm: FloatArray, hi_mm: FloatArray,
              cell_mm: float) -> PieceGrid:
        """Register pieces by midpoint over the box ``[lo, hi]``.

        Parameters
        ----------
        midpoints : ndarray, shape (n, 3)
            Piece midpoints, mm.
        lo_mm, hi_mm : ndarray, shape (3,)
            The box queries can reach, mm; pieces outside are left out.
        cell_mm : float
            Wanted cell side, mm (enlarged when the grid would exceed :data:`MAX_CELLS`
            or :data:`CELLS_PER_PIECE` cells per piece).

        Returns
        -------
        PieceGrid
        """
        lo = np.asarray(lo_mm, dtype=float)
        span = np.maximum(np.asarray(hi_mm, dtype=float) - lo, 1e-9)
        cell = float(cell_mm)
        volume_cells = float(np.prod(span / cell + 1.0))
        max_cells = min(MAX_CELLS, CELLS_PER_PIECE * max(midpoints.shape[0], 1))
        if volume_cells > max_cells:
            cell *= (volume_cells / max_cells) ** (1.0 / 3.0) * 1.01
        dims_arr = np.maximum(np.ceil(span / cell).astype(np.int64) + 1, 1)
        dims = (int(dims_arr[0]), int(dims_arr[1]), int(dims_arr[2]))
        starts, order = _counting_sort(np.ascontiguousarray(midpoints, dtype=float), lo, cell,
                                       dims_arr)
        return cls(lo, cell, dims, starts, order)

    @property
    def n_pieces(self) -> int:
        """Pieces registered (inside the box)."""
        return int(self.order.shape[0])

    def span_of(self, radius_mm: FloatArray) -> IntArray:
        """Cells ``k`` to search on each side for query radii ``radius_mm``."""
        return np.maximum(np.ceil(radius_mm / self.cell_mm).astype(np.int64), 1)

    def candidate_batches(self, centres: FloatArray, span: int, *, max_pairs: int
                          ) -> Iterator[tuple[IntArray, IntArray]]:
        """Candidate ``(query, piece)`` pairs for queries searched ``span`` cells around.

        Queries are grouped by cell: the ``(2 span + 1)^3`` neighbour cells are looked up
        once per occupied cell, and every query of the cell is paired with the pieces of
        its neighbourhood.

        Parameters
        ----------
        centres : ndarray, shape (q, 3)
            Query centres, mm.
        span : int
            Cells searched on each side of a query's cell.
        max_pairs : int
            Upper bound on the pairs of one batch (memory bound); a single query with
            more candidates forms a batch of its own.

        Yields
        ------
        query, piece : ndarray of int64
            Pairs, each query's pairs contiguous; ``query`` indexes ``centres``.
        """
        q = centres.shape[0]
        if q == 0 or self.n_pieces == 0:
            return
        dims = np.asarray(self.dims, dtype=np.int64)
        ijk = np.floor((centres - self.origin_mm) / self.cell_mm).astype(np.int64).T
        ijk = np.clip(ijk, -span - 1, dims[:, None] + span)  # far queries: empty cells
        key = ((ijk[0] + span + 1) * (dims[1] + 2 * span + 3) + ijk[1] + span + 1) * (
            dims[2] + 2 * span + 3) + ijk[2] + span + 1
        by_cell = np.argsort(key, kind="stable")
        cells, first_query, n_query = np.unique(key[by_cell], return_index=True,
                                                return_counts=True)
        cell_ijk = ijk[:, by_cell[first_query]]
        lists, list_start, list_len = self._neighbourhoods(cell_ijk, span)
        per_query = np.repeat(list_len, n_query)  # in by_cell order
        cum = np.cumsum(per_query)
        cell_of = np.repeat(np.arange(cells.shape[0]), n_query)
        start = 0
        while start < q:
            done = int(cum[start - 1]) if start else 0
            stop = max(int(np.searchsorted(cum, done + max_pairs, side="right")), start + 1)
            c = per_query[start:stop]
            total = int(c.sum())
            if total:
                rows = np.repeat(np.arange(start, stop, dtype=np.int64), c)
                within = places_within(c)
                pieces = lists[list_start[cell_of[rows]] + within]
                yield by_cell[rows], pieces
            start = stop

    def _neighbourhoods(self, cell_ijk: IntArray, span: int
                        ) -> tuple[IntArray, IntArray, IntArray]:
        """Pieces around each cell: concatenated lists, their starts and lengths.

        Cells are numbered with z fastest, so the ``2 span + 1`` cells of a column along z
        are one contiguous range of ``order``: ``(2 span + 1)^2`` lookups per cell.
        """
        dims = np.asarray(self.dims, dtype=np.int64)
        rng = np.arange(-span, span + 1, dtype=np.int64)
        oi, oj = (a.ravel() for a in np.meshgrid(rng, rng, indexing="ij"))
        ci = cell_ijk[0][:, None] + oi[None, :]  # (u, n_col)
        cj = cell_ijk[1][:, None] + oj[None, :]
        k0 = np.maximum(cell_ijk[2] - span, 0)[:, None]
        k1 = np.minimum(cell_ijk[2] + span, dims[2] - 1)[:, None]
        valid = (ci >= 0) & (ci < dims[0]) & (cj >= 0) & (cj < dims[1]) & (k0 <= k1)
        column = (np.where(valid, ci, 0) * dims[1] + np.where(valid, cj, 0)) * dims[2]
        first = self.starts[column + np.where(valid, k0, 0)]
        count = np.where(valid, self.starts[column + np.where(valid, k1, 0) + 1] - first, 0)
        count = count.ravel()
        rows = np.repeat(np.arange(count.shape[0], dtype=np.int64), count)
        within = places_within(count)
        lists = self.order[first.ravel()[rows] + within]
        list_len = count.reshape(valid.shape).sum(axis=1)
        list_start = np.cumsum(list_len) - list_len
        return lists, list_start, list_len


def places_within(count: IntArray) -> IntArray:
    """Each element's place within its run, for runs of ``count`` elements laid end to end.

    ``[0, 1, .., count[0] - 1, 0, 1, .., count[1] - 1, ...]`` (int64, ``count.sum()``).
    """
    return (np.arange(int(count.sum()), dtype=np.int64)
            - np.repeat(np.cumsum(count) - count, count))


def span_indices(first: IntArray, count: IntArray) -> IntArray:
    """The indices ``first[i], .., first[i] + count[i] - 1`` of every span, in turn."""
    return np.repeat(first, count) + places_within(count)


@numba.njit(cache=True)
def _cell_of(x_mm: float, lo_mm: float, cell_mm: float, top: float) -> int:
    """The cell along one axis of a coordinate: ``floor(clip((x - lo) / cell, -1, top))``.

    NaN gives ``-1`` (outside), as infinities give ``-1`` or ``top``: far (or non-finite)
    midpoints fall in a cell outside the grid and are left out.
    """
    v = (x_mm - lo_mm) / cell_mm
    if v != v:
        v = -1.0
    return int(np.floor(min(max(v, -1.0), top)))


@numba.njit(cache=True)
def _counting_sort(midpoints: FloatArray, lo_mm: FloatArray, cell_mm: float, dims: IntArray
                   ) -> tuple[IntArray, IntArray]:
    """Pieces inside the grid sorted by cell ``(i n_j + j) n_k + k`` (stable), and offsets.

    A piece's cell is :func:`_cell_of` its midpoint, found here piece by piece (no
    temporaries of the pieces' size but their keys: a grid over the 7 M pieces of the
    bull-nose 5-axis blade program made seven 168 MB ones). ``starts[c]`` counts the pieces
    of the cells before ``c``; ``order`` lists the pieces cell by cell, in their own order
    within a cell (the stable sort of their cell keys).
    """
    n_cells = dims[0] * dims[1] * dims[2]
    top = float(max(dims[0], dims[1], dims[2]))
    starts = np.zeros(n_cells + 1, dtype=np.int64)
    key = np.full(midpoints.shape[0], -1, dtype=np.int64)
    for p in range(midpoints.shape[0]):
        i = _cell_of(midpoints[p, 0], lo_mm[0], cell_mm, top)
        j = _cell_of(midpoints[p, 1], lo_mm[1], cell_mm, top)
        k = _cell_of(midpoints[p, 2], lo_mm[2], cell_mm, top)
        if 0 <= i < dims[0] and 0 <= j < dims[1] and 0 <= k < dims[2]:
            key[p] = (i * dims[1] + j) * dims[2] + k
            starts[key[p] + 1] += 1
    for c in range(n_cells):
        starts[c + 1] += starts[c]
    order = np.empty(starts[n_cells], dtype=np.int64)
    for p in range(midpoints.shape[0]):  # starts[c] runs up to the next cell's start
        if key[p] >= 0:
            order[starts[key[p]]] = p
            starts[key[p]] += 1
    for c in range(n_cells, 0, -1):
        starts[c] = starts[c - 1]
    starts[0] = 0
    return starts, order
