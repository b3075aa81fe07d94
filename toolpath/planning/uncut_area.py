"""The area no cutter comes near, and distances over the surface to it.

A coarse grid (spacing half the cutter radius along ``t``, one stepover across) gives the
uncut area (rays that enter no cut within the horizon, :meth:`~.cut_volume.CutVolume.cut`);
distances from it are taken along the surface (shortest paths over the grid), round a thin
part's edges rather than through it.

Where the chord measurement's contacts are given, each grid node first tries one piece:
the one whose move's track in ``(t, s)`` (interpolated between its contacts) crosses the
node's column nearest to the node (:func:`_node_pieces`). A ray that piece cuts within the
horizon is cut whatever the others do, and the cutter that left a contact stands over the
nodes round it. Only the nodes it does not cut are searched among the pieces near them:
the same uncut area, most nodes without a search.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
import scipy.sparse
import scipy.sparse.csgraph
from numpy.typing import NDArray

from ..surface import ParametricSurface
from ..tolerances import LENGTH_SLACK_MM, TINY
from ..vectors import cross_rows, lengths
from .cut_volume import CutVolume

__all__ = ["UncutArea"]


@dataclass(frozen=True)
class UncutArea:
    """The coarse grid's points no cutter comes near, and distances over the surface to them.

    ``grid`` holds the points ``(n_t, n_s, 3)``, ``uncut`` the uncut ones; ``reach`` the
    distance from each grid node to the nearest uncut one (:func:`_surface_reach`; None:
    nothing uncut), followed up to a cutter diameter (``diameter_mm``).
    """

    grid: NDArray[np.float64]
    uncut: NDArray[np.bool_]
    fraction: float
    reach: NDArray[np.float64] | None
    diameter_mm: float

    @classmethod
    def on_grid(cls, surface: ParametricSurface, volume: CutVolume, width_mm: float,
                contacts: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
                ) -> UncutArea:
        """Grid spacing half the cutter radius along ``t``, ``width_mm`` across.

        ``contacts``: the contacts' ``t`` and ``s`` at each toolpath point (``nan`` where
        none, :attr:`~.chord_measure.ChordMeasurement.contact_t`): each node tries the
        piece they place at it first (module docstring; the same area, found faster).
        """
        big = volume.cutter.radius_mm
        g = np.linspace(0.0, 1.0, 33)
        pts = surface(g, g, grid=True)
        len_t = np.linalg.norm(np.diff(pts, axis=0), axis=2).sum(axis=0).max() * 1.02
        len_s = np.linalg.norm(np.diff(pts, axis=1), axis=2).sum(axis=1).max() * 1.02
        # (two nodes at least each way: a point lies between four, :func:`_distance_from`)
        n_t = max(int(np.ceil(len_t / (0.5 * big))) + 1, 2)
        n_s = max(int(np.ceil(len_s / width_mm)) + 1, 2)
        t, s = np.meshgrid(np.linspace(0.0, 1.0, n_t), np.linspace(0.0, 1.0, n_s),
                           indexing="ij")
        # the first partials only: points, normals and |X_t x X_s| = sqrt(E G - F^2)
        parts = surface.partials_many(t.ravel(), s.ravel(), ((0, 0), (1, 0), (0, 1)))
        q, across = parts[0, 0], cross_rows(parts[1, 0], parts[0, 1])
        area = np.sqrt(np.einsum("ij,ij->i", across, across))
        # outward_normals' unit normals from the cross product and its length at hand
        n = surface.orientation * (across / np.where(area > 0.0, area, 1.0)[:, None])
        # (a node a cutter radius across from a pass is beyond that pass's cutter)
        candidate = (None if contacts is None else
                     _node_pieces(volume, *contacts, bool(surface.closed_t), n_t, n_s,
                                  math.ceil(big / width_mm)))
        uncut = ~volume.cut(q, n, candidate)
        fraction = float(area[uncut].sum() / max(area.sum(), TINY))
        grid = q.reshape(n_t, n_s, 3)
        reach = (_surface_reach(grid, uncut.reshape(n_t, n_s), bool(surface.closed_t),
                                2.0 * big) if uncut.any() else None)
        return cls(grid, uncut, fraction, reach, 2.0 * big)

    def away(self, points: NDArray[np.float64], t: NDArray[np.float64],
             s: NDArray[np.float64]) -> NDArray[np.bool_] | None:
        """Points farther than a cutter diameter from the uncut area (None: none uncut)."""
        if self.reach is None:
            return None
        return _distance_from(self.reach, self.grid, points, t, s) > self.diameter_mm


def _node_pieces(volume: CutVolume, contact_t: NDArray[np.float64],
                 contact_s: NDArray[np.float64], closed: bool, n_t: int, n_s: int,
                 spread: int) -> NDArray[np.int64] | None:
    """A piece for each node of the ``(n_t, n_s)`` grid from the contacts' ``(t, s)`` (-1: none).

    A move between two contacts runs, in ``(t, s)``, along the line between theirs (the
    short way across a closed section's seam). Where that line crosses a grid column
    (``t = i / (n_t - 1)``, at ``u`` along the move, ``s*`` there), the move's piece
    holding ``u`` stands over the column at ``s*``: it is offered to the column's nodes
    within ``spread`` nodes of ``s*``, and each node keeps the piece that crosses its
    column nearest to it in ``s`` (the first of them where several are as near). Pieces of
    other moves (links, leads) place none. None where no contacts are given, or none is
    placed. Compiled, move by move (:func:`_place_pieces`).

    (A piece's own cut spans a short stretch along its pass round its contact: a bull-nose
    leaning ``lead`` ahead cuts within the horizon only within about
    ``sqrt(2 r h)`` of it along the feed. So the piece that crosses the node's column, not
    one whose middle lies within half a column of it, is the one that cuts its ray.)
    """
    if not len(contact_t) or not len(volume.pass_of):
        return None
    start, piece_move = volume.move_starts, volume.piece_move
    node = np.full(n_t * n_s, -1, dtype=np.int64)
    placed = _place_pieces(np.ascontiguousarray(start, dtype=np.int64),
                           np.ascontiguousarray(piece_move, dtype=np.int64),
                           np.ascontiguousarray(contact_t, dtype=float),
                           np.ascontiguousarray(contact_s, dtype=float), closed, n_t, n_s,
                           int(spread), node)
    return node if placed else None


@numba.njit(cache=True)
def _place_pieces(start, piece_move, contact_t, contact_s, closed, n_t, n_s, spread, node):
    """The loop of :func:`_node_pieces`: into ``node``; whether any piece was placed.

    A move's pieces run on in order (``piece_move`` rises): piece ``k`` of a move of ``c``
    holds ``u`` in ``[k / c, (k + 1) / c)`` (the last also ``u = 1``).
    """
    nearest = np.full(n_t * n_s, np.inf)
    placed = False
    first = 0
    total = piece_move.size
    last_column = n_t - 1
    while first < total:
        m = piece_move[first]
        end = first
        while end < total and piece_move[end] == m:
            end += 1
        c = end - first
        a = start[m]
        ta, tb, sa, sb = contact_t[a], contact_t[a + 1], contact_s[a], contact_s[a + 1]
        if np.isfinite(ta) and np.isfinite(tb) and np.isfinite(sa) and np.isfinite(sb):
            if closed:  # the short way across the seam (as :func:`seam_lerp`)
                if tb - ta > 0.5:
                    tb -= 1.0
                elif ta - tb > 0.5:
                    tb += 1.0
            low, high = min(ta, tb), max(ta, tb)
            turns = 1 if closed else 0
            for turn in range(-turns, turns + 1):  # (the columns a whole turn on, too)
                i0 = max(math.ceil((low - turn) * last_column), 0)
                i1 = min(math.floor((high - turn) * last_column), last_column)
                for i in range(i0, i1 + 1):
                    u = 0.0
                    if high > low:
                        u = min(max((i / last_column + turn - ta) / (tb - ta), 0.0), 1.0)
                    k = min(int(u * c), c - 1)
                    at = (sa + u * (sb - sa)) * (n_s - 1)
                    j0 = max(math.ceil(at - spread), 0)
                    j1 = min(math.floor(at + spread), n_s - 1)
                    for j in range(j0, j1 + 1):
                        off = abs(j - at)
                        if off < nearest[i * n_s + j]:
                            nearest[i * n_s + j] = off
                            node[i * n_s + j] = first + k
                            placed = True
        first = end
    return placed


def _surface_reach(grid: NDArray[np.float64], sources: NDArray[np.bool_], closed: bool,
                   limit_mm: float) -> NDArray[np.float64]:
    """Distance over the surface from every node of the sample grid to the nearest source, mm.

    Shortest paths on the sample grid ``(n_t, n_s, 3)`` (its rows at ``t = i / (n_t - 1)``,
    columns likewise in ``s``), edges to the 8 neighbours weighted by their chord (the
    seam joined on closed sections), from every source node at once. Over a thin part
    this is the way round its edge, not through its thickness. Paths are followed up to
    ``limit_mm``: a distance beyond it may read ``inf``.

    A shortest path from the sources to another node leaves them for good at its last
    source, which has a neighbour that is no source (a border source), and runs on over
    no-source nodes only. So the search runs from the border sources over the edges with
    a no-source end (the same sums along the same paths: the same distances), and the
    sources read 0: the inside of a large uncut area is never walked.
    """
    if not limit_mm >= 0.0:
        raise ValueError(f"the reach's limit must be >= 0 mm, got {limit_mm!r}")
    n_t, n_s = sources.shape
    node = np.arange(n_t * n_s).reshape(n_t, n_s)
    ends = [(np.s_[1:, :], np.s_[:-1, :]), (np.s_[:, 1:], np.s_[:, :-1]),
            (np.s_[1:, 1:], np.s_[:-1, :-1]), (np.s_[1:, :-1], np.s_[:-1, 1:])]
    if closed:
        ends.append((np.s_[0, :], np.s_[-1, :]))
    border = np.zeros((n_t, n_s), dtype=bool)
    # each direction's edges and chords from slices of the grid's coordinates (no gather
    # of their ends), those between two sources left out (on no such path), in order
    x, y, z = (np.ascontiguousarray(grid[..., k]) for k in range(3))
    a, b, chord = [], [], []
    for p, q in ends:
        keep = ~(sources[p] & sources[q])
        border[p] |= sources[p] & keep
        border[q] |= sources[q] & keep
        a.append(node[p][keep])
        b.append(node[q][keep])
        chord.append(lengths(*(c[p][keep] - c[q][keep] for c in (x, y, z))))
    a, b = np.concatenate(a), np.concatenate(b)
    source, border = sources.ravel(), border.ravel()
    # a stored 0 is no edge to the graph: coincident nodes (a collapsed row) keep theirs
    weight = np.maximum(np.concatenate(chord), LENGTH_SLACK_MM)
    graph = scipy.sparse.coo_matrix((weight, (a, b)), shape=(node.size, node.size)).tocsr()
    reach = np.full(node.size, np.inf)
    if border.any():
        reach = scipy.sparse.csgraph.dijkstra(graph, directed=False,
                                              indices=np.flatnonzero(border),
                                              min_only=True, limit=limit_mm)
    reach[source] = 0.0
    return reach


def _distance_from(reach: NDArray[np.float64], grid: NDArray[np.float64],
                   points: NDArray[np.float64], t: NDArray[np.float64],
                   s: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance over the surface from ``points`` (at ``t, s``) to the nearest source, mm.

    Through the best of the four grid nodes around each point (:func:`_surface_reach`).
    (Coordinate by coordinate, the nodes gathered by ``take``: the same chords as
    ``np.linalg.norm(points - node, axis=1)`` (:func:`~toolpath.vectors.lengths`), in a
    third of its time.)
    """
    n_t, n_s = grid.shape[:2]
    node_xyz = [np.ascontiguousarray(grid[..., k]).ravel() for k in range(3)]
    point_xyz = [np.ascontiguousarray(points[:, k]) for k in range(3)]
    i0 = np.clip(np.floor(t * (n_t - 1)).astype(np.int64), 0, n_t - 2)
    j0 = np.clip(np.floor(s * (n_s - 1)).astype(np.int64), 0, n_s - 2)
    corner = i0 * n_s + j0  # the node (i0, j0), flat
    best = np.full(len(points), np.inf)
    for k in (corner, corner + 1, corner + n_s, corner + n_s + 1):  # (i0 + di, j0 + dj)
        chord = lengths(*(p - c.take(k) for p, c in zip(point_xyz, node_xyz, strict=True)))
        best = np.minimum(best, reach.take(k) + chord)
    return best
