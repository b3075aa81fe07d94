"""The swept ball-nose cutter as capsule pieces.

* **Ball pieces.** Between consecutive tool instances the ball centre ``C = tip + R a``
  moves on a straight chord (the replay keeps the true path within its chord tolerance of
  these chords), so the ball sweeps exactly the capsule of radius ``R`` around the chord.
  Runs of nearly collinear chords (a program of many short blocks along a line or a gentle
  curve) are merged first (:func:`simplify_polyline`): a vertex is dropped when every
  original ball centre between its kept neighbours lies within ``merge_tol_mm`` of the
  chord joining them. Merging alternates between odd and even vertices, so it takes about
  ``2 log2(run)`` rounds. The cost of the search then follows the geometry, not the block
  count.
* **Shank pieces.** Above the ball centre the flutes and shank are a cylinder of radius
  ``R`` up to ``C + (H - R) a`` (``H`` the flute length). It is placed at instances
  resampled along the path every ``shank_spacing_mm`` (measured at the centre and at the
  top, so tilting in place counts), each a capsule from ``C`` up the axis. Between two such
  instances the union dips below the true swept shank by at most
  ``R - sqrt(R^2 - (spacing / 2)^2)``: the shank check is for collisions, not finish.

Every capsule longer than ``max_piece_mm`` is cut into equal pieces (a union of capsules
on consecutive sub-segments is the same solid), which bounds the reach of a piece from its
midpoint, and so the grid search radius.

* **Flat and bull-nose pieces** (:func:`cutter_pieces`). The same chords, of the core
  centre ``C = tip + r a`` (``r`` the corner radius; the ball centre when ``r = R``), each
  carrying the cutter up to ``L + 2 r`` above its tip (``L`` the core height,
  :mod:`verification.torus`). Such a cutter is not a sphere, so its axis matters: a piece
  holds the normalised mean of the axes at its ends, and is cut so that the axis turns by
  at most ``dtheta = 2 rot_tol_mm / reach_mm`` along it (``reach_mm`` the distance of the
  farthest cutter point from ``C``). The true cutter at a point of the piece is the held
  one turned by at most ``dtheta / 2`` about ``C`` (on the chord within the replay
  tolerance), so the piece's sweep is within ``replay tolerance + merge tolerance +
  rot_tol_mm`` of the true one. Merging works on the six-dimensional polyline
  ``(C, reach a)``, so a vertex is dropped only where the axis, too, stays on the chord.
  The shank of these cutters is :func:`shank_pieces` with the corner radius: the core
  disc swept up the axis (``L = 0``, the chord along ``a``) is the core cylinder.

A ball piece keeps the path length (along the ball-centre polyline of all instances) at its
ends, so a hit is traced back to the block whose stretch of path lies nearest the dexel,
even inside a merged piece.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

import numba
import numpy as np
from numpy.typing import NDArray

from toolpath.row_threads import run_in_threads

from .replay import ToolMotion
from .vectors import row_norms

__all__ = ["Pieces", "ball_pieces", "cutter_pieces", "shank_pieces", "simplify_polyline"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@dataclass(frozen=True, eq=False)
class Pieces:
    """Pieces of one swept cutter, one row per piece.

    A ball piece is a capsule of the ball's radius around the segment ``a -> a + e``
    (``height_mm`` 0); a flat or bull-nose piece is the cutter whose core bottom centre
    moves along that segment, its core ``height_mm`` tall (:mod:`verification.torus`).

    Attributes
    ----------
    a : ndarray, shape (m, 3)
        Segment starts (ball or core bottom centres), mm.
    e : ndarray, shape (m, 3)
        Segment vectors (end minus start), mm.
    ee : ndarray, shape (m,)
        Squared lengths, mm^2.
    mid : ndarray, shape (m, 3)
        Midpoints, mm.
    half_mm : ndarray, shape (m,)
        Half lengths, mm.
    move : ndarray of int64, shape (m,)
        Motion block (0-based, motion order) of the piece (for ball pieces: at its start).
    shank : ndarray of bool, shape (m,)
        The piece is part of the shank (not the ball's sweep).
    axis : ndarray, shape (m, 3)
        Unit tool axis (tip towards spindle): at the piece's start for a ball (where the
        rest of the tool lies), the one the flat or bull-nose piece holds otherwise.
    arc0_mm, arc1_mm : ndarray, shape (m,)
        Ball pieces: path length at the ends, mm (NaN for shank pieces).
    path_arc_mm : ndarray, shape (n_instances,)
        Path length of the ball centre at every tool instance, mm.
    path_move : ndarray of int64, shape (n_instances,)
        Motion block arriving at every instance.
    height_mm : ndarray, shape (m,)
        Core height ``L`` of flat and bull-nose pieces, mm (0 for balls and shanks).
    """

    a: FloatArray
    e: FloatArray
    ee: FloatArray
    mid: FloatArray
    half_mm: FloatArray
    move: IntArray
    shank: NDArray[np.bool_]
    axis: FloatArray
    arc0_mm: FloatArray
    arc1_mm: FloatArray
    path_arc_mm: FloatArray
    path_move: IntArray
    height_mm: FloatArray

    @property
    def size(self) -> int:
        """Number of pieces."""
        return int(self.move.shape[0])

    @property
    def max_height_mm(self) -> float:
        """Largest core height, mm (0 when empty or for balls)."""
        return float(self.height_mm.max()) if self.size else 0.0

    @property
    def max_half_mm(self) -> float:
        """Largest half length, mm (0 when empty)."""
        return float(self.half_mm.max()) if self.size else 0.0

    def concat(self, other: Pieces) -> Pieces:
        """Both sets of pieces (the path arrays are this set's)."""
        def cat(name: str) -> NDArray[np.float64]:
            return np.concatenate((getattr(self, name), getattr(other, name)))

        return Pieces(cat("a"), cat("e"), cat("ee"), cat("mid"), cat("half_mm"), cat("move"),
                      cat("shank"), cat("axis"), cat("arc0_mm"), cat("arc1_mm"),
                      self.path_arc_mm, self.path_move, cat("height_mm"))

    def absorbing(self, other: Pieces) -> Pieces:
        """Both sets of pieces, as :meth:`concat`, holding this set's memory only once.

        Field by field, this set's array is copied into the concatenation and then
        replaced by a view of its first rows (the same values, bit for bit), so each of
        its own arrays is freed as soon as it is copied (where nothing else holds it):
        the concatenation never holds two whole copies of this set, only one field's
        (on the 7 M pieces of the bull-nose 5-axis blade program, 166 MB at most rather
        than 1 GB). This set, changed in place, stays a valid set of the same pieces, but
        from then on shares its memory with the concatenation: a write into one shows in
        the other (pieces are never written in place once built; keep it so).
        """
        n = self.size
        both = {}
        for name in _ROW_FIELDS:
            mine = getattr(self, name)
            both[name] = np.concatenate((mine, getattr(other, name)))
            object.__setattr__(self, name, both[name][:n])
            del mine
        return Pieces(**both, path_arc_mm=self.path_arc_mm, path_move=self.path_move)

    def taken(self, rows: NDArray[np.bool_] | IntArray) -> Pieces:
        """The pieces at ``rows`` (a mask or indices); the path arrays unchanged."""
        return Pieces(self.a[rows], self.e[rows], self.ee[rows], self.mid[rows],
                      self.half_mm[rows], self.move[rows], self.shank[rows], self.axis[rows],
                      self.arc0_mm[rows], self.arc1_mm[rows], self.path_arc_mm,
                      self.path_move, self.height_mm[rows])

    def moves_at(self, piece: IntArray, points_mm: FloatArray) -> IntArray:
        """Motion block nearest each point along its piece (ball: by path length).

        Parameters
        ----------
        piece : ndarray of int64, shape (q,)
            Piece indices.
        points_mm : ndarray, shape (q, 3)
            Points (the dexel origins), mm; each is projected on its piece's segment.

        Returns
        -------
        ndarray of int64
            Motion block numbers (motion order).
        """
        ee = self.ee[piece]
        u = np.einsum("ij,ij->i", points_mm - self.a[piece], self.e[piece])
        u = np.clip(u / np.where(ee > 0.0, ee, 1.0), 0.0, 1.0)
        arc0 = self.arc0_mm[piece]
        arc = arc0 + u * (self.arc1_mm[piece] - arc0)
        ball = np.isfinite(arc)
        out = self.move[piece].copy()
        if ball.any() and self.path_arc_mm.shape[0] > 1:
            inst = np.searchsorted(self.path_arc_mm, arc[ball], side="left")
            out[ball] = self.path_move[np.clip(inst, 1, self.path_arc_mm.shape[0] - 1)]
        return out


#: The fields of :class:`Pieces` with one row per piece (the path arrays are per instance).
_ROW_FIELDS = ("a", "e", "ee", "mid", "half_mm", "move", "shank", "axis", "arc0_mm",
               "arc1_mm", "height_mm")


def simplify_polyline(points: FloatArray, tol_mm: float, max_length_mm: float
                      ) -> IntArray:
    """Vertices to keep so every dropped vertex lies within ``tol_mm`` of the new chords.

    Rounds alternate between odd and even kept vertices; a vertex is dropped when every
    original vertex between its two kept neighbours lies within ``tol_mm`` of the chord
    joining them (checked exactly: the spans of one round are disjoint, so a round costs
    one pass over the polyline; a chord refused once is not checked again while both its
    ends stay kept, as the same numbers refuse it again) and that chord is at most
    ``max_length_mm`` long. The
    original polyline then lies within ``tol_mm`` of the kept one (the distance of a
    segment's points from a chord is largest at its ends).

    Parameters
    ----------
    points : ndarray, shape (n, 3)
        The polyline, mm.
    tol_mm : float
        Largest distance of an original vertex from the chord replacing it, mm.
    max_length_mm : float
        No merged chord longer than this, mm.

    Returns
    -------
    ndarray of int64
        Indices of the kept vertices, first and last always kept.
    """
    n = points.shape[0]
    keep = np.arange(n, dtype=np.int64)
    idle = 0
    parity = 1
    max2 = max_length_mm * max_length_mm
    # per vertex, the kept neighbours of the last chord that failed to replace it: the same
    # chord fails again (the same numbers in), so it is not checked again
    tried_a = np.full(n, -1, dtype=np.int64)
    tried_c = np.full(n, -1, dtype=np.int64)
    while keep.shape[0] > 2 and idle < 2:
        p = np.arange(max(parity, 1), keep.shape[0] - 1, 2)
        a_i, c_i = keep[p - 1], keep[p + 1]
        new = (tried_a[keep[p]] != a_i) | (tried_c[keep[p]] != c_i)
        p, a_i, c_i = p[new], a_i[new], c_i[new]
        tried_a[keep[p]], tried_c[keep[p]] = a_i, c_i  # (a dropped vertex is never asked)
        ac = points[c_i] - points[a_i]
        aa = np.einsum("ij,ij->i", ac, ac)
        short = aa <= max2
        p, a_i, c_i, ac, aa = p[short], a_i[short], c_i[short], ac[short], aa[short]
        inner = c_i - a_i - 1  # original vertices strictly between the chord's ends (>= 1)
        first = np.cumsum(inner) - inner
        owner = np.repeat(np.arange(p.shape[0]), inner)
        k = np.arange(owner.shape[0]) - np.repeat(first, inner)
        v = points[a_i[owner] + 1 + k] - points[a_i[owner]]
        f = np.clip(np.einsum("ij,ij->i", v, ac[owner]) / np.where(aa > 0.0, aa, 1.0)[owner],
                    0.0, 1.0)
        dist = row_norms(v - f[:, None] * ac[owner])
        worst = np.maximum.reduceat(dist, first) if p.shape[0] else np.zeros(0)
        drop = worst <= tol_mm
        if drop.any():
            mask = np.ones(keep.shape[0], dtype=bool)
            mask[p[drop]] = False
            keep = keep[mask]
            idle = 0
        else:
            idle += 1
        parity = 1 - parity
    return keep


#: Fewest segments per thread when :func:`_split` cuts pieces in threads
#: (:func:`~toolpath.row_threads.run_in_threads`).
SPLIT_SEGMENTS_PER_THREAD: Final[int] = 256


def _split(a: FloatArray, b: FloatArray, axis: FloatArray, move: IntArray, arc0: FloatArray,
           arc1: FloatArray, max_piece_mm: float, shank: bool, path_arc: FloatArray,
           path_move: IntArray, *, height_mm: float = 0.0,
           min_count: IntArray | None = None, axis_end: FloatArray | None = None,
           threads: int | None = None) -> Pieces:
    """Pieces of the segments ``a -> b`` (rows (n, 3)), none longer than ``max_piece_mm``.

    ``min_count`` asks for at least that many pieces per segment. Once any segment is cut,
    every segment's ``count`` pieces are cut at the fractions ``k / count`` of its chord
    (:func:`_cut_rows`); otherwise each piece is its segment, ends as given. With
    ``axis_end`` (the axes at ``b``) every piece holds the normalised interpolated axis at
    its middle; otherwise the segment's ``axis``. The pieces are written straight into
    the set's arrays (no temporaries: the bull-nose 5-axis blade program's fine model cuts
    millions of pieces), in ``threads`` threads (default numba's), each piece from its own
    segment alone: the same pieces, bit for bit, whatever the threads.
    """
    length = row_norms(b - a)
    count = np.maximum(np.ceil(length / max_piece_mm), 1).astype(np.int64)
    if min_count is not None:
        count = np.maximum(count, min_count)
    # one rule for every segment: cut at fractions of the chord once any segment is cut
    cut = int(count.max(initial=1)) > 1
    first = np.cumsum(count) - count
    n = int(first[-1] + count[-1]) if count.shape[0] else 0
    out = {"a": np.empty((n, 3)), "e": np.empty((n, 3)), "ee": np.empty(n),
           "mid": np.empty((n, 3)), "half_mm": np.empty(n), "move": np.empty(n, dtype=np.int64),
           "axis": np.empty((n, 3)), "arc0_mm": np.empty(n), "arc1_mm": np.empty(n)}
    f = np.ascontiguousarray
    ends = axis_end is not None
    run_in_threads(_cut_rows, count.shape[0], f(a, dtype=float), f(b, dtype=float),
                   f(axis, dtype=float), f(axis_end if ends else axis, dtype=float),
                   f(move, dtype=np.int64), f(arc0, dtype=float), f(arc1, dtype=float), count,
                   first, cut, ends, *out.values(), threads=threads,
                   min_rows=SPLIT_SEGMENTS_PER_THREAD)
    return Pieces(**out, shank=np.full(n, shank), path_arc_mm=path_arc, path_move=path_move,
                  height_mm=np.full(n, float(height_mm)))


@numba.njit(cache=True, nogil=True)
def _cut_rows(a: FloatArray, b: FloatArray, axis: FloatArray, axis_end: FloatArray,
              move: IntArray, arc0: FloatArray, arc1: FloatArray, count: IntArray,
              first: IntArray, cut: bool, ends: bool, out_a: FloatArray, out_e: FloatArray,
              out_ee: FloatArray, out_mid: FloatArray, out_half: FloatArray,
              out_move: IntArray, out_axis: FloatArray, out_arc0: FloatArray,
              out_arc1: FloatArray, lo: int, hi: int) -> None:
    """The pieces of segments ``lo .. hi - 1`` into rows ``first[s] ..`` (:func:`_split`).

    ``cut``: segment ``s``'s piece ``k`` of ``count[s]`` runs from ``a + f0 (b - a)`` to
    ``a + f1 (b - a)``, ``f0 = k / count``, ``f1 = (k + 1) / count``, its path lengths
    alike; with ``ends``, its axis is ``axis + f (axis_end - axis)`` normalised, ``f`` the
    mean of ``f0`` and ``f1``. Not ``cut``: the piece is the segment, its axis ``axis +
    axis_end`` normalised (``ends``). Then ``e = end - start``, ``ee = e . e``, the midpoint
    ``start + e / 2`` and half length ``sqrt(ee) / 2``.
    """
    p = np.empty(3)
    q = np.empty(3)
    x = np.empty(3)
    for s in range(lo, hi):
        n = count[s]
        for k in range(n):
            row = first[s] + k
            if cut:
                f0 = k / n
                f1 = (k + 1) / n
                for j in range(3):
                    d = b[s, j] - a[s, j]
                    p[j] = a[s, j] + f0 * d
                    q[j] = a[s, j] + f1 * d
                da = arc1[s] - arc0[s]
                c0, c1 = arc0[s] + f0 * da, arc0[s] + f1 * da
                if ends:
                    f = 0.5 * (f0 + f1)
                    for j in range(3):
                        x[j] = axis[s, j] + f * (axis_end[s, j] - axis[s, j])
            else:
                for j in range(3):
                    p[j] = a[s, j]
                    q[j] = b[s, j]
                c0, c1 = arc0[s], arc1[s]
                if ends:
                    for j in range(3):
                        x[j] = axis[s, j] + axis_end[s, j]
            if ends:
                norm = np.sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2])
                for j in range(3):
                    out_axis[row, j] = x[j] / norm
            else:
                for j in range(3):
                    out_axis[row, j] = axis[s, j]
            ee = 0.0
            for j in range(3):
                e = q[j] - p[j]
                out_a[row, j] = p[j]
                out_e[row, j] = e
                out_mid[row, j] = p[j] + 0.5 * e
                ee += e * e
            out_ee[row] = ee
            out_half[row] = 0.5 * np.sqrt(ee)
            out_move[row] = move[s]
            out_arc0[row] = c0
            out_arc1[row] = c1


