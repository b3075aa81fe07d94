"""The extreme deviations, refined: deepest gouge, largest excess, largest scallop.

A grid misses the top of a cusp (a kink) by about ``spacing x slope``, so the most extreme
local extremes of the grid are searched again on three levels of ``9 x 9`` sub-grids around
them (each a quarter of the previous), cutting the spacing by 64. :func:`border` marks the
samples near uncut or hidden ones, so the scallop can be taken away from the flanks of the
uncut stock.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import NDArray

from toolpath.surface import ParametricSurface

from .dexels import DexelResult
from .fine_lazy import LazyFineSweeps
from .fine_model import FineAsk, FineModel, box_centres, on_surface
from .samples import DesignSamples, surface_points_normals
from .search import Dexels

__all__ = ["Extreme", "border", "extreme", "extremes"]

FloatArray = NDArray[np.float64]

_REFINE_GRID: Final[int] = 9
#: Half-widths of the refinement's levels, in grid steps.
_REFINE_SCALES: Final[tuple[float, ...]] = (1.0, 0.25, 0.0625)
#: The fine model's levels, from the coarse ends and the grid starts: a quarter of a step
#: down to 1/256 of one.
_FINE_SCALES: Final[tuple[float, ...]] = (0.25, 0.0625, 0.015625)
#: Share of the lazy fine searches' budget (:data:`~verification.fine_lazy.KEPT_PIECES`)
#: a group of fine starts is sized to need (:func:`_start_groups`): the pieces a pair of
#: starts needs vary along the path with how fast the axis turns there.
GROUP_BUDGET_SHARE: Final[float] = 0.5
#: Share of a start's guessed deviation below which the near search's levels are skipped.
_GUESS_SHARE: Final[float] = 0.5


@dataclass(frozen=True)
class Extreme:
    """An extreme deviation: value (mm), parameters, design point (mm), move, shank."""

    dev: float
    t: float
    s: float
    point: FloatArray
    move: int
    shank: bool


def _local_extremes(dev: FloatArray, eligible: NDArray[np.bool_], largest: bool, limit: float,
                    k: int) -> NDArray[np.int64]:
    """Flat indices of up to ``k`` local extremes among eligible samples, most extreme first.

    Of equally extreme samples the earliest (smallest flat index) are kept and put first:
    on a floor cut flat every value is equal, and the refinement's first start gives the
    extreme its block, so the choice must not depend on how a partition or an unstable
    sort happens to order ties.
    """
    sign = 1.0 if largest else -1.0
    val = np.where(eligible & np.isfinite(dev), sign * dev, -np.inf)
    pad = np.pad(val, 1, constant_values=-np.inf)
    n_t, n_s = dev.shape
    top = np.full(dev.shape, -np.inf)
    for di in range(3):
        for dj in range(3):
            if di == 1 and dj == 1:
                continue
            np.maximum(top, pad[di:di + n_t, dj:dj + n_s], out=top)
    cand = np.flatnonzero(((val >= top) & np.isfinite(val) & (val > sign * limit)).ravel())
    key = -val.ravel()[cand]  # cand is increasing: index order among ties
    if cand.shape[0] > k:
        # the k-th key; every key below it, then the earliest of those equal to it
        kth = np.partition(key, k - 1)[k - 1]
        keep = key < kth
        at = np.flatnonzero(key == kth)[:k - int(np.count_nonzero(keep))]
        keep[at] = True
        cand, key = cand[keep], key[keep]
    return cand[np.argsort(key, kind="stable")]


def _grid_steps(samples: DesignSamples) -> tuple[float, float]:
    """The parameter steps the refinement's levels are scaled by, in ``t`` and ``s``."""
    n_t, n_s = samples.shape
    return 1.0 / max(n_t - 1, 1), 1.0 / max(n_s - 1, 1)


