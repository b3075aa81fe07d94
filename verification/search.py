"""The searches over the whole design-sample grid, and at any design points.

:class:`Dexels` binds the swept-cutter index (:class:`~verification.dexels.SweepIndex`) to
the cutter radius, the near search's levels and gouge depth, and the dexel method, and
turns search results into normal deviations. :func:`grid_search` runs the near search on
every visible sample, the collision search on a coarse subset, and searches again around
every coarse sample where the collision search found more (see :mod:`verification.dexels`).
"""

from __future__ import annotations

from typing import Final

import numpy as np
from numpy.typing import NDArray

from .dexels import DexelResult, SweepIndex, near_search_radius_mm, ranks_before_rows
from .options import DexelMethod
from .samples import DesignSamples
from .vectors import row_norms

__all__ = ["Z_MIN_COSINE", "Dexels", "grid_search", "joined_rows", "scatter"]

FloatArray = NDArray[np.float64]

Z_MIN_COSINE: Final[float] = 0.05
"""A Z-map sees a sample only where its normal is within acos(0.05) = 87 deg of +Z."""

FLAG_MARGIN_MM: Final[float] = 1e-9
"""The collision search finds more than the near search where lower by more than this, mm:
the rounding of one piece met by both searches, far below any deviation reported."""


class Dexels:
    """Deviation of arbitrary design points: the searches with their parameters.

    Parameters
    ----------
    index : SweepIndex
        The swept cutter.
    radius : float
        Cutter radius ``R``, mm.
    horizons : tuple of float
        Near-search levels (iterative deepening), mm; the last is the excess horizon.
    depth : float
        Gouge depth the near search is sized for, mm.
    method : DexelMethod
        ``normal`` or ``z``.
    corner_radius : float, optional
        Corner radius ``r`` of a flat or bull-nose cutter, mm (default: a ball, ``r = R``):
        the near search runs around ``P + r n`` for the core centres.
    model_tol_mm : float
        How far inside the swept cutter its pieces may lie, mm (the replay's chord
        tolerance plus the merge tolerance): a shank piece that leaves less than the near
        search by no more than this met the cutter end the pieces approximate, at one of
        the shank's instances, not something the near search missed (0: any less).
    """

    def __init__(self, index: SweepIndex, radius: float, horizons: tuple[float, ...],
                 depth: float, method: DexelMethod, *, corner_radius: float | None = None,
                 model_tol_mm: float = 0.0) -> None:
        self.index, self.radius, self.depth = index, radius, depth
        self.model_tol_mm = model_tol_mm
        self.corner = radius if corner_radius is None else corner_radius
        self.horizons = horizons
        self.horizon = horizons[-1]
        self.method = method

    def near_radius_mm(self, level_mm: float, depth_mm: float, convexity: FloatArray
                       ) -> FloatArray:
        """Near-search radius around ``P + r n`` at a level, mm (:func:`near_search_radius_mm`)."""
        return near_search_radius_mm(self.corner, level_mm, depth_mm, convexity,
                                     core_radius_mm=self.radius - self.corner)

    def directions(self, normals: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Dexel directions (rows) and their cosine with the normal."""
        if self.method is DexelMethod.Z:
            dirs = np.zeros_like(normals)
            dirs[:, 2] = 1.0
            return dirs, normals[:, 2].copy()
        return normals, row_norms(normals)

    def visible(self, normals: FloatArray) -> NDArray[np.bool_]:
        """Samples whose dexel is defined (Z-map: facing up enough)."""
        _, cos = self.directions(normals)
        return cos >= (Z_MIN_COSINE if self.method is DexelMethod.Z else 0.5)

    def search(self, points: FloatArray, normals: FloatArray, convexity: FloatArray,
               *, near: bool = True, far: bool = False, depth: float | None = None,
               below_mm: FloatArray | None = None,
               below_piece: NDArray[np.int64] | None = None,
               guess_mm: FloatArray | None = None) -> DexelResult:
        """Near and/or collision search at design points.

        Parameters
        ----------
        points, normals : ndarray, shape (q, 3)
            Design points (mm) and their unit outward normals.
        convexity : ndarray, shape (q,)
            ``1/rho`` at the points, 1/mm (widens the near search at convex edges).
        near, far : bool
            Run the near search (iterative deepening over the levels) and/or the
            collision search.
        depth : float, optional
            Gouge depth the near search is sized for, mm (default: the instance's).
        below_mm : ndarray, shape (q,), optional
            Material already known on the dexels, which the caller keeps where it is
            lower: the collision search then seeks only less (where it finds none, the
            result holds the near search's, or nothing).
        below_piece : ndarray of int64, shape (q,), optional
            The pieces of ``below_mm`` (``-1``: none): an equal value of a piece before
            it is sought too (the tie rule of :mod:`verification.dexels`).
        guess_mm : ndarray, shape (q,), optional
            About how much material each dexel holds (normal deviation, mm; ``inf``:
            beyond the horizon): the near search starts a dexel at the first level not
            below its guess, skipping the narrower ones it would most likely pass. The
            result is the same whatever the guess. A level's ball holds every narrower
            level's, so of the levels a dexel passes the widest finds what the deepening
            keeps of them all (the lowest value; of equal values the first piece, which
            its merge keeps). A value found within a narrower level is exact (every piece
            leaving less lies within that level's ball) and would have stopped the
            deepening there, at the first level it lies within, whose ball may miss a
            tied piece of smaller index the wider ball holds: such a dexel is searched
            again at that level and takes its result (the guess was too high; that
            search is the cost). Only the work differs: one wide search rather than
            every narrower one before it.

        Returns
        -------
        DexelResult
            Along the dexel directions.
        """
        g = self.depth if depth is None else depth
        dirs, cos = self.directions(normals)
        out = DexelResult.empty(points.shape[0])
        if near:
            # iterative deepening: a dexel whose remaining material is found within level
            # e_k is exact (every ball that could leave less lies within r(e_k)); the others
            # are searched again with the next, wider level
            centres = normals * self.corner
            centres += points
            first = (np.zeros(points.shape[0], dtype=np.int64) if guess_mm is None else
                     np.minimum(np.searchsorted(self.horizons, guess_mm, side="left"),
                                len(self.horizons) - 1))
            last = int(first.max()) if first.size else 0  # (the last level any dexel joins)
            todo = np.zeros(0, dtype=np.int64)
            for k, level in enumerate(self.horizons):
                # dexels guessed to hold more than the narrower levels join here
                todo = joined_rows(todo, np.flatnonzero(first == k))
                if todo.shape[0] == 0:
                    continue
                # the first level meets every dexel: no copies of the rows
                every = todo.shape[0] == points.shape[0]
                r = self.near_radius_mm(level, g, convexity if every else convexity[todo])
                part = (self.index.search("near", points, dirs, centres, r, rim_in_radii=True)
                        if every else
                        self.index.search("near", points[todo], dirs[todo], centres[todo], r,
                                          rim_in_radii=True))
                # the first of both (the tie rule): a tied piece of smaller index may lie
                # only in the wider ball
                scatter(out, todo, part, merge=True)
                value = part.lam_mm * cos[todo]
                if k:
                    joined = first[todo] == k
                    self._narrower(out, todo[joined], value[joined], k, points, dirs,
                                   centres, convexity, cos, g)
                todo = todo[~(value <= level)]
                if todo.shape[0] == 0 and k >= last:
                    break
        if far:
            # a flat/bull-nose piece's core stands up to its height above its segment
            r = np.full(points.shape[0], self.radius + self.horizon
                        + self.index.ball.max_height_mm)
            low, low_piece = out.lam_mm, out.piece
            if below_mm is not None:
                given_piece = (np.full_like(low_piece, -1) if below_piece is None
                               else below_piece)
                given = ranks_before_rows(below_mm, given_piece, low, low_piece)
                low = np.where(given, below_mm, low)
                low_piece = np.where(given, given_piece, low_piece)
            scatter(out, np.arange(points.shape[0]),
                     self.index.search("far", points, dirs, points, r, below_mm=low,
                                       below_piece=low_piece), merge=True)
        return out

    def _narrower(self, out: DexelResult, joined: NDArray[np.int64], value: FloatArray,
                  k: int, points: FloatArray, dirs: FloatArray, centres: FloatArray,
                  convexity: FloatArray, cos: FloatArray, depth: float) -> None:
        """Dexels started at level ``k`` by a guess, where the deepening may have stopped sooner.

        ``value``: their normal deviation at level ``k``. A narrower level finds no less
        (its ball holds fewer pieces), so the deepening passes every level below the
        first one ``value`` lies within; from there they are searched level by level as
        the deepening searches them, and one that stops below ``k`` takes that level's
        result (the first piece of that ball) in place of level ``k``'s.
        """
        stop = np.searchsorted(self.horizons, value, side="left")
        back, stop = joined[stop < k], stop[stop < k]
        for j in range(int(stop.min()) if back.shape[0] else k, k):
            # those whose value lies within level j may stop there; the others pass it
            may = back[stop <= j]
            if may.shape[0] == 0:
                continue
            level = self.horizons[j]
            part = self.index.search("near", points[may], dirs[may], centres[may],
                                     self.near_radius_mm(level, depth, convexity[may]),
                                     rim_in_radii=True)
            done = np.flatnonzero(part.lam_mm * cos[may] <= level)
            scatter(out, may[done], DexelResult(part.lam_mm[done], part.move[done],
                                                part.shank[done], part.behind[done],
                                                part.pairs, part.piece[done]))
            keep = ~np.isin(back, may[done])
            back, stop = back[keep], stop[keep]

    def deviation(self, result: DexelResult, normals: FloatArray) -> FloatArray:
        """Normal deviation ``lam (d . n)``, mm; ``+inf`` beyond the horizon, NaN hidden."""
        _, cos = self.directions(normals)
        with np.errstate(invalid="ignore"):
            dev = result.lam_mm * cos
        dev = np.where(np.isfinite(dev) & (dev <= self.horizon), dev, np.inf)
        return np.where(self.visible(normals), dev, np.nan)


def joined_rows(rows: NDArray[np.int64], joining: NDArray[np.int64]) -> NDArray[np.int64]:
    """``np.union1d(rows, joining)`` for two sorted, disjoint arrays of row indices.

    The near search's dexels still to search (``rows``, sorted: the deepening only drops
    some) and those joining at this level (``joining``, from :func:`np.flatnonzero`): a
    dexel joins at one level only, so the two never share an index. Their union is then
    the sorted merge, and one of them alone when the other is empty (most levels). Numpy
    2.3+ finds a union's unique values by hashing: 0.45 s of CPU for the ~1,000,000
    dexels joining at the first level on the issue-27 blade, and 0.3 s more over the
    levels no dexel joins; the merge takes milliseconds.
    """
    if joining.shape[0] == 0:
        return rows
    if rows.shape[0] == 0:
        return joining
    merged = np.concatenate((rows, joining))
    merged.sort(kind="stable")  # (two sorted runs: a merge)
    return merged


def _coarse_positions(n: int, stride: int) -> NDArray[np.int64]:
    pos = np.arange(0, n, stride, dtype=np.int64)
    return pos if pos[-1] == n - 1 else np.append(pos, n - 1)


def _dilate(mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
    pad = np.pad(mask, 1)
    out = np.zeros_like(mask)
    for di in range(3):
        for dj in range(3):
            out |= pad[di:di + mask.shape[0], dj:dj + mask.shape[1]]
    return out


class _Windows:
    """Fine samples around flagged coarse samples (one coarse step and its neighbours)."""

    def __init__(self, ct: NDArray[np.int64], cs: NDArray[np.int64], n_t: int, n_s: int,
                 coarse: NDArray[np.int64]) -> None:
        self.ct, self.cs, self.coarse = ct, cs, coarse
        self.lt = np.clip(np.searchsorted(ct, np.arange(n_t), side="right") - 1, 0,
                          ct.shape[0] - 1)
        self.ls = np.clip(np.searchsorted(cs, np.arange(n_s), side="right") - 1, 0,
                          cs.shape[0] - 1)
        self.ut = np.minimum(self.lt + 1, ct.shape[0] - 1)
        self.us = np.minimum(self.ls + 1, cs.shape[0] - 1)

    def around(self, flagged: NDArray[np.bool_]) -> NDArray[np.int64]:
        """Flat indices of the fine samples (not coarse ones) near flagged coarse samples."""
        hot = _dilate(flagged.reshape(self.ct.shape[0], self.cs.shape[0]))
        mark = (hot[np.ix_(self.lt, self.ls)] | hot[np.ix_(self.ut, self.ls)]
                | hot[np.ix_(self.lt, self.us)] | hot[np.ix_(self.ut, self.us)]).ravel()
        mark[self.coarse] = False
        return np.flatnonzero(mark)


def grid_search(ev: Dexels, samples: DesignSamples, collision_stride: int | None, *,
                guess_mm: FloatArray | None = None) -> tuple[DexelResult, FloatArray]:
    """Deviation on the whole sample grid (near everywhere, collision coarse + around hits).

    Parameters
    ----------
    ev : Dexels
        The searches.
    samples : DesignSamples
        The design samples.
    collision_stride : int or None
        Grid steps between the collision search's coarse samples; None: no collision search.
    guess_mm : ndarray, shape (n_t, n_s), optional
        About how much material each sample holds, for the near search to start at the
        level that most likely finds it (:meth:`Dexels.search`: the same results, less
        work; ``inf`` where nothing is expected).

    Returns
    -------
    result : DexelResult
        Per sample (flat, row-major over ``(n_t, n_s)``), along the dexels.
    deviation : ndarray
        Normal deviation per sample, mm (``+inf`` beyond the horizon, NaN hidden).
    """
    n_t, n_s = samples.shape
    pts = samples.points.reshape(-1, 3)
    nrm = samples.normals.reshape(-1, 3)
    conv = samples.convexity_per_mm.ravel()
    vis = np.flatnonzero(ev.visible(nrm))
    res = DexelResult.empty(pts.shape[0])
    # every sample visible (the normal dexels of a surface): no copies of the rows
    every = vis.shape[0] == pts.shape[0]
    guess = None if guess_mm is None else np.asarray(guess_mm, dtype=float).ravel()
    part = (ev.search(pts, nrm, conv, guess_mm=guess) if every else
            ev.search(pts[vis], nrm[vis], conv[vis],
                      guess_mm=None if guess is None else guess[vis]))
    scatter(res, vis, part)
    if collision_stride is not None:
        ct = _coarse_positions(n_t, collision_stride)
        cs = _coarse_positions(n_s, collision_stride)
        coarse = (ct[:, None] * n_s + cs[None, :]).ravel()
        far = ev.search(pts[coarse], nrm[coarse], conv[coarse], near=False, far=True,
                        below_mm=res.lam_mm[coarse], below_piece=res.piece[coarse])
        near_lam, near_move = res.lam_mm[coarse], res.move[coarse]
        # a shank piece starts at the cutter end (a ball's centre), so at its instance it
        # holds the very cutter the near search's merged pieces approximate from inside:
        # of the same block and less by no more than that approximation, it is the same
        # contact, not a miss (a shank of another block is searched around as before)
        end = (far.shank & ~far.behind & (far.move == near_move)
               & (far.lam_mm >= near_lam - ev.model_tol_mm))
        flagged = (far.lam_mm < near_lam - FLAG_MARGIN_MM) & ~end
        # the near search missed it: a ball from outside gouging deeper than it was sized
        # for, or something it never looks at (shank, from behind, a sharp convex edge)
        deep = flagged & ~(far.shank | far.behind) & (far.lam_mm < 0.0)
        collide = flagged & ~deep
        scatter(res, coarse, far, merge=True)
        windows = _Windows(ct, cs, n_t, n_s, coarse)
        if deep.any():
            # a ball from outside, deeper than the near search was sized for: search again
            # near, sized for the deepest such gouge (the ball centre that far below Q)
            depth = min(max(1.25 * float(-far.lam_mm[deep].min()), ev.depth),
                        ev.radius + ev.horizon)
            idx = windows.around(deep)
            scatter(res, idx, ev.search(pts[idx], nrm[idx], conv[idx], depth=depth),
                     merge=True)
        if collide.any():
            idx = windows.around(collide)
            scatter(res, idx, ev.search(pts[idx], nrm[idx], conv[idx], near=False, far=True,
                                        below_mm=res.lam_mm[idx], below_piece=res.piece[idx]),
                     merge=True)
    return res, ev.deviation(res, nrm)


def scatter(res: DexelResult, idx: NDArray[np.int64], part: DexelResult, *,
             merge: bool = False) -> None:
    """Write ``part`` (results at ``idx``) into ``res``; with ``merge`` only where first.

    First: lower, or of equal value a piece before (the tie rule,
    :func:`~verification.dexels.ranks_before_rows`).
    """
    take = (ranks_before_rows(part.lam_mm, part.piece, res.lam_mm[idx], res.piece[idx])
            if merge else np.ones(idx.shape[0], dtype=bool))
    sel = idx[take]
    res.lam_mm[sel] = part.lam_mm[take]
    res.move[sel] = part.move[take]
    res.shank[sel] = part.shank[take]
    res.behind[sel] = part.behind[take]
    res.piece[sel] = part.piece[take]
    object.__setattr__(res, "pairs", res.pairs + part.pairs)