def _path(motion: ToolMotion, radius_mm: float) -> tuple[FloatArray, FloatArray]:
    centres = motion.tips_mm + radius_mm * motion.axes
    step = row_norms(np.diff(centres, axis=0))
    return centres, np.concatenate(([0.0], np.cumsum(step)))


def ball_pieces(motion: ToolMotion, radius_mm: float, max_piece_mm: float, *,
                merge_tol_mm: float = 0.0) -> Pieces:
    """Capsules swept by the ball between consecutive instances (merged, then split).

    Parameters
    ----------
    motion : ToolMotion
        The replayed program.
    radius_mm : float
        Ball radius ``R``, mm.
    max_piece_mm : float
        Longest piece, mm.
    merge_tol_mm : float
        Largest distance of a ball centre from the merged chord replacing it, mm (0: no
        merging).

    Returns
    -------
    Pieces
        One or more pieces per kept chord; a program with a single instance gives one
        sphere.
    """
    centres, arc = _path(motion, radius_mm)
    moves = motion.move_of_instance
    if centres.shape[0] == 1:
        return _split(centres, centres, motion.axes, moves, arc, arc, max_piece_mm, False, arc,
                      moves)
    keep = (simplify_polyline(centres, merge_tol_mm, max_piece_mm) if merge_tol_mm > 0.0
            else np.arange(centres.shape[0]))
    i0, i1 = keep[:-1], keep[1:]
    return _split(centres[i0], centres[i1], motion.axes[i0], moves[i0 + 1], arc[i0], arc[i1],
                  max_piece_mm, False, arc, moves)