@dataclass(frozen=True)
class _Refined:
    """Per start of a refinement: the value found (mm), its parameters, point, move, shank."""

    dev: FloatArray
    t: FloatArray
    s: FloatArray
    points: FloatArray
    move: NDArray[np.int64]
    shank: NDArray[np.bool_]

    def score(self, sign: float) -> FloatArray:
        """``sign x dev``, ``-inf`` where nothing was found."""
        return np.where(np.isfinite(self.dev), sign * self.dev, -np.inf)

    @staticmethod
    def unfound(n: int) -> _Refined:
        """``n`` starts, nothing found yet (their values written in by :meth:`put`)."""
        return _Refined(np.full(n, np.nan), np.full(n, np.nan), np.full(n, np.nan),
                        np.full((n, 3), np.nan), np.full(n, -1, dtype=np.int64),
                        np.zeros(n, dtype=bool))

    def put(self, rows: NDArray[np.int64], part: _Refined) -> None:
        """``part``, the values of the starts ``rows``, written in (in place)."""
        for name in ("dev", "t", "s", "points", "move", "shank"):
            getattr(self, name)[rows] = getattr(part, name)

    def extreme(self, sign: float) -> Extreme | None:
        """The most extreme of the starts' values (None when none is finite)."""
        score = self.score(sign)
        i = int(np.argmax(score))
        if not np.isfinite(score[i]):
            return None
        return Extreme(float(self.dev[i]), float(self.t[i]), float(self.s[i]),
                       self.points[i], int(self.move[i]), bool(self.shank[i]))


def _refine(ev: Dexels, surface: ParametricSurface, samples: DesignSamples, ti: FloatArray,
            si: FloatArray, conv: FloatArray, *, largest: bool, collision: bool,
            scales: Sequence[float] = _REFINE_SCALES, contacts: Dexels | None = None,
            guess: FloatArray | None = None) -> _Refined:
    """Levels of 9 x 9 near searches around each start ``(ti, si)``.

    The levels span ``scales`` grid steps on either side, each centred on the best of the
    previous. The best point of each start is searched once more with the collision search
    (when asked), so a deep gouge only that search sees is measured exactly: ``ev``'s own,
    or with ``contacts`` the collision search of those searches, of which only what the
    near search does not model counts (the shank, a piece from behind).

    ``guess``: about the deviation at each start (a coarser model's), which, as each
    level's least deviation does for the next level, lets the near searches skip the
    narrower levels of their deepening where every point most likely passes them
    (:meth:`~verification.search.Dexels.search`'s ``guess_mm``: the same results, less
    work where a box holds more material than the first levels).
    """
    dt, ds = _grid_steps(samples)
    off = np.linspace(-1.0, 1.0, _REFINE_GRID)
    ot, os_ = (a.ravel() for a in np.meshgrid(off, off, indexing="ij"))
    sign = 1.0 if largest else -1.0
    rows = np.arange(ti.shape[0])
    n = off.size ** 2
    for scale in scales:
        t, s = on_surface(surface, ti[:, None] + scale * dt * ot[None, :],
                          si[:, None] + scale * ds * os_[None, :])
        pts, nrm, _ = surface_points_normals(surface, t.ravel(), s.ravel())
        res = ev.search(pts, nrm, np.repeat(conv, n), guess_mm=_level_guess(guess, n))
        d = ev.deviation(res, nrm).reshape(ti.shape[0], -1)
        pick = np.argmax(np.where(np.isfinite(d), sign * d, -np.inf), axis=1)
        ti, si = t[rows, pick], s[rows, pick]
        # the next level's points lie within this one's box: its least deviation
        guess = np.min(np.where(np.isnan(d), np.inf, d), axis=1)
    pts, nrm, _ = surface_points_normals(surface, ti, si)
    res = ev.search(pts, nrm, conv, far=collision and contacts is None,
                    guess_mm=_level_guess(guess, 1))
    if collision and contacts is not None:
        far = contacts.search(pts, nrm, conv, near=False, far=True, below_mm=res.lam_mm)
        other = far.shank | far.behind
        res = res.merged(DexelResult(np.where(other, far.lam_mm, np.inf), far.move,
                                     far.shank, far.behind))
    return _Refined(ev.deviation(res, nrm), ti, si, pts, res.move, res.shank)


