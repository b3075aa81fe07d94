r"""The fine model's near searches of a flat or bull-nose cutter, built per batch of dexels.

A flat or bull-nose piece holds its axis fixed, so the fine model
(:mod:`verification.fine_model`, every chord of a 20 nm replay kept) cuts a stretch where
the axis turns into pieces each turning it by what moves the cutter's reach by the fine
tolerance: over a thousand pieces per joint segment on the bull-nose 5-axis blade, and
every segment within a near search's radius (3.4 to 3.8 mm for a ``bull:8:1``, a fifth of
the blade's passes) of the refinements' boxes. The whole program's took over 20 GB.

Most of those segments decide nothing: a dexel's value is its lowest entry, and a
neighbouring pass a millimetre away enters it tens of micrometres higher. So
:class:`LazyFineSweeps` answers each batch of near searches (one level of a refinement)
from the segments that can decide them only:

1. ``U_q``: per dexel ``q``, the coarse search (widened by the tolerances below) names the
   coarse piece of lowest entry; the segments it stands for are replayed finely and
   searched: ``U_q`` is a value fine pieces reach, so the fine value ``v_q <= U_q``;
2. every coarse piece whose sweep *widened by* ``w = model_tol + chord_tol +``
   :data:`~verification.piece_runs.ENTRY_MARGIN_MM` floors below ``U_q`` on some dexel
   (:meth:`~verification.dexels.SweepIndex.pieces_entering_below`) adds the segments it
   stands for; the fine search over all of them is the answer.

Soundness, as :mod:`verification.fine_model`'s: every coarse piece stands within
``model_tol`` of the true sweep and every fine piece within ``chord_tol`` of it, so the
fine pieces of a segment lie inside the coarse pieces of its stretch widened by
``model_tol + chord_tol`` (the margin covers the entries' convergence, as for the runs);
a segment left out has every coarse piece's widened floor at ``U_q`` or above on every
dexel, hence every fine piece entering at ``U_q`` or above, and the minimum over the
segments kept, which is at most ``U_q``, is the minimum over all. The candidate rule of
the fine search (a piece's midpoint within the search radius of the centre) is the same on
fewer segments; the coarse pieces are listed from three times their longest half, their
core height and ``w`` farther (a fine piece is no longer than a coarse one).

Memory is bounded by batch: at most :data:`FINE_BATCH` dexels share one fine index.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Final

import numpy as np
from numpy.typing import NDArray

from .dexels import DexelResult
from .piece_runs import ENTRY_MARGIN_MM
from .search import scatter

if TYPE_CHECKING:
    from .fine_model import FineModel

__all__ = ["FINE_BATCH", "LazyFineSweeps"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

FINE_BATCH: Final[int] = 2048
"""Most dexels answered from one fine index (its segments are those of its dexels)."""


class LazyFineSweeps:
    """Near searches over the fine model, built per batch from the segments that decide.

    Stands in for a :class:`~verification.dexels.SweepIndex` in
    :class:`~verification.search.Dexels` (near searches only: the collision search stays
    the coarse model's).

    Parameters
    ----------
    fine : FineModel
        The fine model (replay, machine, coarse searches, fine pieces, tolerances).
    batch : int
        Most dexels per fine index.
    """

    def __init__(self, fine: FineModel, *, batch: int = FINE_BATCH) -> None:
        self.fine = fine
        self.batch = batch
        #: segments replayed finely per batch, summed (a measure of the work)
        self.rows_built = 0

    @property
    def widen_mm(self) -> float:
        """``w``: how far a fine piece may stand outside the coarse pieces of its stretch, mm."""
        return self.fine.model_tol_mm + self.fine.chord_tol_mm + ENTRY_MARGIN_MM

    def search(self, which: str, points: FloatArray, dirs: FloatArray, centres: FloatArray,
               radii_mm: FloatArray, *, below_mm: FloatArray | None = None,
               below_piece: IntArray | None = None) -> DexelResult:
        """The fine model's near search (:meth:`~verification.dexels.SweepIndex.search`).

        The pieces found are numbered within their batch's own index, which no other
        search shares: they are returned as ``-1`` (unknown; of equal values the one
        given or found first is kept), and ``below_piece`` is not used.
        """
        if which != "near":
            raise ValueError(f"the lazy fine model answers near searches only, not {which!r}")
        q = points.shape[0]
        out = DexelResult.empty(q)
        for lo in range(0, q, self.batch):
            sel = np.arange(lo, min(q, lo + self.batch))
            part = self._batch(points[sel], dirs[sel], centres[sel], radii_mm[sel],
                               None if below_mm is None else below_mm[sel])
            scatter(out, sel, part)
        out.piece[:] = -1
        return out

    def _search_rows(self, rows: IntArray, points: FloatArray, dirs: FloatArray,
                     centres: FloatArray, radii_mm: FloatArray,
                     below_mm: FloatArray | None) -> DexelResult:
        """The fine search over the fine pieces of ``rows`` alone."""
        if rows.shape[0] == 0:
            res = DexelResult.empty(points.shape[0])
            if below_mm is not None:
                res.lam_mm[:] = below_mm
            return res
        self.rows_built += int(rows.shape[0])
        index = self.fine._index(rows, centres, radii_mm)
        return index.search("near", points, dirs, centres, radii_mm, below_mm=below_mm)

    def _batch(self, points: FloatArray, dirs: FloatArray, centres: FloatArray,
               radii_mm: FloatArray, below_mm: FloatArray | None) -> DexelResult:
        fine = self.fine
        coarse = fine.coarse.index
        pieces = coarse.pieces("near")
        w = self.widen_mm
        # a fine candidate's midpoint lies within the fine search's reach (its half and
        # height added) of the centre, and within w and a coarse and a fine half length
        # (no longer than a coarse one) of the midpoint of a coarse piece standing for it
        reach = radii_mm + w + 3.0 * pieces.max_half_mm + pieces.max_height_mm
        # 1. the segments of each dexel's lowest coarse piece: U_q
        # (over the coarse runs' grid the coarse searches built: no second one)
        _, hit, _, _ = coarse.sweep_entries("near", points, dirs, centres, reach, built=True)
        first = fine._rows(pieces, np.unique(hit[hit >= 0]))
        res = self._search_rows(first, points, dirs, centres, radii_mm, below_mm)
        # 2. every segment a widened coarse piece may enter below U_q
        listed = coarse.pieces_entering_below("near", points, dirs, centres, reach,
                                              res.lam_mm, w)
        if listed.shape[0] == 0:
            return res
        rows = np.union1d(first, fine._rows(pieces, listed))
        if rows.shape[0] == first.shape[0]:
            return res
        return self._search_rows(rows, points, dirs, centres, radii_mm, below_mm)
