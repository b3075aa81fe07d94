"""The swept cutter modelled finely around a few points: figures free of how moves cut a path.

The whole-program model keeps its pieces within ``replay_tol_mm + merge_tol_mm`` (0.5 + 1
um by default) of the true sweep, *per move*: the replay samples each block at its own
``u = j / n`` and merging starts afresh wherever the instances differ, so one path written
as a few long moves or as many short ones is measured up to that apart (1.5 um is 20 % of
a 8 um gouge, a third of a 5 um scallop). Around a handful of points the sweep can be
modelled far better at little cost: :meth:`FineModel.around`

1. lists the coarse near pieces that come within ``reach`` of the points' near-search
   centres (:meth:`~verification.dexels.SweepIndex.pieces_within`), and the joint-space
   segments of the replay they stand for (``motion.rows``, one instance either side);
2. samples those stretches again in joint space to a fine chord tolerance
   (``VerifyOptions.extremes_tol_mm``, 10 nm; :func:`~verification.replay.replay_rows`)
   and keeps every chord (no merging);
3. builds the near pieces and a near-search index of those stretches alone, whose levels
   stop at the level asked for.

Soundness: every coarse piece lies within ``model_tol`` of the true sweep, so a stretch
none of whose coarse pieces comes within ``reach`` of a near-search centre has its true
sweep (and its fine pieces) farther than ``reach - model_tol`` from it. ``reach`` is the
near search's radius at the last level asked for (sized for the depth asked for), plus
``model_tol`` and the margin the points may move by: the stretches left out cannot change
what a near search finds there up to that level, and the fine near searches at the points
are those of the whole program modelled finely (beyond that level they report nothing).
The collision search (shank, from behind) stays the coarse model's.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from machines import Machine

from .dexels import SweepIndex
from .pieces import Pieces
from .replay import ToolMotion, replay_rows
from .search import Dexels

__all__ = ["FineModel", "PiecesOf"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: The swept cutter's near pieces of replayed stretches, modelled finely (no merging).
PiecesOf = Callable[[ToolMotion], Pieces]


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
    """

    def __init__(self, motion: ToolMotion, machine: Machine, coarse: Dexels,
                 pieces_of: PiecesOf, *, model_tol_mm: float, chord_tol_mm: float) -> None:
        self.motion, self.machine, self.coarse = motion, machine, coarse
        self.pieces_of = pieces_of
        self.model_tol_mm = model_tol_mm
        self.chord_tol_mm = chord_tol_mm

    def level_for_mm(self, deviation_mm: float) -> float:
        """The first near-search level at or above ``deviation_mm`` (else the horizon)."""
        return next((h for h in self.coarse.horizons if h >= deviation_mm),
                    self.coarse.horizon)

    def _rows(self, pieces: Pieces, hit: IntArray) -> IntArray:
        """Joint segments (sorted, unique) the listed near pieces stand for."""
        rows = self.motion.rows
        assert rows is not None
        n_inst = rows.of_instance.shape[0]
        path = pieces.path_arc_mm
        # every instance whose arc lies in [arc0, arc1] and one either side (a centre
        # standing still while the axis turns repeats its arc over several instances)
        lo = np.clip(np.searchsorted(path, pieces.arc0_mm[hit], side="left") - 1, 0, n_inst - 1)
        hi = np.clip(np.searchsorted(path, pieces.arc1_mm[hit], side="right"), 0, n_inst - 1)
        count = np.maximum(hi - lo + 1, 1)
        inst = np.repeat(lo, count) + (np.arange(count.sum())
                                       - np.repeat(np.cumsum(count) - count, count))
        return np.unique(rows.of_instance[inst])

    def around(self, points: FloatArray, normals: FloatArray, convexity_per_mm: FloatArray,
               *, margin_mm: float, level_mm: float, depth_mm: float) -> Dexels | None:
        """Fine near searches, exact up to ``level_mm``, within ``margin_mm`` of ``points``.

        Parameters
        ----------
        points, normals : ndarray, shape (q, 3)
            Design points (mm) and their unit normals.
        convexity_per_mm : ndarray, shape (q,)
            Their convexity (widens the near search at convex edges), 1/mm.
        margin_mm : float
            The searches hold for any design point this close to one of ``points``.
        level_mm : float
            Last level of the near search (one of the coarse levels): more material than
            this is reported as beyond the horizon.
        depth_mm : float
            Gouge depth the near search is sized for, mm.

        Returns
        -------
        Dexels or None
            None when no piece comes near (nothing cut there).
        """
        ev = self.coarse
        levels = (*(h for h in ev.horizons if h < level_mm), level_mm)
        # a point moved by the margin moves its near-search centre P + r n by about as much
        reach = (ev.near_radius_mm(level_mm, depth_mm, convexity_per_mm)
                 + 2.0 * margin_mm + self.model_tol_mm)
        centres = points + ev.corner * normals
        pieces = ev.index.pieces("near")
        hit = ev.index.pieces_within("near", centres, reach)
        if hit.shape[0] == 0:
            return None
        rows = self._rows(pieces, hit)
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
        fine = fine.taken(~joins)
        old = ev.index
        box = float(np.max(reach)) + ev.corner
        index = SweepIndex(fine, fine.taken(np.zeros(fine.size, dtype=bool)), old.radius_mm,
                           points.min(axis=0) - box, points.max(axis=0) + box,
                           base_cell_mm=old.base_cell_mm, reach_limit_mm=old.reach_limit_mm,
                           max_pairs=old.max_pairs, corner_radius_mm=old.corner_radius_mm,
                           compiled=old.compiled)
        return Dexels(index, ev.radius, levels, depth_mm, ev.method, corner_radius=ev.corner,
                      model_tol_mm=self.chord_tol_mm)
