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

The fine pieces are kept across batches (:data:`KEPT_PIECES` of them at most): a batch's
searches run over every segment kept so far that its own segments hold, replayed once for
the whole refinement rather than once per batch (the refinement's levels search the same
few places again and again). Searching more segments than the two steps name changes
nothing: the kept segments are segments of the full model, and the minimum over a set of
them holding those the steps name is the minimum over all (the rule above). The value
``U_q`` of step 1 is then the search over every segment kept,
which holds the first segments: a lower bound still reached by fine pieces, which lists
fewer segments in step 2.

The kept pieces stand in **layers**, one per growth, each with an index of its own: a
search walks them one after the other, each below the first value (and tie key) the ones
before reached, and takes the first of the results by the tie rule, which is the search of
all their pieces together. Steps 1 and 2 then search only the layer they add, below what
the kept ones reach, and no growth indexes the kept pieces again (the one joined index was
rebuilt at each growth, twice per batch where both steps add segments: on a bull-nose
5-axis program the rebuilds and the searches of the rebuilt index over all the batch's
dexels cost more than the new pieces' own). The layers are held to :data:`LAYERS_MOST` by
joining the two smallest, and dropped with the kept pieces for the budget.

**Ties** (:func:`~verification.capsule_search.ranks_before`: of bit-equal values the
piece the full model numbers first). The kept pieces are renumbered as segments are kept
or dropped, so a search gives its pieces back by their tie keys (:func:`tie_keys`: block,
then place among the block's pieces in path order), which order pieces as the full
model's numbers do whatever is kept: segments are kept by whole blocks
(:func:`whole_blocks`), so a block's pieces are the same, in the same order, in every
kept index. The results of batches, of the levels of the iterative deepening (a level
that finds a tied piece only in its wider ball names it where its key is smaller, as the
full model does) and of kept indices before and after a drop then merge by the tie rule
as the full model's do; a key given (``below_piece``) becomes, in the kept index, the
number of the first kept piece whose key is not below it. Without the keys (every piece
unknown, ``-1``) the first level's block was kept on such a tie where the full model
names an earlier one (``test_fine_lazy.py``, the floor raster's leaning dexels).

Memory is bounded by the budget: when a batch's segments would pass it, the kept pieces
are dropped, and a batch whose own segments pass it on their own is halved (down to one
dexel, whose segments are kept whatever their count).
"""

from __future__ import annotations

from dataclasses import fields, replace
from typing import TYPE_CHECKING, Final

import numpy as np
from numpy.typing import NDArray

from .dexels import DexelResult
from .grid import span_indices
from .piece_runs import ENTRY_MARGIN_MM
from .pieces import Pieces
from .search import scatter

if TYPE_CHECKING:
    from .fine_model import FineModel

__all__ = ["FINE_BATCH", "KEPT_PIECES", "LAYERS_MOST", "TIE_KEY_BITS", "LazyFineSweeps",
           "tie_keys", "whole_blocks"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

FINE_BATCH: Final[int] = 2048
"""Most dexels answered in one pass of the two steps."""

KEPT_PIECES: Final[int] = 1_500_000
"""Most fine pieces kept across batches (counted by :meth:`FineModel.full_pieces
<verification.fine_model.FineModel.full_pieces>` before they are built): about 0.65 GB at
the fine model's 430 bytes a piece."""


LAYERS_MOST: Final[int] = 16
"""Most layers of kept pieces, each indexed on its own, before the two smallest are joined
(:meth:`LazyFineSweeps._compact`)."""

TIE_KEY_BITS: Final[int] = 32
"""Bits of a tie key (:func:`tie_keys`) given to a piece's place within its block."""


class LazyFineSweeps:
    """Near searches over the fine model, from the segments that decide, kept across batches.

    Stands in for a :class:`~verification.dexels.SweepIndex` in
    :class:`~verification.search.Dexels` (near searches only: the collision search stays
    the coarse model's).

    Parameters
    ----------
    fine : FineModel
        The fine model (replay, machine, coarse searches, fine pieces, tolerances).
    middles, reach_mm : ndarray, shapes (k, 3) and (k,)
        Balls holding every near search asked (centre and radius), mm: the kept index's
        grids cover them (:meth:`FineModel.rows_around
        <verification.fine_model.FineModel.rows_around>`).
    batch : int, optional
        Most dexels per pass of the two steps (default :data:`FINE_BATCH`).
    kept_pieces : int, optional
        Most fine pieces kept (default :data:`KEPT_PIECES`).
    layers_most : int, optional
        Most layers of kept pieces (default :data:`LAYERS_MOST`; 1: one index of them
        all at the start of each batch).
    """

    def __init__(self, fine: FineModel, middles: FloatArray, reach_mm: FloatArray, *,
                 batch: int | None = None, kept_pieces: int | None = None,
                 layers_most: int | None = None) -> None:
        self.fine = fine
        self.middles, self.reach_mm = middles, reach_mm
        self.batch = FINE_BATCH if batch is None else batch
        self.kept_pieces = KEPT_PIECES if kept_pieces is None else kept_pieces
        self.layers_most = LAYERS_MOST if layers_most is None else layers_most
        #: segments replayed finely, summed (a measure of the work)
        self.rows_built = 0
        #: times the kept pieces were dropped for the budget
        self.drops = 0
        self._rows = np.zeros(0, dtype=np.int64)
        self._counted = 0
        # the kept pieces, a few sets of whole blocks, each with its own index (newest last)
        self._layers: list[_Layer] = []
        # per coarse piece its segments' span (built once), and the prefix sums of the
        # pieces whose segments are all kept, of the segments kept when counted
        self._spans: tuple[IntArray, IntArray] | None = None
        self._listed: tuple[IntArray, IntArray] | None = None

    @property
    def widen_mm(self) -> float:
        """``w``: how far a fine piece may stand outside the coarse pieces of its stretch, mm."""
        return self.fine.model_tol_mm + self.fine.chord_tol_mm + ENTRY_MARGIN_MM

    @property
    def rows_kept(self) -> IntArray:
        """The joint segments whose fine pieces are kept (sorted)."""
        return self._rows

    @property
    def layer_sizes(self) -> list[int]:
        """The fine pieces of each layer of those kept, oldest first."""
        return [layer.pieces.size for layer in self._layers]

    @property
    def pieces_kept(self) -> int:
        """The fine pieces kept, as counted against :attr:`kept_pieces` (the budget)."""
        return self._counted

    def search(self, which: str, points: FloatArray, dirs: FloatArray, centres: FloatArray,
               radii_mm: FloatArray, *, below_mm: FloatArray | None = None,
               below_piece: IntArray | None = None, rim_in_radii: bool = False
               ) -> DexelResult:
        """The fine model's near search (:meth:`~verification.dexels.SweepIndex.search`).

        ``rim_in_radii`` is taken for that interface and left unused: the kept index is
        searched with the full reach (a superset of the candidates; the same minimum).
        The pieces found are returned by their tie keys (:func:`tie_keys`), not by their
        numbers within the kept index, which change as segments are kept or dropped: the
        keys order pieces as the full model's numbers do, so results of different batches,
        levels and kept indices merge by the tie rule as the full model's do;
        ``below_piece`` is such a key too (``-1``: none).
        """
        if which != "near":
            raise ValueError(f"the lazy fine model answers near searches only, not {which!r}")
        del rim_in_radii
        q = points.shape[0]
        out = DexelResult.empty(q)
        for lo in range(0, q, self.batch):
            sel = np.arange(lo, min(q, lo + self.batch))
            part = self._batch(points[sel], dirs[sel], centres[sel], radii_mm[sel],
                               None if below_mm is None else below_mm[sel],
                               None if below_piece is None else below_piece[sel])
            scatter(out, sel, part)
        return out

    def _grown(self, rows: IntArray, *, force: bool = False) -> tuple[bool, _Layer | None]:
        """Whether ``rows`` fit the budget, and the layer of those not kept yet, now kept.

        ``force``: kept whatever the count. Every segment of a block the rows belong to is
        kept with them (:func:`whole_blocks`), so that the tie keys hold. The layer is
        None where every block is kept already, and where they do not fit.
        """
        new = np.setdiff1d(whole_blocks(self.fine.segment_moves, rows), self._rows,
                           assume_unique=True)
        if new.shape[0] == 0:
            return True, None
        counted = self.fine.full_pieces(new)
        if not force and self._counted + counted > self.kept_pieces:
            return False, None
        layer = _Layer(_one_path([self.fine.fine_pieces(new)]), self)
        self._layers.append(layer)
        self.rows_built += int(new.shape[0])
        self._counted += counted
        self._rows = np.union1d(self._rows, new)
        return True, layer

    def _compact(self) -> None:
        """The two smallest layers joined while there are over :attr:`layers_most`.

        (A search walks each layer on its own: each walk costs a little, and the budget's
        drops seldom leave more than a dozen on a bull-nose 5-axis blade program.)
        """
        layers = self._layers
        while len(layers) > max(self.layers_most, 1):
            sizes = [layer.pieces.size for layer in layers]
            first, second = sorted(range(len(layers)), key=sizes.__getitem__)[:2]
            joined = _Layer(_one_path([layers[first].pieces, layers[second].pieces]), self)
            layers[min(first, second)] = joined
            del layers[max(first, second)]

    def _kept_pieces(self, pieces: Pieces) -> IntArray | None:
        """Prefix sums over the coarse pieces of those whose segments are all kept.

        Step 2 need not list them: it lists pieces for their segments, and the kept ones
        are left out of what :meth:`_grown` adds (the same segments are added, the same
        values found, with less of the walk). None: none kept, or the spans unknown.
        """
        if self._rows.shape[0] == 0:
            return None
        if self._listed is not None and self._listed[0] is self._rows:
            return self._listed[1]
        if self._spans is None:
            spans = self.fine.row_spans(pieces)
            if spans is None:
                return None
            self._spans = spans
        first, last = self._spans
        kept = np.zeros(self.fine.segment_moves.shape[0] + 1, dtype=np.int64)
        kept[self._rows + 1] = 1
        np.cumsum(kept, out=kept)
        whole = (kept[last.astype(np.int64) + 1] - kept[first]) == (last - first + 1)
        listed = np.zeros(whole.shape[0] + 1, dtype=np.int64)
        np.cumsum(whole, out=listed[1:])
        self._listed = (self._rows, listed)
        return listed

    def _drop(self) -> None:
        """Every kept piece dropped (the budget)."""
        self.drops += 1
        self._rows = np.zeros(0, dtype=np.int64)
        self._layers, self._counted = [], 0

    @staticmethod
    def _bound(res: DexelResult, below_mm: FloatArray | None) -> FloatArray:
        """``U_q``: the value found, else the value given (which the caller keeps)."""
        if below_mm is None:
            return res.lam_mm
        return np.where(res.move >= 0, res.lam_mm, below_mm)

    @staticmethod
    def _searched(layers: list[_Layer], points: FloatArray, dirs: FloatArray,
                  centres: FloatArray, radii_mm: FloatArray, below_mm: FloatArray | None,
                  below_key: IntArray | None, res: DexelResult | None = None) -> DexelResult:
        """The fine search over the pieces of ``layers`` (none: nothing found), as keys.

        ``res``: what a search of other layers found, which this one goes on from (the
        layers searched one after the other, each below the first value so far, the
        results merged by the tie rule: the search of their pieces all together). A
        dexel where nothing is found holds ``inf`` and the key given.
        """
        q = points.shape[0]
        res = DexelResult.empty(q) if res is None else res
        given_mm = np.full(q, np.inf) if below_mm is None else below_mm
        given_key = np.full(q, -1, dtype=np.int64) if below_key is None else below_key
        everyone = np.arange(q)
        for layer in layers:
            found = res.move >= 0
            scatter(res, everyone, layer.search(points, dirs, centres, radii_mm,
                                                np.where(found, res.lam_mm, given_mm),
                                                np.where(found, res.piece, given_key)),
                    merge=True)
        none = res.move < 0
        res.piece[none] = given_key[none]
        return res

    def _batch(self, points: FloatArray, dirs: FloatArray, centres: FloatArray,
               radii_mm: FloatArray, below_mm: FloatArray | None,
               below_key: IntArray | None, fresh: bool = False) -> DexelResult:
        """The two steps for a batch of dexels over the segments kept, grown as they ask.

        ``fresh``: begun with nothing kept (a single dexel then keeps what it needs
        whatever the budget).
        """
        fine = self.fine
        coarse = fine.coarse.index
        pieces = coarse.pieces("near")
        w = self.widen_mm
        # a fine candidate's midpoint lies within the fine search's reach (its half and
        # height added) of the centre, and within w and a coarse and a fine half length
        # (no longer than a coarse one) of the midpoint of a coarse piece standing for it
        reach = radii_mm + w + 3.0 * pieces.max_half_mm + pieces.max_height_mm
        # 0. the segments kept (a value they reach is a U_q as good as step 1's)
        q = points.shape[0]
        self._compact()
        res = self._searched(self._layers, points, dirs, centres, radii_mm, below_mm,
                             below_key)
        known = self._bound(res, below_mm)
        todo = np.flatnonzero(~np.isfinite(known))
        if todo.shape[0]:
            # 1. where they reach nothing: the segments of each dexel's lowest coarse piece
            # (over the coarse runs' grid the coarse searches built: no second one)
            _, hit, _, _ = coarse.sweep_entries("near", points[todo], dirs[todo],
                                                centres[todo], reach[todo], built=True)
            first = fine._rows(pieces, np.unique(hit[hit >= 0]))
            if first.shape[0]:
                fits, layer = self._grown(first, force=fresh and q == 1)
                if not fits:
                    return self._over_budget(points, dirs, centres, radii_mm, below_mm,
                                             below_key, fresh)
                if layer is not None:
                    # the new pieces searched below what the kept ones reach
                    res = self._searched([layer], points, dirs, centres, radii_mm, below_mm,
                                         below_key, res)
                    known = self._bound(res, below_mm)
        # 2. every segment a widened coarse piece may enter below U_q (but those kept)
        listed = coarse.pieces_entering_below("near", points, dirs, centres, reach, known, w,
                                              listed=self._kept_pieces(pieces))
        if listed.shape[0] == 0:
            return res
        fits, layer = self._grown(fine._rows(pieces, listed), force=fresh and q == 1)
        if not fits:
            return self._over_budget(points, dirs, centres, radii_mm, below_mm, below_key,
                                     fresh)
        if layer is None:
            return res
        return self._searched([layer], points, dirs, centres, radii_mm, below_mm, below_key,
                              res)

    def _over_budget(self, points: FloatArray, dirs: FloatArray, centres: FloatArray,
                     radii_mm: FloatArray, below_mm: FloatArray | None,
                     below_key: IntArray | None, fresh: bool) -> DexelResult:
        """A batch whose segments would pass the budget: afresh, else half by half.

        Afresh: the kept pieces dropped and the batch begun again (the values found so
        far are of segments no longer kept, so none is reused); begun afresh already: its
        halves, each with what the other keeps.
        """
        if not fresh:
            self._drop()
            return self._batch(points, dirs, centres, radii_mm, below_mm, below_key,
                               fresh=True)
        return self._halves(points, dirs, centres, radii_mm, below_mm, below_key)

    def _halves(self, points: FloatArray, dirs: FloatArray, centres: FloatArray,
                radii_mm: FloatArray, below_mm: FloatArray | None,
                below_key: IntArray | None) -> DexelResult:
        """A batch whose segments pass the budget, answered half by half."""
        q = points.shape[0]
        out = DexelResult.empty(q)
        for sel in (np.arange(q // 2), np.arange(q // 2, q)):
            scatter(out, sel, self._batch(points[sel], dirs[sel], centres[sel],
                                          radii_mm[sel],
                                          None if below_mm is None else below_mm[sel],
                                          None if below_key is None else below_key[sel]))
        return out


class _Layer:
    """Fine pieces of some whole blocks (in block order), their tie keys and their index."""

    def __init__(self, pieces: Pieces, owner: LazyFineSweeps) -> None:
        self.pieces = pieces
        self.keys = tie_keys(pieces.move)
        self.index = owner.fine.index_of(pieces, owner.middles, owner.reach_mm)

    def search(self, points: FloatArray, dirs: FloatArray, centres: FloatArray,
               radii_mm: FloatArray, below_mm: FloatArray, below_key: IntArray
               ) -> DexelResult:
        """The near search of these pieces below ``(below_mm, below_key)``, pieces as keys.

        A key given becomes the number of the first piece here whose key is not below it
        (past the last: none is): the pieces before it, and those only, rank before it,
        so the search seeks what the full model's would; a piece found is given back by
        its key, the key given where none is.
        """
        keys = self.keys
        given = np.where(below_key >= 0, np.searchsorted(keys, below_key, side="left"), -1)
        res = self.index.search("near", points, dirs, centres, radii_mm, below_mm=below_mm,
                                below_piece=given)
        found = res.move >= 0
        key = np.where(found, keys[np.where(found, res.piece, 0)] if keys.shape[0] else -1,
                       below_key)
        return replace(res, piece=key.astype(np.int64))


def _one_path(chunks: list[Pieces]) -> Pieces:
    """Fine pieces of several replays as one set, in block order.

    Each replay's path lengths are shifted past the previous one's (one millimetre apart),
    so :meth:`~verification.pieces.Pieces.moves_at` traces a piece back along its own
    replay's instances. The pieces are put in block order, as the full model's (its
    segments replayed in order): of tied pieces the earliest block is found first.
    """
    fields: dict[str, list[NDArray[np.generic]]] = {name: [] for name in _FIELDS}
    paths, moves = [], []
    shift = 0.0
    for chunk in chunks:
        arc = chunk.path_arc_mm
        at = shift - (float(arc[0]) if arc.shape[0] else 0.0)
        for name in _FIELDS:
            fields[name].append(getattr(chunk, name))
        fields["arc0_mm"][-1] = chunk.arc0_mm + at
        fields["arc1_mm"][-1] = chunk.arc1_mm + at
        paths.append(arc + at)
        moves.append(chunk.path_move)
        if arc.shape[0]:
            shift = float(arc[-1]) + at + 1.0
    cat = {name: np.concatenate(v) for name, v in fields.items()}
    joined = Pieces(**cat, path_arc_mm=np.concatenate(paths),  # type: ignore[arg-type]
                    path_move=np.concatenate(moves))
    return joined.taken(np.argsort(joined.move, kind="stable"))


def whole_blocks(segment_moves: IntArray, rows: IntArray) -> IntArray:
    """Every joint segment (sorted) of the blocks some segments belong to.

    ``segment_moves``: the block of each segment of the replay (nondecreasing: the
    segments are in path order), ``motion.rows.move``.
    """
    moves = np.unique(segment_moves[rows])
    lo = np.searchsorted(segment_moves, moves, side="left")
    hi = np.searchsorted(segment_moves, moves, side="right")
    return span_indices(lo, hi - lo)


def tie_keys(move: IntArray) -> IntArray:
    """Per kept piece, a number that orders pieces as the full fine model's numbers do.

    ``(block << TIE_KEY_BITS) + i``, ``i`` the piece's place among its block's pieces in
    path order. The full model numbers its pieces in path order (its segments replayed in
    order), so by block, then by place in the block's path. The kept pieces are each
    block's whole (:func:`whole_blocks`), replayed in one stretch in path order, and put
    in block order (:func:`_one_path`): a block's pieces stand together, in path order,
    the same pieces whichever batch kept them, before or after a drop. The key is then
    the same for a piece whatever else is kept, and of two pieces the full model holds
    the one it numbers first has the smaller key (the full model may hold fewer of a
    block's segments: the place in a block counts the pieces of all of them, which only
    leaves gaps between the keys). ``move``: the kept pieces' blocks, nondecreasing.
    """
    place = np.arange(move.shape[0]) - np.searchsorted(move, move, side="left")
    if move.shape[0] and (int(place.max()) >> TIE_KEY_BITS or int(move.min()) < 0):
        raise ValueError(f"a block of over 2**{TIE_KEY_BITS} fine pieces, or a piece of no "
                         "block: the tie keys cannot order them")
    return (move.astype(np.int64) << TIE_KEY_BITS) + place


#: The per-piece fields of :class:`~verification.pieces.Pieces` (all but the path's).
_FIELDS: Final[tuple[str, ...]] = tuple(
    f.name for f in fields(Pieces) if f.name not in ("path_arc_mm", "path_move"))