def _level_guess(guess: FloatArray | None, n: int) -> FloatArray | None:
    """Each start's guess for its ``n`` points, scaled by :data:`_GUESS_SHARE`.

    The near search skips the levels below it (:meth:`~verification.search.Dexels.search`):
    a point of the box may hold less than the guess, and a level it skips wrongly costs a
    wider search, not a value.
    """
    return None if guess is None else np.repeat(_GUESS_SHARE * guess, n)


@dataclass(frozen=True, eq=False)
class _FineStarts:
    """One refinement's starts for the fine model (coarse ends, grid starts) and its ask."""

    t: FloatArray
    s: FloatArray
    conv: FloatArray
    ask: FineAsk
    #: the coarse model's deviation at each start (:func:`_refine`'s ``guess``)
    guess: FloatArray


def _fine_starts(fine: FineModel, surface: ParametricSurface, samples: DesignSamples,
                 start_t: FloatArray, start_s: FloatArray, start_dev: FloatArray,
                 coarse: _Refined, conv: FloatArray, *, largest: bool) -> _FineStarts | None:
    """What a refinement asks of the fine model (None: no start found anything).

    Every start is refined again with the fine model's searches
    (:meth:`~verification.fine_model.FineModel.around_each`), from its coarse end and from
    its grid start, over a quarter of a grid step and finer (the coarse model's bumps along
    a cusp's ridge may have led its own levels to another top). The fine model is built
    for the near searches at every design point of the parameter boxes,
    ``sum(_FINE_SCALES)`` grid steps on either side of a coarse end or a grid start, that
    the fine levels may visit (:func:`~verification.fine_model.box_centres`).

    No start is left out on its coarse value: the coarse levels measured it at the
    points they visited only, and the fine levels visit others, up to a third of a grid
    step away, where nothing bounds the coarse value short of a slope bound of the cut
    (a cusp's flank rises at up to ``rho / R`` for a near-search radius ``rho``: tens of
    micrometres over a third of a step, far more than the model's tolerance).
    """
    sign = 1.0 if largest else -1.0
    keep = np.flatnonzero(np.isfinite(coarse.score(sign)))
    if keep.shape[0] == 0:
        return None
    c = fine.coarse
    # the near search's last level must hold the most material kept; a gouge deeper than
    # the near search was sized for: sized for it, as the grid search does
    most = float(np.max(coarse.dev[keep])) + fine.model_tol_mm
    level = fine.level_for_mm(most) if largest else c.horizons[0]
    deepest = float(-coarse.dev[keep].min()) + fine.model_tol_mm
    depth = c.depth if largest else min(max(1.25 * deepest, c.depth), c.radius + c.horizon)
    # every point the fine levels search lies in the parameter box of a coarse end or a
    # grid start whose half-width is the levels' summed scales (each level is centred on
    # a point of the previous one's box): the fine model holds the near searches there
    dt, ds = _grid_steps(samples)
    wide = sum(_FINE_SCALES)
    both_t = np.concatenate((coarse.t[keep], start_t[keep]))
    both_s = np.concatenate((coarse.s[keep], start_s[keep]))
    both_conv = np.tile(conv[keep], 2)
    centres, slack = box_centres(surface, both_t, both_s, wide * dt, wide * ds, c.corner)
    return _FineStarts(both_t, both_s, both_conv,
                       FineAsk(centres, slack, both_conv, level, depth),
                       np.concatenate((coarse.dev[keep], start_dev[keep])))