def shank_pieces(motion: ToolMotion, radius_mm: float, flute_length_mm: float,
                 spacing_mm: float, max_piece_mm: float) -> Pieces:
    """Shank capsules at instances resampled every ``spacing_mm`` along the path.

    Parameters
    ----------
    motion : ToolMotion
        The replayed program.
    radius_mm : float
        Cutter radius ``R``, mm (for flat and bull-nose cutters: the corner radius ``r``,
        the shank then being core discs swept up the axis).
    flute_length_mm : float
        Flute length ``H`` from the tip, mm; the shank capsule runs from the ball centre
        to ``H - R`` above it (flat and bull-nose: pass ``H - r``, for a core ``H - 2 r``
        tall).
    spacing_mm : float
        Largest path distance between shank instances (centre or top), mm.
    max_piece_mm : float
        Longest piece, mm.

    Returns
    -------
    Pieces
        Empty when the flutes end at the ball centre.
    """
    height = flute_length_mm - radius_mm
    centres, path_arc = _path(motion, radius_mm)
    path_move = motion.move_of_instance
    if height <= 0.0:
        empty = np.zeros((0, 3))
        none = np.zeros(0)
        return Pieces(empty, empty, none, empty, none, np.zeros(0, dtype=np.int64),
                      np.zeros(0, dtype=np.bool_), empty, none, none, path_arc, path_move,
                      none)
    tops = centres + height * motion.axes
    step = np.maximum(row_norms(np.diff(centres, axis=0)),
                      row_norms(np.diff(tops, axis=0)))
    cum = np.concatenate(([0.0], np.cumsum(step)))
    total = float(cum[-1])
    n = max(int(np.ceil(total / spacing_mm)), 0) + 1
    target = np.linspace(0.0, total, n) if total > 0.0 else np.zeros(1)
    idx = np.clip(np.searchsorted(cum, target, side="right") - 1, 0, max(len(cum) - 2, 0))
    if centres.shape[0] == 1:
        c, ax, move = centres, motion.axes, path_move
    else:
        seg = np.maximum(cum[idx + 1] - cum[idx], 1e-300)
        f = np.clip((target - cum[idx]) / seg, 0.0, 1.0)[:, None]
        c = centres[idx] + f * (centres[idx + 1] - centres[idx])
        ax = motion.axes[idx] + f * (motion.axes[idx + 1] - motion.axes[idx])
        ax /= np.linalg.norm(ax, axis=1, keepdims=True)
        move = path_move[idx + 1]
    nan = np.full(c.shape[0], np.nan)
    return _split(c, c + height * ax, ax, move, nan, nan, max_piece_mm, True, path_arc,
                  path_move)


