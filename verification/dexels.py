r"""Dexels through the design samples: how much material the swept cutter leaves on each.

Every design sample ``P`` carries a dexel, the line ``P + lam d`` with ``d`` either the
outward normal (the default) or ``+Z`` (a Z-map whose nodes are the design samples). A
capsule piece the line meets in ``[lam_in, lam_out]`` with ``lam_out > 0`` (the tool
reaches the design point or above it) leaves ``lam_in`` of material: positive is material
left above ``P``, negative a gouge that deep. A piece that comes *from behind* (its tool
axis points against the dexel, ``a . d < -1/2``, so the rest of the tool lies inside the
part: the other side of a thin wall such as a blade's blunt trailing edge, or an underside
reached from above) and reaches below ``P`` leaves ``max(lam_in, -lam_out)`` instead: it
counts by how far it pokes out through the design point, since the half-space below ``P``
that ``lam_in`` measures into is not material there. The remaining material is the
minimum over the pieces (:func:`~verification.capsule.line_capsule_interval`), converted
to a normal deviation by ``lam (d . n)``. Negative is a gouge.

Two searches keep the candidate pieces few:

* **Near search** (every sample, ball pieces only). A ball that brings the dexel's
  remaining material into ``[-g, e]`` (``e`` the excess horizon, ``g`` the gouge search
  depth) has its centre near ``Q = P + R n``: on a surface of convex radius ``rho`` at
  ``P`` (``1/rho`` the sample's convexity), within
  ``r = 1.1 sqrt(2 R (e + g) (rho + R) / (rho + e)) + g`` of ``Q`` (plane: ``rho`` infinite;
  concave surfaces need less). Remaining material above ``e`` is reported as *not cut*.
* **Collision search** (a coarse subset of samples, ball and shank pieces). Any piece
  within ``R + e`` of ``P`` itself: a ball from behind (through a thin part), a rapid
  through the part, the shank rubbing a wall. Where it finds more than the near search,
  every sample around is searched again: with the collision search when the piece was the
  shank or came from behind, else (a ball gouging deeper than ``g`` from outside) with a
  near search sized for that depth, which holds far fewer candidates. A shank piece that
  finds more by no more than the tolerance of the pieces (replay plus merge) met the ball
  it starts at, which the merged ball pieces approximate from inside: the same contact,
  kept on that sample and not searched around.

**Flat and bull-nose cutters** (corner radius ``r < R``) are the points within ``r`` of a
core disc of radius ``rho0 = R - r`` (:mod:`verification.torus`): every ball of radius
``r`` centred on the core is one of the balls above, so the near search runs around
``Q = P + r n`` with the ball radius for ``r`` (at least ``e + g``: a flat end mill's
``r = 0`` balls are points) plus ``rho0`` for the pieces' core centres. The pieces'
entries are no longer closed-form, so a batch is measured in two rounds: first, for each
dexel, the piece whose cheap lower bound (the entry into a bounding capsule and slab) is
lowest; then only the pieces whose bound is below the best found. A piece whose bound is
not below the best cannot lower the minimum. By default both rounds run in compiled code
inside the grid walk (:mod:`verification.sweep_search`), storing no pair.

Candidates come from :class:`~verification.grid.PieceGrid`; pairs are processed in
batches of at most ``max_pairs``, so memory is bounded whatever the program's length.

**Ties.** Where several pieces leave exactly the same value (a flat bottom on a floor,
passes overlapping on a plane), the dexel goes to the piece of smallest index (ball
pieces in path order, then shank pieces: an equal shank piece of an earlier block loses
to a later block's ball piece), in every search and in every merge of two searches' results
(:meth:`DexelResult.merged`, :func:`~verification.search.scatter`): the order
``(value, piece)`` of :func:`~verification.capsule_search.ranks_before`, where the reasons
for bit-equality are. A result carries its pieces for that, numbered as the collision
search's pieces (:meth:`SweepIndex.pieces`: the near search's, then the shank's).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .capsule import line_capsule_interval
from .capsule_search import TIE_SLACK_MM, lowest_capsule_entries, pair_values
from .grid import PieceGrid
from .piece_runs import PieceRuns, piece_runs
from .pieces import Pieces
from .sweep_below import pieces_entering_below
from .sweep_search import lowest_sweep_entries
from .torus import line_sweep_interval, sweep_entry_bound
from .vectors import row_norms

__all__ = ["BEHIND_COSINE", "CELL_PER_REACH", "MIN_TARGET_CELL_MM", "DexelResult", "SweepIndex",
           "candidate_reach_mm", "grid_margin_mm", "near_search_radius_mm", "ranks_before_rows",
           "reach_beyond_mm"]

#: Search radii per grid cell (the cell nearest ``reach / CELL_PER_REACH`` is used).
CELL_PER_REACH = 2.0

#: Smallest cell a search asks for, mm: a search of radius 0 (a point) gets the finest grid
#: (the cell's log2 needs a positive target; any length far below a grid cell works).
MIN_TARGET_CELL_MM = 1e-12

#: A piece whose tool axis makes ``a . d`` below this with the dexel comes from behind:
#: the rest of the tool lies inside the part (axis more than 120 deg from the dexel). Side
#: contacts (``a`` across the normal) and tilted tools stay "from outside".
BEHIND_COSINE = -0.5

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


def ranks_before_rows(lam_mm: FloatArray, piece: IntArray, best_mm: FloatArray,
                      best_piece: IntArray) -> NDArray[np.bool_]:
    """Where ``(lam_mm, piece)`` ranks before ``(best_mm, best_piece)``, row by row.

    :func:`~verification.capsule_search.ranks_before` (the tie rule) on arrays: lower
    first; of bit-equal values the smaller piece index, where both are known (``>= 0``).
    """
    return (lam_mm < best_mm) | ((lam_mm == best_mm) & (piece >= 0) & (piece < best_piece))


def near_search_radius_mm(radius_mm: float, horizon_mm: float, depth_mm: float,
                          convexity_per_mm: FloatArray, *, core_radius_mm: float = 0.0
                          ) -> FloatArray:
    """Radius around ``P + R n`` holding every ball centre that matters (module formula).

    Parameters
    ----------
    radius_mm : float
        Ball radius ``R``, mm (flat and bull-nose cutters: the corner radius ``r``, the
        search then running around ``P + r n``).
    horizon_mm : float
        Excess horizon ``e``, mm.
    depth_mm : float
        Gouge search depth ``g``, mm.
    convexity_per_mm : ndarray
        ``1/rho`` at the samples (0 on flat or concave parts), 1/mm.
    core_radius_mm : float
        ``rho0 = R - r`` of a flat or bull-nose cutter, mm, added to the radius (0: ball).

    Returns
    -------
    ndarray
        Search radii, mm: ``rho0`` plus the ball's, itself between ``e + g`` and
        ``R + e + g``.
    """
    k = np.asarray(convexity_per_mm, dtype=float)
    factor = (1.0 + radius_mm * k) / (1.0 + horizon_mm * k)
    r = 1.1 * np.sqrt(2.0 * radius_mm * (horizon_mm + depth_mm) * factor) + depth_mm
    reach = np.maximum(r, horizon_mm + depth_mm)
    return core_radius_mm + np.minimum(reach, radius_mm + horizon_mm + depth_mm)


def grid_margin_mm(reach_limit_mm: float, pieces: Pieces, *, spread_mm: float = 0.0) -> float:
    r"""How far beyond the box a grid must hold midpoints for a search to see every candidate.

    A search around ``c`` of radius ``rho`` takes as candidate every piece whose midpoint
    ``m`` lies within ``rho + h + H`` of ``c`` (:meth:`SweepIndex.search`; ``h`` the longest
    half piece, ``H`` the tallest core: a flat or bull-nose piece's flank, a shank piece,
    stands up to ``H`` along its axis above its segment, and every point of the segment lies
    within ``h`` of ``m``), the pieces a search over all of them takes. A grid registers
    the midpoints within ``M`` of the box (the box widened by ``M`` on every side), and

    ``dist(m, box) <= dist(c, box) + |m - c| <= dist(c, box) + rho + h + H <= D + h + H``

    with ``D`` (``reach_limit_mm``) the farthest any search's ball reaches beyond the box,
    ``dist(c, box) + rho``. So ``M = D + h + H`` holds every candidate; less can drop one:
    a flat cutter's flank touching the box's edge with its bottom ``H`` beyond it, or a
    near search's centre ``P + r n`` standing ``r`` beyond the box (``D`` counts both, the
    piece grid's former ``D + h`` neither).

    Runs of pieces (:mod:`verification.piece_runs`) are gridded by their own midpoint
    ``mu``, within their spread ``s`` of every piece's midpoint, and the walk takes a run
    whose ``mu`` lies within ``rho + h + H + s`` of ``c``: the run of a candidate has
    ``dist(mu, box) <= M + s``, so the runs' grid needs ``M + max s`` (``spread_mm``), the
    same argument with the run for the piece. Both grids take their margin here.

    Parameters
    ----------
    reach_limit_mm : float
        ``D``: the farthest a search's ball reaches beyond the box, mm.
    pieces : Pieces
        The pieces the grid holds (their ``h`` and ``H``).
    spread_mm : float
        Largest spread of a run about its midpoint, mm (0: a grid of pieces).

    Returns
    -------
    float
        The margin, mm.
    """
    return reach_limit_mm + pieces.max_half_mm + pieces.max_height_mm + spread_mm


def candidate_reach_mm(radii_mm: FloatArray, pieces: Pieces, core_radius_mm: float | None
                       ) -> FloatArray:
    """How far from a search centre a piece's midpoint may lie and the piece matter, mm.

    A piece matters when a point ``K`` of its swept core lies within the search's ball
    about the centre, and every point of its segment lies within its half length ``h`` of
    its midpoint. With the segment's point ``C`` (a flat or bull-nose piece's core bottom
    centre), ``K = C + u + z a`` with ``|u| <= rho0`` across the axis and ``0 <= z <= H``
    (the core height) along it, so ``|K - C| <= hypot(rho0, H)``.

    ``core_radius_mm`` (``rho0``), for a near search of flat or bull-nose pieces whose radii
    are ``rho0`` plus a ball about the centre holding every core point that matters
    (:func:`near_search_radius_mm`, ``SweepIndex.search(rim_in_radii=True)``): the reach
    is ``radii - rho0 + hypot(rho0, H) + h``. None (a ball, a collision search, radii that
    bound the core's axis): ``radii + H + h``, the sum ``hypot`` bounds. On the 3-axis
    ``flat:6`` blade (``rho0 = H = 3``) 6.8 -> 5.0 mm: about half the candidates over the
    pieces' sheet.
    """
    height = pieces.max_height_mm
    if core_radius_mm is None:
        return radii_mm + pieces.max_half_mm + height
    flank = math.hypot(core_radius_mm, height) - core_radius_mm
    # widened by a rounding of the terms, so that it never falls below the true sum
    return radii_mm + pieces.max_half_mm + flank * (1.0 + 1e-12) + 1e-12


def reach_beyond_mm(centres: FloatArray, radii_mm: FloatArray, lo_mm: FloatArray,
                    hi_mm: FloatArray) -> float:
    """``max (dist(c, box) + rho)`` over searches: how far beyond ``[lo, hi]`` they reach, mm."""
    if centres.shape[0] == 0:
        return 0.0
    out = np.maximum(np.maximum(lo_mm - centres, centres - hi_mm), 0.0)
    return float(np.max(row_norms(out) + radii_mm))


@dataclass(frozen=True, eq=False)
class DexelResult:
    """Per dexel: the lowest entry of a piece that reaches the design point, and its block.

    Attributes
    ----------
    lam_mm : ndarray, shape (q,)
        ``min lam_in`` along the dexel, mm; ``inf`` when no candidate piece hit.
    move : ndarray of int64, shape (q,)
        Motion block of that piece, ``-1`` when none.
    shank : ndarray of bool, shape (q,)
        The piece was part of the shank.
    behind : ndarray of bool, shape (q,)
        The piece came from behind (its tool axis against the dexel).
    pairs : int
        Candidate pairs tested.
    piece : ndarray of int64, shape (q,), optional
        That piece, numbered as :meth:`SweepIndex.pieces` ``("far")`` numbers them (``-1``
        where none, or unknown: from another model, whose numbers do not compare; the lazy
        fine model's tie keys, :func:`~verification.fine_lazy.tie_keys`, order them
        alike); the tie rule's second key (default: all ``-1``).
    """

    lam_mm: FloatArray
    move: IntArray
    shank: NDArray[np.bool_]
    behind: NDArray[np.bool_]
    pairs: int = 0
    piece: IntArray = None  # type: ignore[assignment]  # filled in __post_init__

    def __post_init__(self) -> None:
        if self.piece is None:
            object.__setattr__(self, "piece", np.full(self.lam_mm.shape[0], -1,
                                                      dtype=np.int64))

    @staticmethod
    def empty(q: int) -> DexelResult:
        """No hit on ``q`` dexels."""
        return DexelResult(np.full(q, np.inf), np.full(q, -1, dtype=np.int64),
                           np.zeros(q, dtype=np.bool_), np.zeros(q, dtype=np.bool_))

    def merged(self, other: DexelResult) -> DexelResult:
        """Elementwise the first of two results on the same dexels (the tie rule)."""
        take = ranks_before_rows(other.lam_mm, other.piece, self.lam_mm, self.piece)
        return DexelResult(np.where(take, other.lam_mm, self.lam_mm),
                           np.where(take, other.move, self.move),
                           np.where(take, other.shank, self.shank),
                           np.where(take, other.behind, self.behind), self.pairs + other.pairs,
                           np.where(take, other.piece, self.piece))


@dataclass(eq=False)
class SweepIndex:
    """The swept cutter's pieces, with grids built on demand for each search radius.

    A search of radius ``rho`` uses the grid whose cell is closest to ``rho / 2`` among
    ``base_cell_mm * 2^k`` (so about ``5^3`` cells are scanned per query cell whatever the
    level of the iterative deepening, fewer where :data:`~verification.grid.CELLS_PER_PIECE`
    coarsens the cell); grids are built once and kept, and built again, wider, only for a
    search that reaches farther beyond the box than the one kept was built for.

    Parameters
    ----------
    ball, shank : Pieces
        Ball (or flat/bull-nose) pieces (near and collision searches) and shank pieces
        (collision only).
    radius_mm : float
        Cutter radius ``R``, mm.
    lo_mm, hi_mm : ndarray, shape (3,)
        Box of the design samples, mm.
    base_cell_mm : float
        Smallest grid cell, mm.
    reach_limit_mm : float
        How far beyond the box a search's ball is expected to reach (its centre's
        distance from the box plus its radius), mm: the grids hold every piece such a
        search takes (:func:`grid_margin_mm`). A search that reaches farther rebuilds the
        grid it walks for its own reach, so none misses a piece.
    max_pairs : int
        Candidate pairs per batch.
    corner_radius_mm : float or None
        Corner radius ``r`` of a flat or bull-nose cutter, mm (None: a ball, measured with
        the capsule kernel).
    compiled : bool
        Walk the grid in compiled code (the default): ball pieces measured in the walk
        (:func:`~verification.capsule_search.lowest_capsule_entries`), flat and bull-nose
        pieces too (:func:`~verification.sweep_search.lowest_sweep_entries`), rather
        than expanding candidate pairs in numpy batches (the same values; the tests' oracle).
    """

    ball: Pieces
    shank: Pieces
    radius_mm: float
    lo_mm: FloatArray
    hi_mm: FloatArray
    base_cell_mm: float
    reach_limit_mm: float
    max_pairs: int = 2_000_000
    corner_radius_mm: float | None = None
    compiled: bool = True
    _grids: dict[tuple[str, int], PieceGrid] = field(default_factory=dict, repr=False)
    _pieces: dict[str, Pieces] = field(default_factory=dict, repr=False)
    _sorted: dict[int, tuple[FloatArray, ...]] = field(default_factory=dict, repr=False)
    _runs: dict[tuple[str, int], tuple[PieceGrid, PieceRuns]] = field(default_factory=dict,
                                                                      repr=False)
    _piece_runs: dict[str, PieceRuns] = field(default_factory=dict, repr=False)
    _covers: dict[int, float] = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        # the collision search's pieces are the near search's, then the shank's: one copy
        # of them, the near search's its first rows (a view), not a second concatenated
        # copy (1 GB of the 7 M pieces of a bull-nose 5-axis blade program); the ball
        # pieces given become that view field by field as they are copied
        # (:meth:`Pieces.absorbing`), so the caller's no longer hold a copy of their own
        # even while this runs
        both = self.ball.absorbing(self.shank) if self.shank.size else self.ball
        self.ball = both.taken(slice(0, self.ball.size))
        self._pieces.update(near=self.ball, far=both)

    def pieces(self, which: str) -> Pieces:
        """The pieces a search uses: ``"near"`` ball only, ``"far"`` ball and shank.

        The near search's are the first rows of the collision search's (the same numbers:
        the tie rule's piece order).
        """
        return self._pieces[which]

    def _runs_of(self, which: str) -> PieceRuns:
        """The runs of :meth:`pieces` (:func:`~verification.piece_runs.piece_runs`).

        Built once over the collision search's pieces: a run never mixes ball and shank
        pieces, so the near search's are the runs that start among its rows, sharing the
        prefix sums (indexed by piece, the same numbers).
        """
        if which not in self._piece_runs:
            runs = piece_runs(self._pieces["far"], core_radius_mm=self.radius_mm - self._corner,
                              corner_radius_mm=self._corner)
            self._piece_runs["far"] = runs
            self._piece_runs["near"] = runs.taken(np.flatnonzero(runs.start < self.ball.size))
        return self._piece_runs[which]

    def _level(self, reach_mm: float) -> int:
        """``k`` of the grid whose cell ``base_cell_mm * 2^k`` suits searches of this reach."""
        target = max(reach_mm / CELL_PER_REACH, MIN_TARGET_CELL_MM)
        return max(0, int(np.round(np.log2(target / self.base_cell_mm))))

    def _kept_level(self, kept: Mapping[tuple[str, int], object], which: str,
                    reach_mm: float, built: bool) -> int:
        """The grid level for searches of ``reach_mm`` (:meth:`_level`).

        ``built``: rather the level of a grid of ``kept`` already built for these pieces,
        the one nearest in cell.
        """
        k = self._level(reach_mm)
        have = [level for kind, level in kept if kind == which]
        if built and have and (which, k) not in kept:
            k = min(have, key=lambda level: abs(level - k))
        return k

    def _grid(self, which: str, reach_mm: float, beyond_mm: float = 0.0, *,
              built: bool = False) -> PieceGrid:
        """The grid for searches of ``reach_mm``, built and kept on first use.

        ``beyond_mm``: how far beyond the box the searches reach (:func:`reach_beyond_mm`);
        a kept grid that holds less is built again for it. ``built``: rather a grid
        already built for these pieces, the one nearest in cell (only the cells walked
        differ, not the pieces found), than a new one.
        """
        k = self._kept_level(self._grids, which, reach_mm, built)
        grid = self._grids.get((which, k))
        if grid is None or self._covers[id(grid)] < beyond_mm:
            if grid is not None:
                self._sorted.pop(id(grid), None)
                del self._covers[id(grid)]
            pieces = self.pieces(which)
            cover = max(self.reach_limit_mm, beyond_mm)
            margin = grid_margin_mm(cover, pieces)
            grid = PieceGrid.build(pieces.mid, self.lo_mm - margin, self.hi_mm + margin,
                                   self.base_cell_mm * 2.0**k)
            self._grids[which, k] = grid
            self._covers[id(grid)] = cover
        return grid

    def _sorted_fields(self, which: str, grid: PieceGrid) -> tuple[FloatArray, ...]:
        """The fields the compiled capsule walk reads, in ``grid``'s order (read as met).

        ``mid, half_mm, a, e, ee, axis, height_mm``: copied on the first walk over the
        grid and kept with it, never for a grid only :meth:`pieces_within` walks (it reads
        the pieces in their own order: copies there were 840 MB on the 7 M pieces of the
        bull-nose 5-axis blade program).
        """
        kept = self._sorted.get(id(grid))
        if kept is None:
            pieces = self.pieces(which)
            kept = tuple(np.ascontiguousarray(v[grid.order], dtype=float)
                         for v in (pieces.mid, pieces.half_mm, pieces.a, pieces.e, pieces.ee,
                                   pieces.axis, pieces.height_mm))
            self._sorted[id(grid)] = kept
        return kept

    def _run_grid(self, which: str, reach_mm: float, beyond_mm: float = 0.0, *,
                  built: bool = False) -> tuple[PieceGrid, PieceRuns]:
        """Flat/bull-nose pieces' runs (:mod:`verification.piece_runs`), gridded by midpoint.

        The cell as :meth:`_grid` picks it, the margin :func:`grid_margin_mm` with the
        runs' spread; the runs returned are in the grid's order. ``built``: rather the
        runs' grid already built nearest in cell (the walk finds the same runs, over other
        cells) than a new grid and a copy of the runs in its order.
        """
        k = self._kept_level(self._runs, which, reach_mm, built)
        kept = self._runs.get((which, k))
        if kept is None or self._covers[id(kept[0])] < beyond_mm:
            if kept is not None:
                del self._covers[id(kept[0])]
            pieces = self.pieces(which)
            runs = self._runs_of(which)
            cover = max(self.reach_limit_mm, beyond_mm)
            margin = grid_margin_mm(cover, pieces, spread_mm=runs.max_spread_mm)
            grid = PieceGrid.build(runs.mid, self.lo_mm - margin, self.hi_mm + margin,
                                   self.base_cell_mm * 2.0**k)
            self._runs[which, k] = grid, runs.taken(grid.order)
            self._covers[id(grid)] = cover
        return self._runs[which, k]

    def search(self, which: str, points: FloatArray, dirs: FloatArray, centres: FloatArray,
               radii_mm: FloatArray, *, below_mm: FloatArray | None = None,
               below_piece: IntArray | None = None, rim_in_radii: bool = False
               ) -> DexelResult:
        """Lowest entries along dexels among pieces within ``radii`` of ``centres``.

        Parameters
        ----------
        which : {"near", "far"}
            Near search (ball pieces) or collision search (ball and shank pieces).
        points, dirs : ndarray, shape (q, 3)
            Dexel origins (design samples, mm) and unit directions.
        centres : ndarray, shape (q, 3)
            Search centres, mm.
        radii_mm : ndarray, shape (q,)
            Search radii for piece *segments*, mm (the longest half piece is added).
        below_mm : ndarray, shape (q,), optional
            Values already known on the dexels, which the caller keeps where lower: the
            compiled ball search then seeks only lower ones (elsewhere a dexel may hold
            any value or none; the lower of the two is the same).
        below_piece : ndarray of int64, shape (q,), optional
            The pieces of ``below_mm`` (``-1``: none): an equal value of a piece before
            it is sought too (the tie rule).
        rim_in_radii : bool
            A near search of flat or bull-nose pieces whose radii are the core's radius
            plus a ball about the centre holding every core point that matters
            (:func:`near_search_radius_mm`, the searches of :class:`~verification.search.Dexels`):
            candidates within the tighter reach of :func:`candidate_reach_mm`. Otherwise
            (default) the radii bound the core's axis, and its bottom stands up to its
            height below.

        Returns
        -------
        DexelResult
        """
        q = points.shape[0]
        out = DexelResult.empty(q)
        pieces = self.pieces(which)
        if q == 0 or pieces.size == 0:
            return out
        tight = rim_in_radii and which == "near" and self.corner_radius_mm is not None
        reach = candidate_reach_mm(radii_mm, pieces,
                                   self.radius_mm - self._corner if tight else None)
        beyond = reach_beyond_mm(centres, radii_mm, self.lo_mm, self.hi_mm)
        if self.corner_radius_mm is not None and self.compiled:
            # the same, flat and bull-nose pieces: over runs of consecutive pieces, bounds
            # and exact entries in the walk
            lam, hit, behind, pairs = self.sweep_entries(
                which, points, dirs, centres, reach, below_mm=below_mm, below_piece=below_piece,
                beyond_mm=beyond)
            return _scattered(out, lam, hit, behind, pairs, pieces, points)
        grid = self._grid(which, float(np.median(reach)), beyond)
        spans = grid.span_of(reach)
        if self.compiled:
            # one walk, each dexel over its own span of cells
            mid, half, a, e, ee, axis, _ = self._sorted_fields(which, grid)
            lam, hit, behind, pairs = lowest_capsule_entries(
                grid, spans, points, dirs, centres, reach, mid, half, a, e, ee, axis,
                self.radius_mm, BEHIND_COSINE, below_mm=below_mm, below_piece=below_piece)
            return _scattered(out, lam, hit, behind, pairs, pieces, points)
        pairs = 0
        for span in np.unique(spans):
            sel = np.flatnonzero(spans == span)
            cen, lim2 = centres[sel], reach[sel] ** 2
            for query, piece in grid.candidate_batches(cen, int(span),
                                                       max_pairs=self.max_pairs):
                dm = pieces.mid[piece] - cen[query]
                close = np.einsum("ij,ij->i", dm, dm) <= lim2[query]
                del dm
                qi, piece = sel[query[close]], piece[close]
                pairs += int(qi.shape[0])
                if qi.shape[0] == 0:
                    continue
                if self.corner_radius_mm is None:
                    self._capsules(qi, piece, pieces, points, dirs, out)
                else:
                    self._cutters(qi, piece, pieces, points, dirs, out)
        return DexelResult(out.lam_mm, out.move, out.shank, out.behind, pairs, out.piece)

    def sweep_entries(self, which: str, points: FloatArray, dirs: FloatArray,
                      centres: FloatArray, reach_mm: FloatArray, *,
                      below_mm: FloatArray | None = None,
                      below_piece: IntArray | None = None, beyond_mm: float | None = None,
                      built: bool = False
                      ) -> tuple[FloatArray, IntArray, NDArray[np.bool_], int]:
        """Flat/bull-nose pieces: the lowest entry per dexel and its piece (compiled walk).

        :func:`~verification.sweep_search.lowest_sweep_entries` over the runs of
        :meth:`pieces` whose midpoints lie within ``reach_mm`` of the centres (the
        piece's index into :meth:`pieces`, ``-1`` where none). ``beyond_mm``: how far
        beyond the box the searches reach (default: ``reach_mm`` about the centres, which
        holds the pieces' halves and heights already). ``built``: over a runs' grid
        already built if any (:meth:`_run_grid`).
        """
        pieces = self.pieces(which)
        if beyond_mm is None:
            beyond_mm = reach_beyond_mm(centres, reach_mm, self.lo_mm, self.hi_mm)
        runs_grid, runs = self._run_grid(which, float(np.median(reach_mm)), beyond_mm,
                                         built=built)
        return lowest_sweep_entries(
            runs_grid, runs_grid.span_of(reach_mm + runs.max_spread_mm), points, dirs,
            centres, reach_mm, runs, pieces.mid, pieces.half_mm, pieces.a, pieces.e,
            pieces.axis, pieces.height_mm, core_radius_mm=self.radius_mm - self._corner,
            corner_radius_mm=self._corner, behind_cosine=BEHIND_COSINE, below_mm=below_mm,
            below_piece=below_piece)

    def runs_grid(self, which: str, reach_mm: FloatArray, centres: FloatArray
                  ) -> tuple[PieceGrid, PieceRuns]:
        """The runs' grid for walks of ``reach_mm`` about ``centres`` (one already built if any).

        :meth:`_run_grid` at the median reach, holding every run those walks may take.
        """
        return self._run_grid(which, float(np.median(reach_mm)),
                              reach_beyond_mm(centres, reach_mm, self.lo_mm, self.hi_mm),
                              built=True)

    def pieces_entering_below(self, which: str, points: FloatArray, dirs: FloatArray,
                              centres: FloatArray, reach_mm: FloatArray,
                              below_mm: FloatArray, widen_mm: float,
                              listed: IntArray | None = None) -> IntArray:
        """Flat/bull-nose pieces whose widened sweep may enter a dexel below ``below_mm``.

        Indices into :meth:`pieces`, sorted: the sweep widened by ``widen_mm``
        (:func:`~verification.sweep_below.pieces_entering_below`, ``listed`` the prefix
        sums of pieces left out as listed already), walked over a runs' grid already
        built if any (:meth:`_run_grid`).
        """
        pieces = self.pieces(which)
        if points.shape[0] == 0 or pieces.size == 0:
            return np.zeros(0, dtype=np.int64)
        runs_grid, runs = self.runs_grid(which, reach_mm, centres)
        marked = pieces_entering_below(
            runs_grid, runs_grid.span_of(reach_mm + runs.max_spread_mm), points, dirs,
            centres, reach_mm, below_mm, runs, pieces.mid, pieces.half_mm, pieces.a,
            pieces.e, pieces.axis, pieces.height_mm,
            core_radius_mm=self.radius_mm - self._corner, corner_radius_mm=self._corner,
            widen_mm=widen_mm, listed=listed)
        return np.flatnonzero(marked).astype(np.int64)

    def pieces_within(self, which: str, centres: FloatArray, radii_mm: FloatArray
                      ) -> IntArray:
        """Pieces (indices into :meth:`pieces`, sorted) within ``radii_mm`` of a centre.

        A piece's reach is its core: the segment its bottom centre moves along and up to
        ``height_mm`` above it along its axis (a flat or bull-nose cutter's flank; 0 for a
        ball). A core point ``z`` up the axis stands at most ``z`` farther from the centre
        than its foot on the segment, so a piece is kept where its exact point-segment
        distance is within ``radii_mm + height_mm``, over the grid's candidates.

        Parameters
        ----------
        which : {"near", "far"}
            Ball pieces, or ball and shank pieces.
        centres : ndarray, shape (q, 3)
            Points, mm.
        radii_mm : ndarray, shape (q,)
            Distance from each point, mm.
        """
        pieces = self.pieces(which)
        if centres.shape[0] == 0 or pieces.size == 0:
            return np.zeros(0, dtype=np.int64)
        reach = radii_mm + pieces.max_half_mm + pieces.max_height_mm
        # a few points: whichever grid the searches built walks them (no grid of its own)
        grid = self._grid(which, float(np.median(reach)),
                          reach_beyond_mm(centres, radii_mm, self.lo_mm, self.hi_mm), built=True)
        spans = grid.span_of(reach)
        found = []
        for span in np.unique(spans):
            sel = np.flatnonzero(spans == span)
            for query, piece in grid.candidate_batches(centres[sel], int(span),
                                                       max_pairs=self.max_pairs):
                v = centres[sel[query]] - pieces.a[piece]
                ee = pieces.ee[piece]
                f = np.clip(np.einsum("ij,ij->i", v, pieces.e[piece])
                            / np.where(ee > 0.0, ee, 1.0), 0.0, 1.0)
                gap = row_norms(v - f[:, None] * pieces.e[piece])
                found.append(piece[gap <= radii_mm[sel[query]] + pieces.height_mm[piece]])
        return np.unique(np.concatenate(found)) if found else np.zeros(0, dtype=np.int64)

    def _capsules(self, qi: IntArray, piece: IntArray, pieces: Pieces, points: FloatArray,
                  dirs: FloatArray, out: DexelResult) -> None:
        """Ball pieces: every pair measured in closed form, folded into ``out``."""
        lam_in, lam_out = line_capsule_interval(
            points[qi], dirs[qi], pieces.a[piece], pieces.e[piece], pieces.ee[piece],
            self.radius_mm)
        _fold_min(qi, *_values(lam_in, lam_out, pieces.axis[piece], dirs[qi]), piece,
                  pieces, points, out)

    def _cutters(self, qi: IntArray, piece: IntArray, pieces: Pieces, points: FloatArray,
                 dirs: FloatArray, out: DexelResult) -> None:
        """Flat/bull-nose pieces: the lowest-bound pair per dexel, then the ones below."""
        bound, _ = sweep_entry_bound(points[qi], dirs[qi], pieces.a[piece], pieces.e[piece],
                                     pieces.axis[piece], pieces.height_mm[piece],
                                     core_radius_mm=self.radius_mm - self._corner,
                                     corner_radius_mm=self._corner)
        # a bound may equal a tied value (a flat bottom's zlo): pairs within the tie slack
        # are measured (TIE_SLACK_MM says what it covers)
        todo = np.flatnonzero(bound < out.lam_mm[qi] + TIE_SLACK_MM)
        if todo.shape[0] == 0:
            return
        # round 1: per dexel the pair of lowest bound (pairs are sorted by dexel)
        key = np.lexsort((bound[todo], qi[todo]))
        ordered = todo[key]
        first = ordered[np.r_[True, qi[ordered][1:] != qi[ordered][:-1]]]
        self._measure(qi[first], piece[first], pieces, points, dirs, out)
        rows = np.setdiff1d(todo, first, assume_unique=True)
        rows = rows[bound[rows] < out.lam_mm[qi[rows]] + TIE_SLACK_MM]
        self._measure(qi[rows], piece[rows], pieces, points, dirs, out)

    @property
    def _corner(self) -> float:
        return float(self.corner_radius_mm or 0.0)

    def _measure(self, q: IntArray, piece: IntArray, pieces: Pieces, points: FloatArray,
                 dirs: FloatArray, out: DexelResult) -> None:
        """Flat/bull-nose pairs (grouped by dexel) measured exactly, folded into ``out``."""
        if q.shape[0] == 0:
            return
        d, axis = dirs[q], pieces.axis[piece]
        lam_in, lam_out = line_sweep_interval(
            points[q], d, pieces.a[piece], pieces.e[piece], axis, pieces.height_mm[piece],
            core_radius_mm=self.radius_mm - self._corner, corner_radius_mm=self._corner,
            exit_wanted=np.einsum("ij,ij->i", axis, d) < BEHIND_COSINE)
        _fold_min(q, *_values(lam_in, lam_out, axis, d), piece, pieces, points, out)


def _scattered(out: DexelResult, lam: FloatArray, hit: IntArray, behind: NDArray[np.bool_],
               pairs: int, pieces: Pieces, points: FloatArray) -> DexelResult:
    """A compiled walk's per-dexel lowest values and pieces (``-1``: none) written into ``out``."""
    qi = np.flatnonzero(hit >= 0)
    hit = hit[qi]
    out.lam_mm[qi] = lam[qi]
    out.move[qi] = pieces.moves_at(hit, points[qi])
    out.shank[qi] = pieces.shank[hit]
    out.behind[qi] = behind[qi]
    out.piece[qi] = hit
    return DexelResult(out.lam_mm, out.move, out.shank, out.behind, pairs, out.piece)


def _values(lam_in: FloatArray, lam_out: FloatArray, axis: FloatArray, dirs: FloatArray
            ) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Remaining material each pair leaves on its dexel, and whether it came from behind."""
    f = np.ascontiguousarray
    return pair_values(f(lam_in, dtype=float), f(lam_out, dtype=float),
                       np.einsum("ij,ij->i", axis, dirs), BEHIND_COSINE)


def _fold_min(query: IntArray, value: FloatArray, behind: NDArray[np.bool_], piece: IntArray,
              pieces: Pieces, points: FloatArray, out: DexelResult) -> None:
    """Fold per-pair values into per-query firsts (pairs are grouped by query).

    Per query the least value, of equal ones the smallest piece index, taken where it
    ranks before what ``out`` holds (the tie rule, :meth:`DexelResult.before`).
    """
    starts = np.flatnonzero(np.r_[True, query[1:] != query[:-1]])
    best = np.minimum.reduceat(value, starts)
    group = np.repeat(np.arange(starts.shape[0]), np.diff(np.r_[starts, query.shape[0]]))
    hit = np.flatnonzero((value == best[group]) & np.isfinite(value))
    if hit.shape[0] == 0:
        return
    # of the tied pairs of each query, the one of smallest piece index
    hit = hit[np.lexsort((piece[hit], group[hit]))]
    g = group[hit]
    first = hit[np.r_[True, g[1:] != g[:-1]]]
    gq = query[first]
    better = ranks_before_rows(value[first], piece[first], out.lam_mm[gq], out.piece[gq])
    gq, first = gq[better], first[better]
    out.lam_mm[gq] = value[first]
    out.move[gq] = pieces.moves_at(piece[first], points[gq])
    out.shank[gq] = pieces.shank[piece[first]]
    out.behind[gq] = behind[first]
    out.piece[gq] = piece[first]
