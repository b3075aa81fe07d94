"""The swept cutter modelled finely around a few points: figures free of how moves cut a path.

The whole-program model keeps its pieces within ``replay_tol_mm + merge_tol_mm`` (0.5 + 1
um by default) of the true sweep, *per move*: the replay samples each block at its own
``u = j / n`` and merging starts afresh wherever the instances differ, so one path written
as a few long moves or as many short ones is measured up to that apart (1.5 um is 20 % of
a 8 um gouge, a third of a 5 um scallop). Around a handful of points the sweep can be
modelled far better at little cost: :meth:`FineModel.around`

1. lists the coarse near pieces that come within ``reach`` of the near-search centres
   the caller's searches may use (:meth:`~verification.dexels.SweepIndex.pieces_within`;
   of flat and bull-nose pieces a compiled walk over the coarse search's runs,
   :meth:`FineModel.rows_within`), and the joint-space segments of the replay they stand
   for (``motion.rows``, one instance either side);
2. samples those stretches again in joint space to a fine chord tolerance
   (``VerifyOptions.extremes_tol_mm``, 20 nm; :func:`~verification.replay.replay_rows`)
   and keeps every chord (no merging);
3. builds the near pieces and a near-search index of those stretches alone, whose levels
   stop at the level asked for.

:meth:`FineModel.around_each` does so for several asks at once (the deepest gouge's and the
largest scallop's refinements): their stretches are replayed in one batch, a segment two
asks share once, and indexed once (its grids sized by its few pieces,
:data:`~verification.grid.CELLS_PER_PIECE`); each ask keeps its own levels and depth.

Soundness: every coarse piece lies within ``model_tol`` of the true sweep, and every fine
piece within ``chord_tol`` of it, so a stretch none of whose coarse pieces comes within
``r + model_tol + chord_tol`` of a near-search centre ``c`` has no fine piece within ``r``
of ``c``: the stretches left out cannot change what a near search of radius ``r`` around
``c`` finds. The searches the fine model must answer are those at every design point the
caller's levels may visit, each around its own centre ``c = P + r_c n`` (``r_c`` the
corner radius, the ball's radius for a ball). That centre moves faster than the design
point on a convex surface: ``dc = dP + r_c dn`` and ``|dn| <= kappa |dP|``, so by up to
``(1 + r_c kappa)`` times as much (3 to 5 times for a 3 mm ball on a 1 mm convex edge),
and a parameter box maps to a sheared, stretched patch of space. Rather than bound
``kappa`` and the shear, :func:`box_centres` measures the centres themselves on a grid over
each parameter box the levels may visit (the wrap of a closed ``t`` and the clip of an
open one as the levels apply them), with the longest diagonal of a cell of that grid as
how far a centre inside the cell may stand from the cell's corners. :meth:`FineModel.around`
keeps every stretch that comes within ``r`` of a ball holding those centres, widened by
the slack.
The collision search (shank, from behind) stays the coarse model's.

A flat or bull-nose cutter's fine pieces hold their axis fixed, so where the axis turns the
stretches near the boxes are millions of pieces (over 20 GB on the bull-nose 5-axis
blade): its fine searches are answered per batch of dexels from the segments that can
decide them only (:mod:`verification.fine_lazy`; ``FineModel(lazy=False)`` keeps the full
method above, the tests' oracle). Lazily only where the full model would be large
(:meth:`FineModel.full_pieces` over :data:`FULL_PIECES`): the lazy searches replay each
deciding segment once and keep its fine pieces across batches
(:data:`~verification.fine_lazy.KEPT_PIECES` of them at most), but step 2's walk over the
coarse pieces runs for every batch.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Final

import numba
import numpy as np
from numpy.typing import NDArray

from machines import Machine, forward
from toolpath.surface import ParametricSurface

from .capsule_search import spread_slots, walk_shape
from .dexels import SweepIndex
from .fine_lazy import LazyFineSweeps
from .grid import span_indices
from .pieces import Pieces
from .replay import ToolMotion, replay_rows
from .samples import surface_points_normals
from .search import Dexels
from .vectors import row_norms

__all__ = ["BOX_GRID", "FULL_PIECES", "FineAsk", "FineModel", "PiecesOf", "box_centres",
           "on_surface"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: The swept cutter's near pieces of replayed stretches, modelled finely (no merging).
PiecesOf = Callable[[ToolMotion], Pieces]

#: Centres measured per side of a parameter box (:func:`box_centres`).
BOX_GRID: Final[int] = 9

#: Most fine pieces the full method builds at once (:meth:`FineModel.full_pieces`): a
#: memory budget of about 1.7 GB. The full fine model holds per piece its fields
#: (:class:`~verification.pieces.Pieces`, ~20 floats), their copies in its runs' grid
#: order, the runs' prefix sums and the replayed instances it came from: head -n 3000 of
#: the bull-nose blade program builds 3.44 million pieces in a verify whose whole peak RSS
#: is 1.49 GB (head -n 700: 0.93 million, 0.63 GB), so under 430 bytes a piece. The whole
#: program's would be tens of millions (killed at 23 GB); beyond the budget the searches
#: are answered per batch of dexels (:class:`~verification.fine_lazy.LazyFineSweeps`),
#: which costs more CPU where the full model is small (head -n 700: verify CPU 121 s
#: against 44 s; head -n 3000: 166 s against main's full method's 159 s).
FULL_PIECES: Final[int] = 4_000_000


def on_surface(surface: ParametricSurface, t: FloatArray, s: FloatArray
               ) -> tuple[FloatArray, FloatArray]:
    """Parameters brought onto the surface: ``t`` wrapped if closed, else both clipped.

    ``t`` is wrapped on a closed-``t`` surface and clipped to ``[0, 1]`` otherwise, ``s``
    clipped: the refinement's levels and :func:`box_centres` alike (the boxes hold the
    points the levels search only if both treat them the same).
    """
    closed = bool(getattr(surface, "closed_t", False))
    return (np.mod(t, 1.0) if closed else np.clip(t, 0.0, 1.0)), np.clip(s, 0.0, 1.0)


def box_centres(surface: ParametricSurface, t: FloatArray, s: FloatArray, half_t: float,
                half_s: float, corner_mm: float) -> tuple[FloatArray, FloatArray]:
    """Near-search centres over parameter boxes, and how far any centre of a box may stray.

    The box of each ``(t, s)`` is ``[t - half_t, t + half_t] x [s - half_s, s + half_s]``,
    ``t`` wrapped on a closed-``t`` surface and both clipped to ``[0, 1]`` otherwise (as
    the refinement's levels treat the points they search). Its centres ``P + r_c n`` are
    measured on a ``BOX_GRID x BOX_GRID`` grid of it; a point of the box lies in one of the
    grid's cells, and where the map ``(t, s) -> c`` is affine over a cell, a centre in it
    is a convex combination of the cell's corner centres, within half the cell's longest
    diagonal of one of them. The slack returned, the longest diagonal of any cell of the
    box, is twice that: the other half covers the map's departure from affine over a
    cell (``|c''| h^2 / 8``, for a cell ``h`` of a twelfth of a grid step a small fraction
    of the ``|c'| h`` diagonal itself).

    Parameters
    ----------
    surface : ParametricSurface
        The design surface.
    t, s : ndarray, shape (k,)
        The boxes' middles.
    half_t, half_s : float
        The boxes' half-widths in ``t`` and ``s``.
    corner_mm : float
        ``r_c``: the near search's centres stand this far along the normal, mm.

    Returns
    -------
    centres : ndarray, shape (k, BOX_GRID ** 2, 3)
        The centres measured, box by box, mm.
    slack_mm : ndarray, shape (k,)
        Of each box: how far a centre anywhere in it may stand from the nearest centre
        measured, mm.
    """
    off = np.linspace(-1.0, 1.0, BOX_GRID)
    tt = t[:, None, None] + half_t * off[None, :, None] + np.zeros((1, 1, BOX_GRID))
    ss = s[:, None, None] + half_s * off[None, None, :] + np.zeros((1, BOX_GRID, 1))
    tt, ss = on_surface(surface, tt, ss)
    points, normals, _ = surface_points_normals(surface, tt.ravel(), ss.ravel())
    c = (points + corner_mm * normals).reshape(t.shape[0], BOX_GRID, BOX_GRID, 3)
    diagonal = np.maximum(row_norms((c[:, 1:, 1:] - c[:, :-1, :-1]).reshape(-1, 3)),
                          row_norms((c[:, 1:, :-1] - c[:, :-1, 1:]).reshape(-1, 3)))
    slack = diagonal.reshape(t.shape[0], -1).max(axis=1)
    return c.reshape(t.shape[0], -1, 3), slack


@dataclass(frozen=True, eq=False)
class FineAsk:
    """Near searches one refinement asks of the fine model (:meth:`FineModel.around_each`).

    Attributes
    ----------
    centres : ndarray, shape (k, q, 3)
        Per box, near-search centres ``P + r_c n`` measured over it, mm
        (:func:`box_centres`).
    slack_mm : ndarray, shape (k,)
        Per box: the searches hold for any centre this close to one of its ``centres``.
    convexity_per_mm : ndarray, shape (k,)
        The convexity each box's near searches are sized with, 1/mm.
    level_mm : float
        Last level of the near search (one of the coarse levels): more material than this
        is reported as beyond the horizon.
    depth_mm : float
        Gouge depth the near search is sized for, mm.
    """

    centres: FloatArray
    slack_mm: FloatArray
    convexity_per_mm: FloatArray
    level_mm: float
    depth_mm: float


class FineModel:
    """Fine near searches around given points, from the coarse model of the whole program.

    Parameters
    ----------
    motion : ToolMotion
        The replay (it must have kept its joint segments, ``motion.rows``).
    machine : Machine
        The machine it was replayed on.
    coarse : Dexels
        The whole-program searches (their index finds the stretches; their levels, depth
        and method are the fine searches' too).
    pieces_of : callable
        ``motion -> near pieces`` of replayed stretches, without merging.
    model_tol_mm : float
        How far the coarse pieces may stand from the true sweep, mm (replay + merge).
    chord_tol_mm : float
        The fine replay's chord tolerance, mm.
    pieces_per_rad : float
        Fine pieces a segment is cut into per radian its tool axis turns
        (:func:`~verification.pieces.cutter_pieces`: ``reach / (2 rot_tol)``); 0 for a
        ball, whose pieces do not split by the turn.
    lazy : bool or None
        Flat/bull-nose searches answered per batch of dexels from the segments that can
        decide them (:class:`~verification.fine_lazy.LazyFineSweeps`); False: every
        segment near the boxes replayed and indexed at once (the full method); None: lazily
        where the full method would build more than ``full_pieces`` pieces.
    full_pieces : int
        The full method's budget of fine pieces (:data:`FULL_PIECES`).
    """

    def __init__(self, motion: ToolMotion, machine: Machine, coarse: Dexels,
                 pieces_of: PiecesOf, *, model_tol_mm: float, chord_tol_mm: float,
                 pieces_per_rad: float = 0.0, lazy: bool | None = None,
                 full_pieces: int = FULL_PIECES) -> None:
        self.motion, self.machine, self.coarse = motion, machine, coarse
        self.pieces_of = pieces_of
        self.model_tol_mm = model_tol_mm
        self.chord_tol_mm = chord_tol_mm
        self.pieces_per_rad = pieces_per_rad
        self.lazy = lazy
        self.full_pieces_budget = full_pieces

    @property
    def can_build_lazily(self) -> bool:
        """Flat/bull-nose searches may be answered per batch (:mod:`verification.fine_lazy`)."""
        index = self.coarse.index
        return self.lazy is not False and index.corner_radius_mm is not None and index.compiled

    def builds_lazily(self, rows: IntArray) -> bool:
        """The searches over ``rows`` are answered per batch rather than by the full method.

        Always when ``lazy`` is True, never when False (or for a ball); when None, where
        :meth:`full_pieces` of ``rows`` exceeds the budget.
        """
        if not self.can_build_lazily:
            return False
        return self.lazy is True or self.full_pieces(rows) > self.full_pieces_budget

    def full_pieces(self, rows: IntArray) -> int:
        """About how many fine pieces the full method would build for ``rows``, before it does.

        Per segment ``max(1, ceil(pieces_per_rad * turn))``, ``turn`` the angle its tool
        axis turns through from its start to its middle and on to its end (forward
        kinematics at three joint positions, not the replay): the axis split of
        :func:`~verification.pieces.cutter_pieces`, which dominates where the axis turns
        (the chord rule's and the length's splits add a few per segment). A lower bound
        on the turn, so the count is an estimate, not a bound; either method is exact.
        """
        kept = self.motion.rows
        if kept is None or rows.shape[0] == 0:
            return int(rows.shape[0])
        j0, j1 = kept.start[rows], kept.end[rows]
        a0, am, a1 = (forward(self.machine, j)[1] for j in (j0, 0.5 * (j0 + j1), j1))
        turn = sum(np.arccos(np.clip(np.einsum("ij,ij->i", u, v), -1.0, 1.0))
                   for u, v in ((a0, am), (am, a1)))
        return int(np.maximum(1.0, np.ceil(self.pieces_per_rad * turn)).sum())

    @property
    def segment_moves(self) -> IntArray:
        """The block of each joint segment of the replay (``motion.rows.move``)."""
        rows = self.motion.rows
        assert rows is not None
        return rows.move

    def level_for_mm(self, deviation_mm: float) -> float:
        """The first near-search level at or above ``deviation_mm`` (else the horizon)."""
        return next((h for h in self.coarse.horizons if h >= deviation_mm),
                    self.coarse.horizon)

    def _instances(self, pieces: Pieces, hit: IntArray | slice) -> tuple[IntArray, IntArray]:
        """Per listed piece, the first and last replay instance it stands for.

        Every instance whose arc lies in ``[arc0, arc1]`` and one either side (a centre
        standing still while the axis turns repeats its arc over several instances).
        """
        rows = self.motion.rows
        assert rows is not None
        n_inst = rows.of_instance.shape[0]
        path = pieces.path_arc_mm
        lo = np.clip(np.searchsorted(path, pieces.arc0_mm[hit], side="left") - 1, 0, n_inst - 1)
        hi = np.clip(np.searchsorted(path, pieces.arc1_mm[hit], side="right"), 0, n_inst - 1)
        return lo, hi

    def _rows(self, pieces: Pieces, hit: IntArray) -> IntArray:
        """Joint segments (sorted, unique) the listed near pieces stand for."""
        lo, hi = self._instances(pieces, hit)
        inst = span_indices(lo, np.maximum(hi - lo + 1, 1))
        return np.unique(self.motion.rows.of_instance[inst])

    def row_spans(self, pieces: Pieces) -> tuple[IntArray, IntArray] | None:
        """Per piece, the first and last joint segment :meth:`_rows` names for it.

        Every segment it names lies between the two (the replay's instances are in path
        order, so their segments are nondecreasing); None where they are not.
        """
        of = self.motion.rows.of_instance
        if of.shape[0] == 0 or np.any(of[1:] < of[:-1]):
            return None
        lo, hi = self._instances(pieces, slice(None))
        return of[lo].astype(np.int32), of[np.maximum(hi, lo)].astype(np.int32)

    def rows_within(self, centres: FloatArray, radii_mm: FloatArray) -> IntArray:
        """Joint segments (sorted, unique) whose sweep may come within ``radii_mm`` of a centre.

        Those of every coarse near piece within ``radii_mm + model_tol + chord_tol``: a
        coarse piece stands within ``model_tol`` of the true sweep, a fine one within
        ``chord_tol`` of it. Of a flat or bull-nose cutter's pieces (millions on a 5-axis
        program, a few hundred thousand within each ball) the runs the coarse searches
        gridded are walked in compiled code (:func:`_pieces_near`), rather than every
        candidate pair in numpy over a grid of the pieces built for it.
        """
        ev = self.coarse
        index = ev.index
        radii = radii_mm + self.model_tol_mm + self.chord_tol_mm
        if index.corner_radius_mm is not None and index.compiled:
            hit = _runs_within(index, centres, radii)
        else:
            hit = index.pieces_within("near", centres, radii)
        if hit.shape[0] == 0:
            return np.zeros(0, dtype=np.int64)
        return self._rows(index.pieces("near"), hit)

    def rows_around(self, centres: FloatArray, slack_mm: FloatArray,
                    convexity_per_mm: FloatArray, *, level_mm: float, depth_mm: float
                    ) -> tuple[IntArray, FloatArray, FloatArray]:
        """Joint segments the near searches around any centre of some boxes may need.

        Each box's centres (:func:`box_centres`) are enclosed in one ball, about their
        mean, of radius their farthest distance from it plus the box's slack: a centre
        anywhere in the box lies in that ball, and the near search around it (radius
        ``r``) within ``r`` more of it. One query per box rather than per centre.

        Returns
        -------
        rows : ndarray of int64
            :meth:`rows_within` those balls widened by ``r``.
        middles : ndarray, shape (k, 3)
            The balls' centres, mm.
        reach_mm : ndarray, shape (k,)
            Their radii plus ``r``, mm.
        """
        ev = self.coarse
        middles = centres.mean(axis=1)
        spread = np.sqrt(np.max(np.sum((centres - middles[:, None, :]) ** 2, axis=2), axis=1))
        reach = ev.near_radius_mm(level_mm, depth_mm, convexity_per_mm) + spread + slack_mm
        return self.rows_within(middles, reach), middles, reach

    def around(self, centres: FloatArray, slack_mm: FloatArray, convexity_per_mm: FloatArray,
               *, level_mm: float, depth_mm: float) -> Dexels | None:
        """Fine near searches, exact up to ``level_mm``, around any centre of some boxes.

        One :class:`FineAsk` of :meth:`around_each` (its parameters are the ask's fields).

        Returns
        -------
        Dexels or None
            None when no piece comes near (nothing cut there).
        """
        return self.around_each([FineAsk(centres, slack_mm, convexity_per_mm, level_mm,
                                         depth_mm)])[0]

    def around_each(self, asks: Sequence[FineAsk]) -> list[Dexels | None]:
        """Fine near searches for each ask, from one replay and one index of them all.

        The stretches every ask may need (:meth:`rows_around`, each with its own level and
        depth) are replayed together, a segment two asks share once, and indexed once;
        each ask gets its own searches (levels up to its ``level_mm``, its depth) over
        that index. Each ask's searches around its centres meet only pieces of its own
        segments (the soundness argument above), and the replay samples every segment on
        its own, so they meet the pieces its own model holds; the one difference is where
        another ask's segment comes just before one of its stretches: the stretch then
        starts at that segment's end (posed at ``u = 1``) rather than at its own first
        segment's start, the same joints up to their last bit. Figures the same, bit for
        bit, on the bench's blade programs (``tests/verification/test_fine_model_shared.py``
        checks it on a dome).

        Returns
        -------
        list of Dexels or None
            Per ask; None where no piece comes near its boxes (nothing cut there).
        """
        ev = self.coarse
        found = [self.rows_around(a.centres, a.slack_mm, a.convexity_per_mm,
                                  level_mm=a.level_mm, depth_mm=a.depth_mm) for a in asks]
        near = [i for i, (rows, _, _) in enumerate(found) if rows.shape[0]]
        out: list[Dexels | None] = [None] * len(asks)
        if not near:
            return out
        index: SweepIndex | LazyFineSweeps
        rows = np.unique(np.concatenate([found[i][0] for i in near]))
        middles = np.concatenate([found[i][1] for i in near])
        reach = np.concatenate([found[i][2] for i in near])
        if self.builds_lazily(rows):
            index = LazyFineSweeps(self, middles, reach)
        else:
            index = self.index_of(self.fine_pieces(rows), middles, reach)
        for i in near:
            level = asks[i].level_mm
            levels = (*(h for h in ev.horizons if h < level), level)
            out[i] = Dexels(index, ev.radius, levels, asks[i].depth_mm, ev.method,
                            corner_radius=ev.corner, model_tol_mm=self.chord_tol_mm)
        return out

    def fine_pieces(self, rows: IntArray) -> Pieces:
        """The near pieces of some joint segments replayed finely (stretches not joined)."""
        ev = self.coarse
        stretch, starts = replay_rows(self.motion, self.machine, rows,
                                      chord_tol_mm=self.chord_tol_mm, radius_mm=ev.radius)
        fine = self.pieces_of(stretch)
        # no piece joins one stretch's end to the next one's start
        arc = fine.path_arc_mm
        gap_lo, gap_hi = arc[starts[1:] - 1], arc[starts[1:]]
        mid = 0.5 * (fine.arc0_mm + fine.arc1_mm)
        j = np.minimum(np.searchsorted(gap_hi, mid, side="left"), max(gap_hi.shape[0] - 1, 0))
        joins = (mid > gap_lo[j]) & (mid < gap_hi[j]) if gap_hi.shape[0] else np.zeros(
            mid.shape[0], dtype=bool)
        return fine.taken(~joins)

    def index_of(self, fine: Pieces, middles: FloatArray, reach_mm: FloatArray
                 ) -> SweepIndex:
        """A near-search index of fine pieces for searches within balls ``(middles, reach)``."""
        # always the compiled walk: the very walk the coarse searches use (checked against
        # the pair search there), whereas pairs over the dense fine pieces grow as their
        # square; an uncompiled coarse index (a test's oracle) is not copied here
        ev = self.coarse
        old = ev.index
        box = float(np.max(reach_mm)) + ev.corner + fine.max_height_mm
        return SweepIndex(fine, fine.taken(np.zeros(fine.size, dtype=bool)), old.radius_mm,
                          middles.min(axis=0) - box, middles.max(axis=0) + box,
                          base_cell_mm=old.base_cell_mm, reach_limit_mm=old.reach_limit_mm,
                          max_pairs=old.max_pairs, corner_radius_mm=old.corner_radius_mm)


def _runs_within(index: SweepIndex, centres: FloatArray, radii_mm: FloatArray) -> IntArray:
    """Flat/bull-nose near pieces (sorted) within ``radii_mm`` of a centre, over their runs.

    The set of :meth:`~verification.dexels.SweepIndex.pieces_within` (a piece's exact
    point-segment distance within the radius plus its core height), over and above it
    by at most a rounding (:data:`_WITHIN_SLACK_MM`: a superset of segments changes no
    search, the soundness rule above): the pieces of every run whose midpoint lies
    within the piece reach plus the run's spread of the centre (every piece within that
    reach is in such a run), on the runs' grid the coarse searches built.
    """
    pieces = index.pieces("near")
    if centres.shape[0] == 0 or pieces.size == 0:
        return np.zeros(0, dtype=np.int64)
    reach = radii_mm + pieces.max_half_mm + pieces.max_height_mm
    grid, runs = index.runs_grid("near", reach, centres)
    spans, dims = walk_shape(grid, grid.span_of(reach + runs.max_spread_mm), centres.shape[0])
    f = np.ascontiguousarray
    marked = np.zeros(pieces.size, dtype=np.bool_)
    _pieces_near(f(centres, dtype=float), f(radii_mm, dtype=float), f(reach, dtype=float),
                 spans, dims, f(grid.origin_mm, dtype=float), float(grid.cell_mm), grid.starts,
                 runs.mid, runs.spread_mm, runs.start, runs.stop, f(pieces.a, dtype=float),
                 f(pieces.e, dtype=float), f(pieces.ee, dtype=float),
                 f(pieces.height_mm, dtype=float), runs.max_spread_mm, marked)
    return np.flatnonzero(marked).astype(np.int64)


#: How far past :meth:`~verification.dexels.SweepIndex.pieces_within`'s distance test
#: :func:`_runs_within` keeps a piece (compiled arithmetic may round otherwise), mm.
_WITHIN_SLACK_MM: Final[float] = 1e-9


@numba.njit(cache=True)
def _pieces_near(centres: FloatArray, radii: FloatArray, reach: FloatArray, spans: IntArray,
                 dims: IntArray, origin: FloatArray, cell: float, starts: IntArray,
                 run_mid: FloatArray, run_spread: FloatArray, run_start: IntArray,
                 run_stop: IntArray, a: FloatArray, e: FloatArray, ee: FloatArray,
                 height: FloatArray, widest: float, marked: NDArray[np.bool_]) -> None:
    buf = np.empty(1024, dtype=np.int64)
    for q in range(centres.shape[0]):
        cx, cy, cz = centres[q, 0], centres[q, 1], centres[q, 2]
        buf, n = spread_slots(cx, cy, cz, reach[q], widest, spans[q], dims, origin, cell,
                              starts, run_mid, run_spread, buf)
        for c in range(n):
            slot = buf[c]
            for i in range(run_start[slot], run_stop[slot]):
                if marked[i]:
                    continue
                vx, vy, vz = cx - a[i, 0], cy - a[i, 1], cz - a[i, 2]
                den = ee[i] if ee[i] > 0.0 else 1.0
                t = (vx * e[i, 0] + vy * e[i, 1] + vz * e[i, 2]) / den
                t = min(max(t, 0.0), 1.0)
                gx, gy, gz = vx - t * e[i, 0], vy - t * e[i, 1], vz - t * e[i, 2]
                lim = radii[q] + height[i] + _WITHIN_SLACK_MM
                if gx * gx + gy * gy + gz * gz <= lim * lim:
                    marked[i] = True
