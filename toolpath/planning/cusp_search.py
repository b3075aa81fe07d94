"""Cusps searched by ray casting into the cut volume from the chord measurement's seeds.

From a seed (a contact, or a mid-chord contact standing above the surface), at fixed
``t``, towards increasing ``s``, over 2.5 times the distance from the contact to the
nearest contact of another pass: the height ``h_own(s)`` left by the contact's own pass
rises from 0 and the height ``h_other(s)`` left by the other passes
(:meth:`~.cut_volume.CutVolume.height`) falls to 0 at the next pass; the cusp is where
they cross (a sign change found on 3 samples over the bracket, then closed by regula
falsi with the Illinois rule, :mod:`.roots`), its height ``min(h_own, h_other)``. A
contact with no pass within that bracket borders an uncut area and has no cusp.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from ..row_threads import query_workers
from ..surface import ParametricSurface, outward_normals
from ..tolerances import ROUND_OFF, TINY
from ..vectors import row_lengths
from .chord_measure import ChordMeasurement
from .cut_volume import CutVolume
from .roots import illinois_roots
from .sweep_kernel import segment_distances

__all__ = ["BRACKET_PAIRS_BATCH", "CUSP_BISECT_STEPS", "CUSP_HEIGHT_SHARE", "CUSP_SECANT_STEPS",
           "CUSP_S_SHARE", "FIRST_CHUNK", "KEPT_PAIRS_CHUNK", "CuspSearch", "SearchSeeds"]


class SearchSeeds(NamedTuple):
    """Where cusps are searched from: ``t, s``, pass, ``X_s``, surface point and normal."""

    t: NDArray[np.float64]
    s: NDArray[np.float64]
    pass_: NDArray[np.int64]
    x_s: NDArray[np.float64]
    q: NDArray[np.float64]
    n: NDArray[np.float64]
    rows: NDArray[np.int64]

    @classmethod
    def of(cls, surface: ParametricSurface, chord: ChordMeasurement
           ) -> tuple[SearchSeeds, _OtherPasses]:
        """The chord measurement's seeds short of ``s = 1`` (``rows`` among all of them).

        Their points, normals and ``X_s`` as the chord measurement carries them, else
        evaluated here.

        And the contacts of every seed (:class:`_OtherPasses`).
        """
        st, ss, sp = chord.seeds_t, chord.seeds_s, chord.seeds_pass
        if len(chord.seeds_q) == st.size:  # carried from the chord measurement
            seed_q, seed_n, x_s = chord.seeds_q, chord.seeds_n, chord.seeds_x_s
        elif st.size:
            # one evaluation of the three partials: points, normals and X_s
            parts = surface.partials_many(st, ss, ((0, 0), (1, 0), (0, 1)))
            seed_q, x_s = parts[0, 0], parts[0, 1]
            seed_n = outward_normals(surface, parts[1, 0], x_s)
        else:
            seed_q = seed_n = x_s = np.zeros((0, 3))
        others = _OtherPasses(seed_q, sp)
        live = np.flatnonzero(ss < 1.0 - ROUND_OFF)
        columns = (st, ss, sp, x_s, seed_q, seed_n)
        if live.size < st.size:  # (else the arrays as they are: no copies of every seed)
            # (``take`` gathers rows of (n, 3) arrays several times faster than indexing)
            columns = tuple(a.take(live, axis=0) for a in columns)
        return cls(*columns, live), others


class CuspSearch:
    """Cusps searched by ray casting from the seeds, each once (:func:`_cusps`).

    From a seed at ``s`` over 2.5 times the distance to the nearest contact of another
    pass (what the toolpath itself shows of the spacing; ``default_gap_mm`` where none),
    at most ``chunk`` seeds at a time (fewer where their brackets meet many pieces:
    :data:`KEPT_PAIRS_CHUNK`). :attr:`height` and :attr:`s` hold the cusps found (``nan``:
    none or not cast), :attr:`cast` the seeds cast, :attr:`bracket_s` where their
    brackets end.
    """

    def __init__(self, volume: CutVolume, surface: ParametricSurface, seeds: SearchSeeds,
                 others: _OtherPasses, default_gap_mm: float, chunk: int) -> None:
        self.volume, self.surface, self.seeds, self.others = volume, surface, seeds, others
        self.default_gap_mm, self.chunk = default_gap_mm, chunk
        m = len(seeds.t)
        self.height = np.full(m, np.nan)
        self.s = np.full(m, np.nan)
        self.cast = np.zeros(m, dtype=bool)
        self.bracket_s = np.full(m, np.nan)

    def run(self, rows: NDArray[np.bool_]) -> None:
        """Ray cast the seeds ``rows`` not cast yet."""
        seeds = self.seeds
        todo = np.flatnonzero(rows & ~self.cast)
        self.cast[todo] = True
        gap = self.others.distance(seeds.rows[todo])
        gap = np.where(np.isfinite(gap), gap, self.default_gap_mm)
        speed = row_lengths(seeds.x_s.take(todo, axis=0))
        s1 = np.minimum(seeds.s[todo] + 2.5 * gap / np.maximum(speed, TINY), 1.0)
        self.bracket_s[todo] = s1
        room = s1 > seeds.s[todo] + ROUND_OFF  # no room above (s in [0, 1]): no cusp
        # brackets of like length batched together: a batch meets the pieces within
        # reach of its longest bracket
        order = np.argsort(gap[room], kind="stable")
        todo, s1 = todo[room][order], s1[room][order]
        # as many seeds at a time as keep their pieces within KEPT_PAIRS_CHUNK (the last
        # batch's pieces per seed tell; the brackets only lengthen), at most ``chunk``
        least = min(self.chunk, FIRST_CHUNK)
        lo, size = 0, least
        while lo < todo.size:
            sl = todo[lo:lo + size]
            self.height[sl], self.s[sl], pairs = _cusps(
                self.volume, self.surface, seeds.t[sl], seeds.s[sl], s1[lo:lo + size],
                seeds.pass_[sl])
            lo += size
            size = int(np.clip(KEPT_PAIRS_CHUNK * sl.size / max(pairs, 1), least,
                               self.chunk))


def _cusps(volume: CutVolume, surface: ParametricSurface, t: NDArray[np.float64],
           s0: NDArray[np.float64], s1: NDArray[np.float64], own: NDArray[np.int64]
           ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
    """Cusp height and ``s`` between ``s0`` (a contact of pass ``own``) and ``s1``, fixed ``t``.

    ``nan`` where no other pass comes within the bracket; ``inf`` where the cusp is higher
    than the horizon. And how many (ray, piece) pairs the brackets met.
    """
    m = len(t)
    own_pieces, other_pieces = _bracket_pieces(volume, surface, t, s0, s1, own)
    pairs = own_pieces[2].size + other_pieces[2].size
    f = _HeightDifference(volume, surface, t, own_pieces, other_pieces)
    # at its own contact a pass leaves nothing and the others leave more: f(s0) < 0 (where
    # it does not read so, within the search's tolerance, another pass touches there too:
    # -horizon stands in)
    f_tol = CUSP_HEIGHT_SHARE * volume.scallop_mm
    f_lo = f(s0, np.arange(m))
    covered = f_lo >= -f_tol
    f_lo[covered] = -volume.horizon
    f.end_f[covered, 0], f.end_h[covered, 0] = np.inf, 0.0
    lo, f_lo, hi, f_hi = _sign_change(f, s0, s1, f_lo, steps=3)
    result_h = np.full(m, np.nan)
    result_s = np.full(m, np.nan)
    act = np.flatnonzero(~np.isnan(hi))
    if not act.size:
        return result_h, result_s, pairs
    # the crossing, from the side where the own pass stands lower (-f >= 0); the ends'
    # heights are the own pass's and the other's there, each below the crest between
    # them: the higher is the cusp
    s_low, s_high = illinois_roots(lambda sv, rows: -f(sv, act[rows]), lo[act], hi[act],
                                   -f_lo[act], -f_hi[act], secant_steps=CUSP_SECANT_STEPS,
                                   bisect_steps=CUSP_BISECT_STEPS,
                                   x_tol=CUSP_S_SHARE * (hi[act] - lo[act]),
                                   f_tol=f_tol, either_end=True)
    high = f.end_h[act, 1] > f.end_h[act, 0]
    result_h[act] = f.end_h[act, high.astype(np.int64)]
    result_s[act] = np.where(high, s_high, s_low)
    return result_h, result_s, pairs


#: Seeds are cast so many at a time that their brackets keep about this many (ray, piece)
#: pairs (the pieces a cast meets: :func:`_bracket_pieces`; about 130 MB of them), ...
KEPT_PAIRS_CHUNK = 16_000_000
#: ... and at least this many (the first batch's size, before any pairs are counted).
FIRST_CHUNK = 2_000


#: The bracket's candidate pieces are met and filtered this many (ray, piece) pairs at a
#: time (:func:`_bracket_pieces`): about 160 MB of them and their bounds at once.
BRACKET_PAIRS_BATCH = 4_000_000


#: Ray ``i`` meets the pieces ``item[lo[i]:hi[i]]`` (:func:`~.sweep_kernel.ray_ranges`):
#: ``(lo, hi, item)``.
_RayRanges = tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]


def _bracket_pieces(volume: CutVolume, surface: ParametricSurface, t: NDArray[np.float64],
                    s0: NDArray[np.float64], s1: NDArray[np.float64], own: NDArray[np.int64]
                    ) -> tuple[_RayRanges, _RayRanges]:
    """The pieces that can reach the rays over each bracket, of its own pass and the others.

    The pieces that matter have their centres on the sheet ``lift`` above the surface,
    within ``lateral`` of the bracket (a cutter whose centre came nearer the surface would
    cut into it: the plan's gouge checks keep every pose of the program off it, within
    the chord tolerance, and the cut volume moves the leads and links as the post emits
    them, :class:`~.cut_volume.CutVolume`); of those, the ones whose cutters come below the
    horizon somewhere over it (flat and bull-nose: a cheap bound first), within the
    cutter's reach of the bracket's chord on the surface (plus the chord's sag).

    Returns the ray ranges (:func:`~.sweep_kernel.ray_ranges`) of the seed's own pass and
    of the others.
    """
    m = len(t)
    mid, mid_n = surface.points_and_normals(t, 0.5 * (s0 + s1))
    p0, p1 = surface(t, s0), surface(t, s1)
    half = 0.5 * row_lengths(p1 - p0)
    sag = row_lengths(0.5 * (p0 + p1) - mid)
    # the candidates a run of rays at a time (a dense toolpath's would fill memory: 286
    # million for 20,000 rays on a 5-axis flat:6 job on the bundled propeller), filtered,
    # and the pieces kept per ray, each ray's own pass's apart (the rays in order: their
    # pieces are runs, ray_ranges' without the owners held)
    counts = np.zeros((2, m), dtype=np.int64)
    items: tuple[list[NDArray[np.int64]], ...] = ([], [])
    for owner, item in volume.pair_batches(mid + volume.lift * mid_n, volume.lateral + float(
            half.max()) if m else 0.0, BRACKET_PAIRS_BATCH):
        if not volume.ball:
            near = volume.floor_over(mid, half + sag, owner, item) <= volume.horizon
            owner, item = owner[near], item[near]
        dist = segment_distances(p0, p1, owner, volume.piece_a, volume.piece_b, item)
        near = dist <= volume.segment_reach + 2.0 * sag[owner]
        owner, item = owner[near], item[near]
        other = (volume.pass_of[item] != own[owner]).astype(np.int64)
        for side in range(2):
            kept = other == side
            items[side].append(item[kept])
            counts[side] += np.bincount(owner[kept], minlength=m)
    starts = np.zeros((2, m + 1), dtype=np.int64)
    np.cumsum(counts, axis=1, out=starts[:, 1:])
    return tuple((starts[side, :-1], starts[side, 1:], np.concatenate(
        [np.zeros(0, dtype=np.int64), *items[side]])) for side in range(2))


class _HeightDifference:
    """``f(s) = h_own(s) - h_other(s)`` (clipped) along each seed's line of fixed ``t``.

    ``h_own`` is the height the seed's own pass leaves, ``h_other`` the other passes'
    (:meth:`CutVolume.height` over the pieces of :func:`_bracket_pieces`). Each call
    keeps, at the end of the bracket on its side (column 0: ``f <= 0``, 1: ``f > 0``),
    ``|f|`` in :attr:`end_f` and ``min(h_own, h_other)`` in :attr:`end_h`.
    """

    def __init__(self, volume: CutVolume, surface: ParametricSurface, t: NDArray[np.float64],
                 own: _RayRanges, other: _RayRanges) -> None:
        self.volume, self.surface, self.t = volume, surface, t
        self.own, self.other = own, other
        self.clip = 10.0 * volume.horizon + 1.0
        self.end_f = np.full((len(t), 2), np.inf)
        self.end_h = np.zeros((len(t), 2))

    def __call__(self, sv: NDArray[np.float64], active: NDArray[np.int64]
                 ) -> NDArray[np.float64]:
        """``f`` at ``sv`` for seeds ``active``."""
        x, nrm = self.surface.points_and_normals(self.t[active], sv)
        lo, hi, item = self.own
        h_own = self.volume.height(x, nrm, lo[active], hi[active], item)
        lo, hi, item = self.other
        h_other = self.volume.height(x, nrm, lo[active], hi[active], item)
        value = np.minimum(h_own, self.clip) - np.minimum(h_other, self.clip)
        side = (value > 0.0).astype(np.int64)
        self.end_f[active, side] = np.abs(value)
        self.end_h[active, side] = np.minimum(h_own, h_other)
        return value


def _sign_change(f: _HeightDifference, s0: NDArray[np.float64], s1: NDArray[np.float64],
                 f_lo: NDArray[np.float64], steps: int
                 ) -> tuple[NDArray[np.float64], ...]:
    """The first of ``steps`` even samples over ``(s0, s1]`` where ``f > 0``, per seed.

    Returns ``lo, f_lo`` (the last sample with ``f <= 0``, from ``s0`` and ``f_lo``
    there) and ``hi, f_hi`` (the first with ``f > 0``; ``nan``: none).
    """
    m = len(s0)
    lo, f_lo = s0.copy(), f_lo.copy()
    hi = np.full(m, np.nan)
    f_hi = np.full(m, np.nan)
    for j in range(1, steps + 1):
        sj = s0 + (s1 - s0) * j / steps
        open_ = np.flatnonzero(np.isnan(hi))
        if not open_.size:
            break
        fj = f(sj[open_], open_)
        found = fj > 0.0
        hi[open_[found]], f_hi[open_[found]] = sj[open_[found]], fj[found]
        lo[open_[~found]], f_lo[open_[~found]] = sj[open_[~found]], fj[~found]
    return lo, f_lo, hi, f_hi


#: The cusp search (:func:`_cusps`) stops where the two heights are within this share of
#: the requested scallop at an end of its bracket (the cusp's height then within about
#: half of it), ...
CUSP_HEIGHT_SHARE = 3e-3

#: ... or the bracket within this share of its first width (in ``s``) ...
CUSP_S_SHARE = 2.0 ** -24

#: ... after at most these regula falsi steps and then bisections
#: (:func:`~.roots.illinois_roots`).
CUSP_SECANT_STEPS = 8
CUSP_BISECT_STEPS = 16


#: Contacts asked of the k-d tree first for the nearest contact of another pass: along a
#: pass the contacts lie a chord apart, several stepovers, so few of the nearest are the
#: contact's own (8 held one of another pass for 1058 of the 1074 contacts cast on the
#: dev blade's 3-axis ball job, 16 for all: a cheaper first query, the rest asked again);
FIRST_NEIGHBOURS = 8

#: ... and at most (a contact with none of another pass among them has none near).
MOST_NEIGHBOURS = 1024


class _OtherPasses:
    """Distance from contacts to the nearest contact of another pass (a k-d tree of all)."""

    def __init__(self, points: NDArray[np.float64], passes: NDArray[np.int64]) -> None:
        self.points, self.passes = points, passes
        # unbalanced, uncompacted: the same neighbours, built in half the time (most
        # seeds are never queried)
        self.tree = (cKDTree(points, balanced_tree=False, compact_nodes=False)
                     if len(points) else None)

    def distance(self, rows: NDArray[np.int64]) -> NDArray[np.float64]:
        """For contacts ``rows``: the distance, mm (inf if none).

        The nearest :data:`FIRST_NEIGHBOURS` contacts asked first, four times as many for
        those with none of another pass among them, up to :data:`MOST_NEIGHBOURS`: the
        first of another pass in distance order is the nearest, whichever round finds it.
        """
        out = np.full(len(rows), np.inf)
        if self.tree is None:
            return out
        n = len(self.points)
        todo = np.arange(len(rows))
        k = FIRST_NEIGHBOURS
        while todo.size:
            dist, idx = self.tree.query(self.points[rows[todo]], k=min(k, n),
                                        workers=query_workers(todo.size))
            dist, idx = dist.reshape(len(todo), -1), idx.reshape(len(todo), -1)
            other = self.passes[np.minimum(idx, n - 1)] != self.passes[rows[todo]][:, None]
            other &= np.isfinite(dist)
            found = other.any(axis=1)
            first = np.argmax(other, axis=1)
            out[todo[found]] = dist[found, first[found]]
            todo = todo[~found]
            if k >= min(n, MOST_NEIGHBOURS):
                break
            k = min(4 * k, MOST_NEIGHBOURS)
        return out
