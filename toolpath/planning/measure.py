"""Scallop measured on a finished toolpath, independently of the planner.

Nothing here uses the planner's curvature formulas or its internal parameters: only the
toolpath's arrays (tips, axes, kinds, passes), the surface and the cutter solid. The chord
error, whose contacts seed the scallop's search, is measured by :mod:`.chord_measure`.

**Scallop.** At a surface point ``Q`` with normal ``n`` the height of the machined surface
is the distance along ``n`` at which the ray ``Q + l n`` enters the material removed by
the cutter (:mod:`.cut_volume`). Heights beyond the horizon (10 times the request, at least
0.05 mm) count as *uncut*. The cusps are searched from every contact point and every
mid-chord contact standing above the surface found by the chord measurement, at fixed
``t``, towards increasing ``s``, where the height left by the contact's own pass meets the
height left by the other passes (ray cast, :mod:`.cusp_search`; most seeds' cusps first
estimated from the passes' own geometry, :mod:`.cusp_estimates`, and ray cast only where
the estimate cannot decide; where none stands, a sample along the passes and the seeds near
its high cusps). A contact with no other pass within the search's bracket
borders an uncut area and has no cusp. A coarse grid gives the uncut area, and distances
from it along the surface (:mod:`.uncut_area`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from machines import Machine

from ..path import Toolpath
from ..surface import ParametricSurface
from .chord_measure import ChordMeasurement
from .cusp_estimates import ball_cusp_estimates, torus_cusp_bounds
from .cusp_search import CuspSearch, SearchSeeds
from .cut_volume import CutVolume, cusp_horizon_mm
from .cutters import Cutter
from .uncut_area import UncutArea

__all__ = ["ESTIMATE_MIN_SEEDS", "ESTIMATE_SHARE", "ESTIMATE_TOP", "ESTIMATE_TOP_MOST",
           "ESTIMATE_TOP_SHARE", "ScallopMeasurement", "SeedCusps", "cast_beyond_estimates",
           "measure_scallop", "seed_cusps"]


@dataclass(frozen=True)
class ScallopMeasurement:
    """Height of the material left between passes, mm.

    Attributes
    ----------
    max_mm : float
        Largest height over the cut samples (0 when nothing was cut).
    t, s : float
        Where it is.
    interior_max_mm : float
        Largest height over samples more than a cutter diameter away, along the surface,
        from any uncut sample (excludes the slivers along the border of unreachable
        regions).
    uncut_fraction : float
        Area fraction of the surface left uncut (coarse grid).
    n_samples : int
        Seeds whose cusp was measured.
    n_cast : int
        Of them, those measured by ray casting (the others by the ball's estimate).
    """

    max_mm: float
    t: float
    s: float
    interior_max_mm: float
    uncut_fraction: float
    n_samples: int
    n_cast: int = 0


#: Seeds whose cusp, as estimated from the passes' own geometry, exceeds the largest cusp
#: the ray cast found by this factor are ray cast too: the estimate errs by a few per cent
#: (of the cusps above half the largest, 98 % stand within 0.98 to 1.18 of the ray cast on
#: the dev blade, 0.99 to 1.002 on the R150 dome), so where it stands higher than that
#: the ray cast decides.
ESTIMATE_SHARE = 1.03


#: Seeds of the largest estimates ray cast first (per group): on planned passes the
#: largest cusp is among them, or one within a fraction of a per cent of it where the
#: cusps are all alike (the estimate then ranks seeds by its few per cent of error; more
#: are cast wherever an estimate not cast reaches the largest found, below). 64, not 256
#: as before: on the 90 plans of ``bench_toolpath.py --sweep`` the same figures to the
#: printed digit, and the smaller plans of a flat or bull-nose cutter (about half a
#: millisecond a cast) measured faster (lying blade, bull:8:1, scallop 0.25 mm, chord
#: 0.03 mm: 0.297 -> 0.213 s; standing, chord 0.1 mm: 0.379 -> 0.242 s); in full
#: precision one plan's largest cusp came 0.005 % lower (one among thousands alike that
#: the 256 had happened to cast) ...
ESTIMATE_TOP = 64

#: ... or this share of the seeds, when more (a quarter of the 1 % it was, with the count).
ESTIMATE_TOP_SHARE = 0.0025

#: Where an estimate not cast still reaches the largest cusp found (the estimate ranks the
#: seeds poorly there, as on the elliptic blade in 5 axes, or a cluster of alike cusps
#: reads a little high), twice as many of the largest are cast, and so on up to this many:
#: a cusp the first cast missed is then found wherever the estimates do not read low. (The
#: estimates standing above the largest cusp by more than they err are then cast this many
#: at a time, then twice as many, and so on.)
ESTIMATE_TOP_MOST = 1024

#: Fewer seeds are all ray cast: as few as the first round casts. Above it the estimate
#: (about a fifteenth of a seed's ray cast per seed) pays wherever it leaves seeds out: on
#: the coarse plans of ``bench_toolpath.py --sweep`` (470 to 2,900 seeds) it left out up to
#: 80 % of them, with the same figures as casting all.
ESTIMATE_MIN_SEEDS = ESTIMATE_TOP


#: Seeds with no estimate from the passes' own geometry (a flat end or a bull-nose turning
#: round its contact, or where no pose of a pass touches near the seed: most seeds of the
#: 5-axis flat-end jobs on the real-like blades) are ray cast a sample at a time: along each
#: run of them (consecutive seeds of a pass, a contact or a mid-chord contact apart: about
#: 0.07 mm at the median on the DCA rotor's 5-axis flat:6 job) its first and last and every
#: this many between, ...
SAMPLE_STRIDE = 8

#: ... and then every seed with no estimate within :data:`SAMPLE_STRIDE` seeds of one whose
#: cusp cast reaches this share of the largest cusp cast in its group, or stands above the
#: horizon, until none is left near one (the cusps along a pass change
#: gradually: on the DCA rotor's 5-axis flat:6 job, trunnion-ac, every seed of a cusp above
#: 0.8 of the largest had a seed within 16 of it, among every 16th, of at least 0.9 of
#: it).
SAMPLE_NEAR_SHARE = 0.6


def measure_scallop(toolpath: Toolpath, surface: ParametricSurface, cutter: Cutter,
                    scallop_mm: float, chord: ChordMeasurement, *,
                    machine: Machine | None = None, chunk: int = 20_000,
                    estimate: bool = True, estimate_min_seeds: int = ESTIMATE_MIN_SEEDS,
                    estimate_top: int = ESTIMATE_TOP,
                    estimate_top_share: float = ESTIMATE_TOP_SHARE,
                    estimate_top_most: int = ESTIMATE_TOP_MOST) -> ScallopMeasurement:
    """Measure the material left between passes (module docstring).

    With the 5-axis ``machine`` whose joint interpolation the toolpath was checked under,
    the cutter moves as that interpolation moves it (as in
    :func:`~.chord_measure.measure_chord`). The largest of the seeds' cusps
    (:func:`seed_cusps`), overall and away from uncut areas.

    Parameters
    ----------
    toolpath, surface, cutter
        What was cut, the design surface and the cutter.
    scallop_mm : float
        The request; sets the horizon (:func:`cusp_horizon_mm`).
    chord : ChordMeasurement
        From :func:`~.chord_measure.measure_chord` on the same toolpath: its contacts seed
        the search.
    chunk : int
        Seeds per vectorized batch.
    estimate : bool
        More than ``estimate_min_seeds`` seeds: estimate every seed's cusp from the
        passes' own geometry (:func:`~.cusp_estimates.ball_cusp_estimates`, flat and
        bull-nose cutters :func:`~.cusp_estimates.torus_cusp_estimates`) and ray-cast only
        the seeds of the largest estimates, and of those with none a sample and the seeds
        near its high cusps (:func:`cast_beyond_estimates`);
        False ray-casts every seed (the full method).
    estimate_min_seeds, estimate_top, estimate_top_share, estimate_top_most
        Fewer seeds are all ray cast; else at least the ``estimate_top`` seeds of the
        largest estimates, or that share of the seeds when more, and twice as many while
        any estimate not cast reaches the largest cusp cast, up to ``estimate_top_most``
        (defaults :data:`ESTIMATE_MIN_SEEDS`, :data:`ESTIMATE_TOP`,
        :data:`ESTIMATE_TOP_SHARE`, :data:`ESTIMATE_TOP_MOST`).
    """
    return _scallop_result(seed_cusps(
        toolpath, surface, cutter, scallop_mm, chord, machine=machine, chunk=chunk,
        estimate=estimate, estimate_min_seeds=estimate_min_seeds, estimate_top=estimate_top,
        estimate_top_share=estimate_top_share, estimate_top_most=estimate_top_most))


@dataclass(frozen=True)
class SeedCusps:
    """Each seed's cusp: where the search starts, the ball's estimate, the ray cast.

    One row per seed: the chord measurement's seeds short of ``s = 1``
    (:attr:`ChordMeasurement.seeds_t` and so on), in their order.

    Attributes
    ----------
    t, s : ndarray
        Where the search starts (a contact, or a mid-chord contact above the surface).
    pass_index : ndarray of int
        The seed's pass.
    estimate_mm : ndarray
        The estimate from the passes' own geometry, mm (``nan``: not estimated, or
        none stands; ``inf``: the tubes do not meet); a bull-nose's pose-section bounds
        tightened only where they decide a cast (elsewhere the looser one-pose bound,
        :class:`~.cusp_estimates.LooseEstimates`).
    cast : ndarray of bool
        The seeds ray cast.
    height_mm : ndarray
        The cusp the ray cast found, mm (``nan``: not cast, or no other pass within the
        bracket; ``inf``: above the horizon).
    cusp_s : ndarray
        Where it is, ``s`` at the seed's ``t`` (``nan`` likewise).
    bracket_s : ndarray
        Where the ray cast's bracket ends, ``s`` (``nan``: not cast).
    clear_of_uncut : ndarray of bool
        Cusps found farther than a cutter diameter, along the surface, from any uncut
        sample of the coarse grid.
    uncut_fraction : float
        Area fraction of the surface left uncut (coarse grid).
    """

    t: NDArray[np.float64]
    s: NDArray[np.float64]
    pass_index: NDArray[np.int64]
    estimate_mm: NDArray[np.float64]
    cast: NDArray[np.bool_]
    height_mm: NDArray[np.float64]
    cusp_s: NDArray[np.float64]
    bracket_s: NDArray[np.float64]
    clear_of_uncut: NDArray[np.bool_]
    uncut_fraction: float


def seed_cusps(toolpath: Toolpath, surface: ParametricSurface, cutter: Cutter,
               scallop_mm: float, chord: ChordMeasurement, *,
               machine: Machine | None = None, chunk: int = 20_000,
               estimate: bool = True, estimate_min_seeds: int = ESTIMATE_MIN_SEEDS,
               estimate_top: int = ESTIMATE_TOP,
               estimate_top_share: float = ESTIMATE_TOP_SHARE,
               estimate_top_most: int = ESTIMATE_TOP_MOST) -> SeedCusps:
    """The cusp searched from each seed (module docstring), seed by seed.

    Parameters as :func:`measure_scallop`, which reports the largest of these cusps.
    """
    h = float(scallop_mm)
    rho = cutter.corner_radius_mm if cutter.corner_radius_mm > h else cutter.radius_mm
    width = 2.0 * np.sqrt(h * (2.0 * rho - h))
    volume = CutVolume(toolpath, cutter, cusp_horizon_mm(h), h, machine)
    uncut = UncutArea.on_grid(surface, volume, width, (chord.contact_t, chord.contact_s))
    seeds, others = SearchSeeds.of(surface, chord)
    search = CuspSearch(volume, surface, seeds, others, 3.0 * width, chunk)
    guess = np.full(len(seeds.t), np.nan)
    if estimate and len(seeds.t) > estimate_min_seeds:
        count = max(estimate_top, int(estimate_top_share * len(seeds.t)))
        tighten = None
        if volume.ball:
            guess = ball_cusp_estimates(volume, surface, seeds)
        else:  # (its loose bounds tightened where they decide: as though all were)
            loose = torus_cusp_bounds(volume, surface, seeds)
            guess, tighten = loose.mm, loose.tighten
        groups = [np.ones(len(seeds.t), dtype=bool)]
        away = uncut.away(seeds.q, seeds.t, seeds.s)
        if away is not None:
            groups.append(away)
        cast_beyond_estimates(search, guess, groups, count, max(count, estimate_top_most),
                              tighten=tighten, passes=seeds.pass_)
    else:
        search.run(np.ones(len(seeds.t), dtype=bool))
    found = ~np.isnan(search.height)
    clear = found.copy()
    away = uncut.away(surface(seeds.t[found], search.s[found]), seeds.t[found],
                      search.s[found]) if found.any() else None
    if away is not None:
        clear[found] = away
    return SeedCusps(seeds.t, seeds.s, seeds.pass_, guess, search.cast, search.height,
                     search.s, search.bracket_s, clear, uncut.fraction)


def cast_beyond_estimates(search: CuspSearch, guess: NDArray[np.float64],
                          groups: list[NDArray[np.bool_]], count: int, most: int, *,
                          tighten: Callable[..., int] | None = None,
                          passes: NDArray[np.int64] | None = None) -> None:
    """Ray cast where the estimates cannot decide the largest cusp of each group.

    ``guess``: every seed's cusp from the passes' own geometry
    (:func:`~.cusp_estimates.ball_cusp_estimates`,
    :func:`~.cusp_estimates.torus_cusp_estimates`; NaN where none stands); ``groups``:
    masks of the seeds whose largest cusp is reported (all, and away from uncut areas as
    the seeds stand). Cast: where the tubes do not meet (an infinite estimate), the
    ``count`` largest estimates of each group (twice as many while any estimate not cast
    reaches the largest cusp cast, up to ``most``), and wherever an estimate stands above
    the largest cusp the ray cast found by more than it errs (:data:`ESTIMATE_SHARE`):
    the largest of them first, ``most`` and then twice as many a round, the largest cusp
    found rising as they are cast (where the largest estimates read far above their cusps,
    the largest cusp cast after the first rounds lies among the estimates' bulk: on the
    DCA rotor's 5-axis ball job, scallop 0.005 mm, all at once from there would be 83,000
    of 151,000 seeds; round by round 2,700, the same largest cusp);
    where none stands, a sample of the seeds along each run of them (:func:`_run_samples`,
    :data:`SAMPLE_STRIDE`: ``passes``, each seed's pass, tells the runs apart; None: one
    pass), then those near a high cusp (:func:`_cast_near_high`). ``search`` holds the
    casts.

    ``tighten(at_least_mm, among=None)``: where some estimates are loose upper bounds
    (:class:`~.cusp_estimates.LooseEstimates`), tightens (in ``guess``) those at or above
    ``at_least_mm`` (of the mask ``among``) and says how many. Every choice here reads
    estimates only against a height (the ``count``-th largest of a group, the largest
    cusp, a share of it): the loose ones at or above it are tightened first (the ranks
    until no loose one reaches the ``count``-th largest, which only falls), and a loose
    one left below stands above its tight one, so below it too: the same seeds are cast
    as with every estimate tight.
    """
    def tight_from(at_least_mm: float, among: NDArray[np.bool_] | None = None) -> None:
        if tighten is not None:
            tighten(at_least_mm, among)

    def largest(group: NDArray[np.bool_], top: int) -> NDArray[np.bool_]:
        while tighten is not None and tighten(_nth_largest(guess, group, top), group):
            # (the ranks down to twice as far too: fewer rounds, each tightening many)
            tighten(_nth_largest(guess, group, 2 * top), group)
        return _largest_first(guess, group, top)

    unknown = np.isnan(guess)
    passes = np.zeros(len(guess), dtype=np.int64) if passes is None else passes
    first = np.isinf(guess) | _run_samples(unknown, passes, SAMPLE_STRIDE)
    for group in groups:
        first |= largest(group, count)
    search.run(first)
    for group in groups:
        top = count
        while top < most:  # the estimate ranks poorly here: cast more of the largest
            top_mm = _largest_cast(search, group)
            if top_mm is None:  # (the whole group is cast below)
                break
            tight_from(top_mm, group & ~search.cast)
            if not np.any(group & ~search.cast & (guess >= top_mm)):
                break  # (no seed left uncast whose estimate reaches what was found)
            top = min(2 * top, most)
            search.run(largest(group, top))
    for group in groups:
        size = most
        while True:
            top_mm = _largest_cast(search, group)
            if top_mm is None:
                search.run(group)
                break
            # an estimate above the largest cusp by more than it errs: cast it too, the
            # largest first (the largest cusp rises as they are cast)
            beyond = ESTIMATE_SHARE * top_mm
            tight_from(beyond, group & ~search.cast)
            left = group & ~search.cast & (guess >= beyond)
            if not left.any():
                break
            search.run(largest(left, size))
            size *= 2
    _cast_near_high(search, unknown, groups, SAMPLE_STRIDE, SAMPLE_NEAR_SHARE)


def _largest_cast(search: CuspSearch, group: NDArray[np.bool_]) -> float | None:
    """The largest finite cusp cast among ``group``, mm (None: none yet)."""
    measured = group & search.cast & np.isfinite(search.height)
    return float(search.height[measured].max()) if measured.any() else None


def _run_samples(rows: NDArray[np.bool_], pass_: NDArray[np.int64], stride: int
                 ) -> NDArray[np.bool_]:
    """Of each run of consecutive ``rows`` of one pass: its first, its last, every ``stride``-th."""
    at = np.flatnonzero(rows)
    out = np.zeros(len(rows), dtype=bool)
    if not at.size:
        return out
    starts = np.ones(at.size, dtype=bool)
    starts[1:] = (np.diff(at) > 1) | (pass_[at[1:]] != pass_[at[:-1]])
    first = np.flatnonzero(starts)
    within = np.arange(at.size) - first[np.cumsum(starts) - 1]
    ends = np.append(starts[1:], True)
    out[at[(within % stride == 0) | ends]] = True
    return out


def _cast_near_high(search: CuspSearch, unknown: NDArray[np.bool_],
                    groups: list[NDArray[np.bool_]], stride: int, share: float) -> None:
    """Ray cast the ``unknown`` seeds within ``stride`` seeds of a high cusp, until none is left.

    High: a cusp cast at or above ``share`` of the largest cusp cast in its group, or one
    above the horizon (:data:`SAMPLE_NEAR_SHARE`). (Only what was cast decides: the same
    seeds are cast whether loose estimates were tightened or not.)
    """
    while True:
        high = search.cast & np.isinf(search.height)
        for group in groups:
            top_mm = _largest_cast(search, group)
            if top_mm is None:
                high |= group & unknown  # (nothing measured: every seed)
                continue
            high |= group & search.cast & (search.height >= share * top_mm)
        # (a window of 2 stride + 1 seeds about each high one: the counts' running sum)
        total = np.concatenate([[0], np.cumsum(high)])
        rows = np.arange(len(high))
        near = total[np.minimum(rows + stride + 1, len(high))] > total[np.maximum(rows - stride, 0)]
        todo = near & unknown & ~search.cast
        if not todo.any():
            return
        search.run(todo)


def _nth_largest(estimate: NDArray[np.float64], group: NDArray[np.bool_], count: int) -> float:
    """The ``count``-th largest finite estimate of ``group`` (``-inf``: fewer)."""
    values = estimate[group & np.isfinite(estimate)]
    if values.size < count or count < 1:
        return -np.inf
    return float(np.partition(values, values.size - count)[values.size - count])


def _largest_first(estimate: NDArray[np.float64], group: NDArray[np.bool_], count: int
                   ) -> NDArray[np.bool_]:
    """The ``count`` seeds of ``group`` with the largest finite estimates.

    Ties at the ``count``-th largest go to the seeds first in order, so the choice depends
    only on the estimates at or above it: loose bounds left below it (never tightened,
    :func:`cast_beyond_estimates`) pick the same seeds as tight ones would.
    """
    rows = np.flatnonzero(group & np.isfinite(estimate))
    if rows.size > count:
        value = estimate[rows]
        least = _nth_largest(estimate, group, count)
        above = rows[value > least]
        rows = np.concatenate([above, rows[value == least][:count - above.size]])
    out = np.zeros(len(estimate), dtype=bool)
    out[rows] = True
    return out


def _scallop_result(cusps: SeedCusps) -> ScallopMeasurement:
    """The largest cusp found, overall and away from the uncut area."""
    n_cast = int(cusps.cast.sum())
    found = ~np.isnan(cusps.height_mm)
    if not found.any():
        return ScallopMeasurement(0.0, float("nan"), float("nan"), 0.0, cusps.uncut_fraction,
                                  len(cusps.t), n_cast)
    ch, ct, cs = cusps.height_mm[found], cusps.t[found], cusps.cusp_s[found]
    k = int(np.argmax(ch))
    interior = np.where(cusps.clear_of_uncut[found], ch, -np.inf)
    return ScallopMeasurement(max_mm=float(ch[k]), t=float(ct[k]), s=float(cs[k]),
                              interior_max_mm=max(float(interior.max()), 0.0),
                              uncut_fraction=cusps.uncut_fraction, n_samples=len(cusps.t),
                              n_cast=n_cast)