def _refine_finely(ev: Dexels, coarse: Dexels, surface: ParametricSurface,
                   samples: DesignSamples, starts: _FineStarts, *, largest: bool,
                   collision: bool) -> Extreme | None:
    """The fine value of a refinement: its starts searched with the fine model ``ev``.

    ``ev`` holds the fine searches of the starts' ask, ``coarse`` the whole program's.
    The fine value is taken at the coarse ends and the grid starts themselves with the
    collision search (a contact only that search sees leads the levels nowhere), and
    from both through the fine levels, the most extreme kept.

    Where the fine searches are lazy (:class:`~verification.fine_lazy.LazyFineSweeps`,
    which keeps the fine pieces of the segments its searches needed, up to a budget) the
    starts go through every level a group at a time (:func:`_start_groups`): a level of
    all the starts at once asks for the segments round every start, more than the budget
    holds on a 5-axis flat or bull-nose program, and each batch dropped and replayed what
    the previous level's same batch had kept. Each start's levels depend on its own
    values only, and a search's values not on what else is kept
    (:mod:`verification.fine_lazy`), so the figures are those of all the starts at once.
    """
    sign = 1.0 if largest else -1.0
    kw = {"largest": largest, "collision": collision, "contacts": coarse}
    # guesses where the fine searches are lazy (each level a replay and a walk of the
    # whole program's coarse pieces); elsewhere a level skipped to builds a wider grid
    # (on the ball blade 70-90 MB more peak, for no time)
    lazy = isinstance(ev.index, LazyFineSweeps)
    n = starts.t.shape[0]
    at_both, levels = _Refined.unfound(n), _Refined.unfound(n)
    for rows in _start_groups(ev.index if lazy else None, n):
        # at the coarse ends and grid starts themselves, then from both through the fine
        # levels: the coarse model's bumps may have led its levels to another top
        here = _refine(ev, surface, samples, starts.t[rows], starts.s[rows],
                       starts.conv[rows], scales=(),
                       guess=starts.guess[rows] if lazy else None, **kw)
        deeper = _refine(ev, surface, samples, starts.t[rows], starts.s[rows],
                         starts.conv[rows], scales=_FINE_SCALES,
                         guess=here.dev if lazy else None, **kw)
        at_both.put(rows, here)
        levels.put(rows, deeper)
    best = [at_both.extreme(sign), levels.extreme(sign)]
    known = [e for e in best if e is not None]
    return max(known, key=lambda e: sign * e.dev) if known else None