def cutter_pieces(motion: ToolMotion, corner_radius_mm: float, height_mm: float,
                  max_piece_mm: float, *, reach_mm: float, rot_tol_mm: float,
                  merge_tol_mm: float = 0.0) -> Pieces:
    """Flat or bull-nose cutter pieces between consecutive instances (merged, then split).

    Parameters
    ----------
    motion : ToolMotion
        The replayed program.
    corner_radius_mm : float
        Corner radius ``r``, mm (0 for a flat end mill).
    height_mm : float
        Core height ``L`` of every piece, mm.
    max_piece_mm : float
        Longest piece (core centre travel), mm.
    reach_mm : float
        Distance of the farthest point of a piece's cutter from its core centre, mm.
    rot_tol_mm : float
        Largest displacement of a cutter point by the axis turning within a piece, mm
        (module docstring).
    merge_tol_mm : float
        Merge tolerance on the polyline ``(C, reach a)``, mm (0: no merging).

    Returns
    -------
    Pieces
        Pieces with ``height_mm`` ``L``, each holding its mean axis.
    """
    centres, arc = _path(motion, corner_radius_mm)
    moves, axes = motion.move_of_instance, motion.axes
    if centres.shape[0] == 1:
        return _split(centres, centres, axes, moves, arc, arc, max_piece_mm, False, arc, moves,
                      height_mm=height_mm)
    keep = (simplify_polyline(np.hstack((centres, reach_mm * axes)), merge_tol_mm,
                              max_piece_mm) if merge_tol_mm > 0.0
            else np.arange(centres.shape[0]))
    i0, i1 = keep[:-1], keep[1:]
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", axes[i0], axes[i1]), -1.0, 1.0))
    count = np.ceil(reach_mm * turn / (2.0 * rot_tol_mm)).astype(np.int64)
    return _split(centres[i0], centres[i1], axes[i0], moves[i0 + 1], arc[i0], arc[i1],
                  max_piece_mm, False, arc, moves, height_mm=height_mm, min_count=count,
                  axis_end=axes[i1])