def _start_groups(lazy: LazyFineSweeps | None, n: int) -> Iterator[NDArray[np.int64]]:
    """The rows of ``n`` fine starts, a group at a time (all at once without ``lazy``).

    The starts are the coarse ends, then the grid starts in the same order
    (:func:`_fine_starts`): a coarse end and its grid start lie within a third of a grid
    step of each other and need the same segments, so they go in one group. The first
    group's levels are one batch of ``lazy``'s searches; each next group as many pairs as
    the budget holds :data:`GROUP_BUDGET_SHARE` of, at the pieces per pair kept so far
    (those kept, since a drop, over the pairs searched since).
    """
    pairs = n // 2
    if lazy is None:
        yield np.arange(n)
        return
    per = max(lazy.batch // (2 * _REFINE_GRID ** 2), 1)
    lo, since, drops = 0, 0, lazy.drops
    while lo < pairs:
        hi = min(lo + per, pairs)
        yield np.concatenate((np.arange(lo, hi), pairs + np.arange(lo, hi)))
        since = hi - lo if lazy.drops != drops else since + hi - lo
        drops, lo = lazy.drops, hi
        per = max(int(GROUP_BUDGET_SHARE * lazy.kept_pieces * since
                      / max(lazy.pieces_kept, 1)), 1)


def extreme(ev: Dexels, surface: ParametricSurface, samples: DesignSamples,
             res: DexelResult, dev: FloatArray, eligible: NDArray[np.bool_], *,
             largest: bool, limit: float, refine: int, collision: bool,
             fine: FineModel | None = None) -> Extreme | None:
    """The most extreme deviation among eligible samples beyond ``limit``, refined."""
    return extremes(ev, surface, samples, res, dev, [(eligible, largest, limit)],
                    refine=refine, collision=collision, fine=fine)[0]


def extremes(ev: Dexels, surface: ParametricSurface, samples: DesignSamples,
             res: DexelResult, dev: FloatArray,
             asks: Sequence[tuple[NDArray[np.bool_], bool, float]], *, refine: int,
             collision: bool, fine: FineModel | None = None) -> list[Extreme | None]:
    """:func:`extreme` of each ask ``(eligible, largest, limit)``, searching each start once.

    An extreme depends on its mask only through the most extreme eligible sample and the
    ``refine`` local extremes its refinement starts from: an ask with the same sense,
    limit, sample and starts as an earlier one (the largest scallop is most often the
    largest excess, away from the uncut flanks) has the very same searches, so it takes
    the earlier one's result instead of running them again.

    With a ``fine`` model the figures are those of the fine model (:func:`_refine_finely`):
    the same whatever moves the path is written in. Its candidates are taken from
    ``limit`` widened by the coarse model's tolerance, so an extreme the coarse model puts
    short of the limit (a gouge shallower than the gouge tolerance) but the fine model
    beyond it is still found; it is reported only if its fine value is beyond ``limit``.
    The fine model is built once for every ask's refinement
    (:meth:`~verification.fine_model.FineModel.around_each`): the stretches of path they
    share replayed and indexed once.
    """
    n_s = samples.shape[1]
    found: dict[tuple[bool, float, int, bytes], Extreme | None] = {}
    keys: list[tuple[bool, float, int, bytes] | None] = []
    # with a fine model: each refinement's fine starts, the fine model built once for all
    pending: list[tuple[tuple[bool, float, int, bytes], bool, Extreme, _FineStarts]] = []
    for eligible, largest, limit in asks:
        flat = np.where(eligible & np.isfinite(dev), dev, np.nan).ravel()
        if np.isnan(flat).all():
            keys.append(None)
            continue
        i = int(np.nanargmax(flat) if largest else np.nanargmin(flat))
        sign = 1.0 if largest else -1.0
        widen = fine.model_tol_mm if fine is not None else 0.0
        cand = (_local_extremes(dev, eligible, largest, limit - sign * widen, refine)
                if refine else np.zeros(0, dtype=np.int64))
        key = (largest, limit, i, cand.tobytes())
        keys.append(key)
        if key in found:
            continue
        best: Extreme | None = Extreme(
            float(flat[i]), float(samples.t[i // n_s]), float(samples.s[i % n_s]),
            samples.points.reshape(-1, 3)[i], int(res.move[i]), bool(res.shank[i]))
        if cand.shape[0]:
            conv = samples.convexity_per_mm.ravel()[cand]
            t0, s0 = samples.t[cand // n_s], samples.s[cand % n_s]
            # (no guess here: a coarse level skipped to builds the whole program's grid
            # for a wider search, 120 MB more peak on the ball blade, for no time)
            coarse = _refine(ev, surface, samples, t0, s0, conv, largest=largest,
                             collision=collision)
            if fine is None:
                refined = coarse.extreme(sign)
                if refined is not None and sign * refined.dev >= sign * best.dev:
                    best = refined
            else:
                # the fine model's value (once it is built for every ask), else the grid's
                starts = _fine_starts(fine, surface, samples, t0, s0, dev.ravel()[cand],
                                      coarse, conv, largest=largest)
                if starts is not None:
                    pending.append((key, largest, best, starts))
        found[key] = _beyond(best, largest, limit)
    if fine is not None and pending:
        models = fine.around_each([starts.ask for _, _, _, starts in pending])
        for (key, largest, best, starts), model in zip(pending, models, strict=True):
            refined = None if model is None else _refine_finely(
                model, ev, surface, samples, starts, largest=largest, collision=collision)
            found[key] = _beyond(best if refined is None else refined, largest, key[1])
    return [None if key is None else found[key] for key in keys]


def _beyond(best: Extreme | None, largest: bool, limit: float) -> Extreme | None:
    """``best`` where it lies beyond ``limit`` (above it for the largest, else below)."""
    sign = 1.0 if largest else -1.0
    return best if best is not None and sign * best.dev > sign * limit else None


def border(bad: NDArray[np.bool_], rt: int, rs: int) -> NDArray[np.bool_]:
    """Samples within ``rt`` x ``rs`` grid steps of a ``bad`` sample (box filter)."""
    c = np.pad(bad.astype(np.int64), ((rt + 1, rt), (rs + 1, rs))).cumsum(0).cumsum(1)
    n_t, n_s = bad.shape
    box = (c[2 * rt + 1:2 * rt + 1 + n_t, 2 * rs + 1:2 * rs + 1 + n_s]
           - c[:n_t, 2 * rs + 1:2 * rs + 1 + n_s]
           - c[2 * rt + 1:2 * rt + 1 + n_t, :n_s] + c[:n_t, :n_s])
    return box > 0
