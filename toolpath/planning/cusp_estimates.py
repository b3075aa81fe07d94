"""Each seed's cusp estimated from the passes' own geometry, without ray casting.

A ball's from the two tubes round its centre's segments (:func:`ball_cusp_estimates`); a
flat or bull-nose cutter's from the two passes' sections in the plane of the seed's line of
``t`` (:func:`torus_cusp_estimates`; where no prism along a pass holds, a bound from one pose
of each pass). The scallop measurement ray casts where the estimate cannot decide
(:mod:`.measure`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from ..row_threads import query_workers
from ..surface import ParametricSurface
from ..tolerances import LENGTH_SLACK_MM, TINY
from ..vectors import move_axes, row_lengths, unit
from .cusp_kernel import (
    RIDGE_FOUND,
    RIDGE_NO_PASS,
    RIDGE_OPEN,
    next_pieces,
    path_curving,
    ridges,
)
from .cusp_search import SearchSeeds
from .cut_volume import CutVolume
from .cutters import radial_directions
from .torus_kernel import window_nearest
from .torus_profile import pose_section_ridges, profile_ridges

__all__ = ["AXIS_WAY_COSINE", "BEND_AWAY", "BEND_AWAY_CAP", "BEND_AWAY_GROWTH",
           "BEND_AWAY_SHARE", "CARRY_PIECES", "CARRY_TURN", "CONTACT_ALONG_SHARE",
           "CONTACT_WALKS", "CONTACT_WINDOW", "DEEP_FLAT_SHARE", "GENTLE_CURVING",
           "PIVOT_TURN", "POSE_FRACTIONS", "POSE_PIECES", "RIDGE_SINK_SHARE",
           "TIGHT_SINK_SHARE", "LooseEstimates", "ball_cusp_estimates", "torus_cusp_bounds",
           "torus_cusp_estimates"]


#: Share of how deep the ridge lies inside other tubes by which it sinks: where one side's
#: lower envelope drops by ``delta`` (the passes' own curving, a pass folding back, a
#: third pass), its crossing with the other side's, whose slopes across are about
#: opposite (``+-d / R``), drops by about half of it.
RIDGE_SINK_SHARE = 0.5

#: ... only where both passes' centres curve gently near the ridge, ``kappa R`` below this
#: (``kappa`` their curvature over ``R / 2`` either way at the ridge's two pieces, the
#: tighter side; ``R`` the ball's): on the R150 dome ``kappa R`` is 0.02 to 0.07, on the
#: R50 cap's parallels up to 0.3; round the dev blade's 0.2 mm leading edge up to 1 (the
#: centres' circle barely wider than the tube), at a link turning at a pass's end more.
#: There a straight piece's tube stands far off the pass's and sunk by half the ridge
#: read down to -1 times the ray cast (standing dev blade, 5-axis, ball 6); below 0.3
#: (and no deeper than the ridge's height, :func:`ball_cusp_estimates`) the half reads
#: 0.87 to 1.0 times it where the ray cast finds a cusp above half the largest (0.92 and
#: up but on the lying dev blade at scallop 0.005 mm; dev blade, propeller, blunt rotor,
#: R50 cap, R150 dome, elliptic blade; 3 and 5 axes; ball 3 and 6; scallop 0.005 to
#: 0.05 mm).
GENTLE_CURVING = 0.3

#: Where they curve more tightly the ridge sinks by this share of that depth: there the
#: ray cast stood 0.13 to 0.3 of it below the ridge (the 5th percentile to the median,
#: ``kappa R`` 0.7 to 1.5, cusps above half the largest), and half of it read down to
#: 0.3 times the ray cast; unsunk, the ridges of the propeller's edge read up to 1.3
#: times it and crowded the largest cusp out of the largest estimates (its ray cast
#: skipped, the measured largest cusp 2 % low).
TIGHT_SINK_SHARE = 0.15

#: Where the ridge lies deeper in those tubes than it stands high, the cusp is taken as
#: this share of the flat cusp (:func:`ball_cusp_estimates`): the ray cast read 0 to 1.04
#: times the flat cusp there (nearly 0 where the passes' curving cuts the ridge away: a
#: third of those on the elliptic blade, whose flat cusps stand 1.05 times its largest
#: cusp; taken whole they rank above the true largest cusps and all seeds are cast).
DEEP_FLAT_SHARE = 0.95


def ball_cusp_estimates(volume: CutVolume, surface: ParametricSurface, seeds: SearchSeeds
                        ) -> NDArray[np.float64]:
    """Cusp height from each seed towards increasing ``s``, from two centre segments (ball).

    A ball sweeps the tubes of radius ``R`` round its centre's segments. Near the seed,
    ``P = Q + R n`` with ``Q`` its surface point, take the nearest segment of its own pass
    and the nearest of another pass on the ``+s`` side (``(C - P) . X_s > 0``), their points
    ``C1`` and ``C2`` nearest to ``P``, among the pieces whose midpoints lie within
    ``near_mm`` of ``P`` (:data:`~.cut_volume.NEAR_WIDTHS`; where no other pass lies there, within 4
    times that, and so on up to ``2 R`` and a piece's length: beyond, the tubes are apart).
    Across the own segment (direction ``u``) the two tubes are circles ``2 d`` apart (``d``
    half the across part ``D`` of ``C2 - C1``), meeting at
    ``X = C1 + D / 2 - sqrt(R^2 - d^2) v`` (``v`` across ``u`` and ``D``, pointing away
    from the surface): the bottom of the cusp's ridge
    (:func:`~.cusp_kernel.ridges`). Its height ``H`` is ``(X - X(t, s_c)) . n(t, s_c)`` over
    the surface point one first-order step from the seed,
    ``s_c = s + (X - Q) . X_s / |X_s|^2``. ``X`` lies ``delta`` deep in a nearby tube of a
    third pass (passes closing up, links) or of the two passes' other pieces (their
    curving, a fold):

    * where ``delta <= H``, the cusp is ``H`` less :data:`RIDGE_SINK_SHARE` of ``delta``
      where both passes curve gently at the two segments (:data:`GENTLE_CURVING`), less
      :data:`TIGHT_SINK_SHARE` of it where they curve tightly (the half is no measure
      there; the straight tubes remove less than the passes: ``H`` is at or above the
      cusp, where the ray cast decides as it stands high);
    * where ``delta > H`` (round a tight leading edge, where the passes' curving cuts
      deeper than the straight tubes' ridge stands), the material under ``X`` is cut and
      the ridge stands elsewhere, about as high as the two tubes' meeting over a plane
      ``R`` below their centres, ``R - sqrt(R^2 - d^2)`` (the flat cusp), or lower: the
      cusp is ``H`` or :data:`DEEP_FLAT_SHARE` of the flat cusp, the lower.

    Returns NaN where no other pass lies on that side within that reach, a segment has
    no length or is a pass's first or last (``X`` may lie on the tube's end cap: the ray
    cast decides there), ``inf`` where the tubes do not meet (``d >= R``: material
    between the passes).
    """
    n_seed = len(seeds.t)
    out = np.full(n_seed, np.nan)
    if not n_seed or not len(volume.pass_of):
        return out
    x, inside, state, pieces = _ridges_widening(volume, seeds)
    out[state == RIDGE_OPEN] = np.inf
    ok = np.flatnonzero(state == RIDGE_FOUND)
    own, other = pieces[ok, 0], pieces[ok, 1]
    height = _ridge_heights(surface, seeds, ok, x[ok])
    depth = np.maximum(inside[ok, 0], inside[ok, 1])  # (max(axis=1) over 2: ten times slower)
    big = volume.cutter.radius_mm
    curving = _piece_curving(volume, np.concatenate([own, other])).reshape(2, -1).max(axis=0)
    share = np.where(curving * big < GENTLE_CURVING, RIDGE_SINK_SHARE, TIGHT_SINK_SHARE)
    estimate = height - share * depth
    deep = np.flatnonzero(depth > height)
    flat = _flat_cusps(volume, seeds.q[ok[deep]] + big * seeds.n[ok[deep]], own[deep],
                       other[deep])
    estimate[deep] = np.minimum(height[deep], DEEP_FLAT_SHARE * flat)
    out[ok] = estimate
    out[ok[_ends_pass(volume, own) | _ends_pass(volume, other)]] = np.nan
    return out


def _flat_cusps(volume: CutVolume, centre: NDArray[np.float64], own: NDArray[np.int64],
                other: NDArray[np.int64]) -> NDArray[np.float64]:
    """``R - sqrt(R^2 - d^2)``: where tubes round pieces ``own`` and ``other`` meet over a plane.

    ``d`` half the across part (across ``own``) of ``C2 - C1``, the pieces' points nearest
    to ``centre`` (:func:`ball_cusp_estimates`), mm.
    """
    e = volume.piece_vectors
    near_own, _ = _foot_on(volume.a[own], e[own], centre)
    near_other, _ = _foot_on(volume.a[other], e[other], centre)
    u = unit(e[own])
    apart = near_other - near_own
    apart -= np.einsum("ij,ij->i", apart, u)[:, None] * u
    big = volume.cutter.radius_mm
    half_sq = np.minimum(0.25 * np.einsum("ij,ij->i", apart, apart), big * big)
    return big - np.sqrt(big * big - half_sq)


def _ends_pass(volume: CutVolume, piece: NDArray[np.int64]) -> NDArray[np.bool_]:
    """Whether each piece is its pass's first or last (a pass's pieces run on in order)."""
    pass_of = volume.pass_of
    before = pass_of[np.maximum(piece - 1, 0)]
    after = pass_of[np.minimum(piece + 1, len(pass_of) - 1)]
    return ((piece == 0) | (piece == len(pass_of) - 1) | (before != pass_of[piece])
            | (after != pass_of[piece]))


def _piece_curving(volume: CutVolume, piece: NDArray[np.int64]) -> NDArray[np.float64]:
    """Mean curvature of the centre path within ``R / 2`` of pieces, 1/mm.

    From each piece to its pass's pieces ``R / 2`` before and after: the turn over the
    length between their midpoints, the tighter side (a link turning at a pass's end, a
    tight edge). (A straight move's pieces run on in line and the turn between two moves
    lies at their joint: one piece's neighbours would read no turn or all of it.)
    Compiled, piece by piece (:func:`~.cusp_kernel.path_curving`).
    """
    return path_curving(piece, volume.piece_vectors, volume.pass_of, volume.cutter.radius_mm,
                        TINY)


def _ridge_heights(surface: ParametricSurface, seeds: SearchSeeds, rows: NDArray[np.int64],
                   x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Height of ridge points ``x`` over the surface near seeds ``rows``, mm.

    ``(X - X(t, s_c)) . n(t, s_c)`` over the surface point one first-order step from the
    seed, ``s_c = s + (X - Q) . X_s / |X_s|^2``.
    """
    xs = seeds.x_s.take(rows, axis=0)
    s_c = np.clip(seeds.s[rows] + np.einsum("ij,ij->i", x - seeds.q.take(rows, axis=0), xs)
                  / np.maximum(np.einsum("ij,ij->i", xs, xs), TINY), 0.0, 1.0)
    foot_c, n_c = surface.points_and_normals(seeds.t[rows], s_c)
    return np.einsum("ij,ij->i", x - foot_c, n_c)


class LooseEstimates:
    """Seeds' estimates some of which are upper bounds that tighten on demand.

    ``mm``: each seed's estimate (as :func:`torus_cusp_estimates`), where ``loose`` an
    upper bound on the tight one (no lower than it): :meth:`tighten` replaces those at or
    above a height by the tight ones, in place. What the estimates decide
    (:func:`~.measure.cast_beyond_estimates`: the largest, those at or above a share of
    the largest cusp) then reads as with every estimate tight, wherever every loose one
    left stands below the height asked: a tight one stands no higher.
    """

    def __init__(self, mm: NDArray[np.float64], loose: NDArray[np.bool_],
                 tight: Callable[[NDArray[np.int64]], NDArray[np.float64]] | None) -> None:
        self.mm, self.loose, self._tight = mm, loose, tight

    def tighten(self, at_least_mm: float, among: NDArray[np.bool_] | None = None) -> int:
        """Tighten the loose estimates at or above ``at_least_mm`` (of ``among``); how many."""
        todo = self.loose & (self.mm >= at_least_mm)
        if among is not None:
            todo &= among
        rows = np.flatnonzero(todo)
        if rows.size and self._tight is not None:
            self.mm[rows] = self._tight(rows)
        self.loose[rows] = False
        return int(rows.size)

    def tightened(self) -> NDArray[np.float64]:
        """Every estimate tight."""
        self.tighten(-np.inf)
        return self.mm


def torus_cusp_estimates(volume: CutVolume, surface: ParametricSurface, seeds: SearchSeeds
                         ) -> NDArray[np.float64]:
    """Cusp height from each seed towards increasing ``s``, flat or bull-nose cutter, tight.

    :func:`torus_cusp_bounds` with every estimate tightened.
    """
    return torus_cusp_bounds(volume, surface, seeds).tightened()


def torus_cusp_bounds(volume: CutVolume, surface: ParametricSurface, seeds: SearchSeeds
                      ) -> LooseEstimates:
    """Cusp height from each seed towards increasing ``s`` for a flat or bull-nose cutter.

    The piece of the seed's own pass whose ring centre lies nearest the own ring centre
    as the own pass's nearest piece's axis puts it (one k-d tree a pass: the own pass's
    pieces alone are met, however many other passes' crowd round a tight edge; its
    segment within ``2 R`` and a piece's length of it) and the next pass's: that of the
    nearest seed of another pass on the ``+s`` side (the contacts, not the ring centres,
    show which pass is next: round a leading edge a zigzag's lead tilts neighbouring
    passes' axes far apart; where there is none, the piece of another pass nearest the
    own one on that side, :func:`~.cusp_kernel.next_pieces`, within
    :attr:`CutVolume.near_mm`, where none within 4 times that, and so on), the
    poses of their passes that touch nearest the seed's contact (:func:`_contact_poses`),
    and the two passes'
    sections in the plane of the seed's line of ``t`` through its contact (normal
    ``X_s x n``: where the ray cast meets the ridge), each pass's prism along the way its
    cutter's point at the contact moves (:func:`_contact_way`;
    :func:`~.torus_profile.profile_ridges`: the ring's ellipse widened by ``r``, seen
    aslant where a way crosses the plane aslant, as at a move joint): where they meet is
    the bottom of the ridge ``X``, its height over the surface as for the ball
    (:func:`_ridge_heights`).

    No prism holds where no next pass lies within that reach, the own piece has no length,
    a pass's cutter turns round its contact (:data:`PIVOT_TURN`), a pass runs across that
    plane more steeply than :data:`~.torus_profile.LEAST_WAY_COSINE`, the sections do
    not meet nearest the surface, a pass ends or turns before the pose whose cutter leaves
    the ridge (:func:`_runs_on`) or runs along its cutter's axis (:data:`AXIS_WAY_COSINE`):
    there, where both contact poses were found facing the seed's surface, the ridge
    between those two poses' own sections bounds the cusp (:func:`_pose_section_bounds`;
    bull-noses); elsewhere it returns NaN: the ray cast decides. The pose-section bounds
    come loose, from the two contact poses alone, and tighten with their pieces' poses on
    demand (:class:`LooseEstimates`).
    """
    n_seed = len(seeds.t)
    out = np.full(n_seed, np.nan)
    none_loose = np.zeros(n_seed, dtype=bool)
    if not n_seed or not len(volume.pass_of):
        return LooseEstimates(out, none_loose, None)
    cutter = volume.cutter
    big, r = cutter.radius_mm, cutter.corner_radius_mm
    a, e = volume.piece_a, volume.piece_b - volume.piece_a
    corner = seeds.q + r * seeds.n
    # the own ring centre as the axis of the own pass's piece whose ring centre is nearest
    # puts it (round a leading edge another pass's nearest pose stands tilted far off)
    middle = a + 0.5 * e
    near = _nearest_in_pass(middle, volume.pass_of, corner, seeds.pass_)
    near = np.maximum(near, 0)
    inward, _ = radial_directions(seeds.n, unit(volume.axes0[near] + volume.axes1[near]))
    target = corner + (big - r) * inward
    found = np.full((n_seed, 2), -1, dtype=np.int64)
    # the own pass's piece whose ring centre is nearest that (its contact pose is sought
    # about it: _contact_poses), where its segment lies within reach of it
    own = _nearest_in_pass(middle, volume.pass_of, target, seeds.pass_)
    foot, _ = _foot_on(a[np.maximum(own, 0)], e[np.maximum(own, 0)], target)
    close = (own >= 0) & (row_lengths(foot - target) <= _widest_reach(volume))
    found[close, 0] = own[close]
    # the next pass as the contacts show it: the pass of the nearest contact of another
    # pass on the +s side, at its own piece (the ring centres' nearest can skip a pass
    # round a leading edge, where a zigzag's lead tilts the two ways' axes far apart)
    beside = _nearest_of(cKDTree(seeds.q), seeds.pass_, seeds.q, seeds.pass_,
                         towards=seeds.x_s)
    known = (beside >= 0) & (found[np.maximum(beside, 0), 0] >= 0)
    found[known, 1] = found[beside[known], 0]

    def search(todo: NDArray[np.int64], apart_mm: float) -> NDArray[np.bool_]:
        found[todo, 1] = next_pieces(foot[todo], seeds.x_s[todo], seeds.pass_[todo],
                                     volume.near_cells, apart_mm, a, e, volume.pass_of)
        return found[todo, 1] < 0

    # elsewhere the next pass's piece nearest the own one's foot, on the +s side
    _widening(volume, np.flatnonzero(close & ~known), search)
    ok = np.flatnonzero((found >= 0).all(axis=1))
    own_c, own_axis, j_own, own_ok = _contact_poses(volume, found[ok, 0], corner[ok],
                                                    seeds.n[ok])
    next_c, next_axis, j_next, next_ok = _contact_poses(volume, found[ok, 1], corner[ok],
                                                        seeds.n[ok])
    live = own_ok & next_ok & (np.einsum("ij,ij->i", e[j_own], e[j_own]) > TINY)
    n = seeds.n[ok]
    own_way, own_turn = _contact_way(volume, n, j_own)
    next_way, next_turn = _contact_way(volume, n, j_next)
    # a cutter turning round its contact sweeps no prism: the ray cast decides there
    gap = np.where(beside[ok] >= 0, np.linalg.norm(seeds.q[np.maximum(beside[ok], 0)]
                                                   - seeds.q[ok], axis=1),
                   np.linalg.norm(next_c - own_c, axis=1))
    live &= np.maximum(own_turn, next_turn) * gap < PIVOT_TURN
    # a pose found on the far side of a thin edge (its axis swung round, facing into the
    # seed's surface: a = -n there) agrees with itself and reads low (0.71 of the ray cast
    # on the standing dev blade, 5-axis flat:6; its contact stood 1.9 mm off the seed's,
    # against a few um elsewhere): both poses must face the seed's surface
    facing = (np.einsum("ij,ij->i", own_axis, n) > 0.0) & (
        np.einsum("ij,ij->i", next_axis, n) > 0.0)
    live &= facing
    # (both poses found and facing the seed's surface: their sections bound the ridge)
    posed = own_ok & next_ok & facing
    poses = (ok[posed], own_c[posed], next_c[posed], own_axis[posed], next_axis[posed],
             j_own[posed], j_next[posed])
    ok, own_way, next_way = ok[live], own_way[live], next_way[live]
    own_c, own_axis, next_c, next_axis = own_c[live], own_axis[live], next_c[live], next_axis[live]
    # the sections in the plane of the seed's line of t (where the ray cast meets the
    # ridge), each pass's prism along the way the cutter's point at the contact moves
    n = seeds.n[ok]
    across = unit(np.cross(seeds.x_s[ok], n))
    ridge = profile_ridges(own_c, next_c, own_axis, next_axis, own_way, next_way, n,
                           through=seeds.q[ok], across=across, radius_mm=big,
                           corner_radius_mm=r, flute_length_mm=cutter.flute_length_mm)
    # each prism holds only where its pass runs on, straight, to the pose that leaves the
    # ridge, and does not run along its cutter's axis (AXIS_WAY_COSINE)
    met = ridge.found & _runs_on(volume, j_own[live], own_c, own_axis, ridge.own_way,
                                 ridge.own_normal, ridge.point, across)
    met &= _runs_on(volume, j_next[live], next_c, next_axis, ridge.next_way, ridge.next_normal,
                    ridge.point, across)
    met &= np.abs(np.einsum("ij,ij->i", own_way, own_axis)) <= AXIS_WAY_COSINE
    met &= np.abs(np.einsum("ij,ij->i", next_way, next_axis)) <= AXIS_WAY_COSINE
    x = ridge.point
    # a pass bending away from the surface sweeps less than its prism: margin the ridge
    # by a share growing with the bend, and cast where it bends more tightly
    bend = big * np.maximum(_bend_away(volume, j_own[live], n),
                            _bend_away(volume, j_next[live], n))
    met &= bend <= BEND_AWAY_CAP
    share = np.where(bend > BEND_AWAY, 1.0 + BEND_AWAY_SHARE + BEND_AWAY_GROWTH * bend, 1.0)
    out[ok[met]] = share[met] * _ridge_heights(surface, seeds, ok[met], x[met])
    loose = _pose_section_bounds(volume, surface, seeds, out, poses)
    if loose is None:
        return LooseEstimates(out, none_loose, None)
    return LooseEstimates(out, *loose)


def _pose_section_bounds(volume: CutVolume, surface: ParametricSurface, seeds: SearchSeeds,
                         out: NDArray[np.float64], poses: tuple[NDArray[np.float64], ...]
                         ) -> tuple[NDArray[np.bool_],
                                    Callable[[NDArray[np.int64]], NDArray[np.float64]]] | None:
    """Fill ``out`` where no prism held from the two contact poses' sections (in place).

    ``poses``: the rows whose own and next contact poses were found facing the seed's
    surface, and those poses' ring centres and axes (:func:`torus_cusp_bounds`). Where
    ``out`` is NaN there (a cutter turning round its contact, a pass ending, bending away,
    running along its axis), the ridge between the two poses' own sections
    (:func:`~.torus_profile.pose_section_ridges`: each pose lies inside what its pass
    removes) over the surface as for the prisms' (:func:`_ridge_heights`): a loose bound.
    Tight: the lower of it and the bound with the poses of the two contact poses' pieces
    and their neighbours (:func:`_piece_poses`) joining each side: every pose of a piece
    lies inside what the toolpath removes, so their sections only lower the bound (at the
    median, of the ray cast: bull:8:1 1.29 -> 1.13, bull:10:2 1.16 -> 1.05 on the
    standing blade, test_planning_measure_pose_sections). Each of the two is a bound of
    the ridge's height (:func:`~.torus_profile.pose_section_ridges`), so the lower is
    too, and the tight one stands no higher than the loose. The several poses' bound costs
    about 60 times the one pose's (17 poses a side, each grid interval bounded): on the
    user's 5-axis bull job (trunnion-ac, bull:8:1, lead 10 degrees, scallop 0.005 mm) the
    one pose's bounds of 17,418 of the 48,339 seeds bounded so stood above
    ESTIMATE_SHARE times the largest cusp (with every bound tight, 2,630 estimates of all
    221,178), so the loose bounds are tightened only where they decide anything
    (:class:`LooseEstimates`; 17,795 tightened there). Rows whose one-pose crossing was
    not found (or lies beyond the surface's edge) are tightened at once.
    A flat cutter gets none (:func:`~.torus_profile.pose_section_ridges`). The bound is of
    the ridge's height over the surface, whose section in the plane bends by the normal
    curvature along the line of ``t``, ``X_ss . n / |X_s|^2`` (``bend_per_mm``).

    Returns the seeds whose estimates are loose and the tightening (seed rows -> their
    tight estimates), None where none was bounded.
    """
    rows, own_c, next_c, own_axis, next_axis, j_own, j_next = poses
    todo = np.flatnonzero(np.isnan(out[rows]))
    if not todo.size or volume.cutter.corner_radius_mm <= 0.0:
        return None
    rows = rows[todo]
    n, q = seeds.n[rows], seeds.q[rows]
    across = unit(np.cross(seeds.x_s[rows], n))
    cutter = volume.cutter
    ring = cutter.radius_mm - cutter.corner_radius_mm
    # the next contact: its ring centre less the ring's way across its axis
    w_next, _ = radial_directions(n, next_axis[todo])
    w_own, _ = radial_directions(n, own_axis[todo])
    contact_next = next_c[todo] - ring * w_next - q
    contact_own = own_c[todo] - ring * w_own - q
    apart = contact_next - contact_own
    reach = np.linalg.norm(apart - np.einsum("ij,ij->i", apart, across)[:, None] * across,
                           axis=1)
    # the surface's normal curvature along the line of t: its section in the plane
    x_s = seeds.x_s[rows]
    x_ss = surface.partials_many(seeds.t[rows], seeds.s[rows], ((0, 2),))[(0, 2)]
    speed_sq = np.maximum(np.einsum("ij,ij->i", x_s, x_s), TINY)
    bend = np.einsum("ij,ij->i", x_ss, n) / speed_sq
    # and how far across the surface runs, as _ridge_heights reads s from x
    within = (1.0 - seeds.s[rows]) * np.sqrt(speed_sq)
    own_c, next_c = own_c[todo], next_c[todo]
    own_axis, next_axis = own_axis[todo], next_axis[todo]
    j_own, j_next = j_own[todo], j_next[todo]

    def bounds(at: NDArray[np.int64], several: bool
               ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
        more = ((*_piece_poses(volume, j_own[at]), *_piece_poses(volume, j_next[at]))
                if several else None)
        return pose_section_ridges(own_c[at], next_c[at], own_axis[at], next_axis[at], n[at],
                                   x_s[at], through=q[at], bend_per_mm=bend[at],
                                   within_mm=within[at], across=across[at],
                                   reach_mm=reach[at], radius_mm=cutter.radius_mm,
                                   corner_radius_mm=cutter.corner_radius_mm,
                                   more_poses=more)

    def tight(seed_rows: NDArray[np.int64]) -> NDArray[np.float64]:
        at = local[seed_rows]
        value = out[seed_rows].copy()  # (the loose bound; NaN where none)
        point, found = bounds(at, True)
        value[found] = np.fmin(value[found],
                               _ridge_heights(surface, seeds, seed_rows[found], point[found]))
        return value

    local = np.full(len(out), -1, dtype=np.int64)
    local[rows] = np.arange(len(rows))
    point, found = bounds(np.arange(len(rows)), False)
    out[rows[found]] = _ridge_heights(surface, seeds, rows[found], point[found])
    out[rows[~found]] = tight(rows[~found])  # (no one-pose bound: tight at once)
    loose = np.zeros(len(out), dtype=bool)
    loose[rows[found]] = True
    return loose, tight


#: The pieces whose poses join a contact pose's section in the bound
#: (:func:`_pose_section_bounds`): its own and this many either side (every pose lies
#: inside what the toolpath removes: more only lower the bound). On the user's 5-axis job's
#: kind (standing dev blade, trunnion-ac, bull:8:1, lead 10 degrees, scallop 0.005 mm,
#: 223,719 seeds) the bounds standing above ESTIMATE_SHARE times the largest cusp, all cast,
#: fell from 7,785 (1 piece) to 6,631 (2; 3: 6,093 for 10 % more of the estimate's CPU); at
#: scallop 0.03 mm its bounds over the ray cast read 1.025 and up, 1.128 at the median (1
#: piece: 1.031, 1.139) ...
POSE_PIECES = 2

#: ... each at this many even fractions (its start, then on; the last piece's end too).
POSE_FRACTIONS = 3


def _piece_poses(volume: CutVolume, piece: NDArray[np.int64]
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Ring centres and axes (m, K, 3) of poses the cut pieces round ``piece`` take.

    Pieces ``piece - POSE_PIECES .. piece + POSE_PIECES`` (within the toolpath's pieces:
    another pass's piece, at a pass's end, is cut material all the same), each at
    fractions ``f = k / POSE_FRACTIONS`` (``k < POSE_FRACTIONS``; the last piece to
    ``f = 1``): the tip linear and the axis normalized-linear along the piece, as the ray
    cast's pieces move (:func:`_contact_poses`): poses the toolpath takes, each inside what
    it removes.
    """
    last = len(volume.pass_of) - 1
    centres, axes = [], []
    for step in range(-POSE_PIECES, POSE_PIECES + 1):
        j = np.clip(piece + step, 0, last)
        ends = POSE_FRACTIONS + (step == POSE_PIECES)
        for k in range(ends):
            f = np.full(len(j), k / POSE_FRACTIONS)
            axis = move_axes(volume.axes0[j], volume.axes1[j], f)
            tip = volume.tips0[j] + f[:, None] * (volume.tips1[j] - volume.tips0[j])
            centres.append(tip + volume.cutter.corner_radius_mm * axis)
            axes.append(axis)
    return np.stack(centres, axis=1), np.stack(axes, axis=1)


#: Where a pass's ring centres bend away from the surface (``kappa_n R`` above this,
#: ``kappa_n`` their curvature along the surface normal, :func:`_bend_away`), its sweep
#: lands off-plane material ``kappa_n w^2 / 2`` higher than its prism along the way (``w``
#: the material's distance from the plane) and the ridge stands higher than the prisms'
#: crossing: ...
BEND_AWAY = 0.004

#: ... by this share of it, and :data:`BEND_AWAY_GROWTH` times ``kappa_n R`` more: the
#: estimate over the ray cast read 1.000 and up where the passes run straight or bend
#: towards the surface, and without a margin down to 0.968 where they bend away on the
#: standing dev blade in 3 axes (bull:8:1, scallop 0.03 mm, ``kappa_n R`` 0.02 to 0.05),
#: 0.88 on the lying one's far side in 5 axes (bull:8:1 and flat:6, scallop 0.1 mm, lead
#: 10 degrees, ``kappa_n R`` 0.05 to 0.1): the shortfall grows with the bend. With
#: ``0.02 + 2 kappa_n R`` the lowest read 1.007 on those three (``0.04 + 1.0 kappa_n R``
#: 0.98; the former flat 0.04, 0.915).
BEND_AWAY_SHARE = 0.02

#: ... (per unit of ``kappa_n R``) ...
BEND_AWAY_GROWTH = 2.0

#: ... up to this ``kappa_n R``; beyond, the ray cast decides (a margin of 0.22 of the
#: cusp and more ranks a seed's estimate far above its cusp; the bend's shortfall was
#: measured below it).
BEND_AWAY_CAP = 0.1


def _bend_away(volume: CutVolume, piece: NDArray[np.int64], normal: NDArray[np.float64]
               ) -> NDArray[np.float64]:
    """Curvature of a pass's ring centres at ``piece`` along ``normal`` (away from it), 1/mm.

    The turn of the pieces' direction from 2 pieces before to 2 after (within the pass)
    over the distance between their midpoints, its part along ``normal``.
    """
    a, b, pass_of = volume.piece_a, volume.piece_b, volume.pass_of
    last = len(pass_of) - 1
    before, after = np.maximum(piece - 2, 0), np.minimum(piece + 2, last)
    before = np.where(pass_of[before] == pass_of[piece], before, piece)
    after = np.where(pass_of[after] == pass_of[piece], after, piece)
    turn = unit(b[after] - a[after]) - unit(b[before] - a[before])
    apart = np.linalg.norm(0.5 * (a[after] + b[after] - a[before] - b[before]), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        bend = np.where(apart > TINY, np.einsum("ij,ij->i", turn, normal) / apart, 0.0)
    return bend


def _runs_on(volume: CutVolume, piece: NDArray[np.int64], centre: NDArray[np.float64],
             axis: NDArray[np.float64], way: NDArray[np.float64], normal: NDArray[np.float64],
             ridge: NDArray[np.float64], across: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Whether a pass runs on, straight, from its pose to the pose that leaves the ridge.

    A prism along ``way`` meets the plane of normal ``nu = across`` through ``ridge`` in
    its section (:func:`~.torus_profile.profile_ridges`); the section's point of outward
    normal ``m`` (in the plane) there is the cutter's support point ``P`` in the direction
    ``N = m - (m . way) / (nu . way) nu`` (across the way), ``P = C + r N + (R - r) N_a +
    (L - r) a [N . a > 0]`` (``N_a`` the unit part of ``N`` across the axis ``a``: corner,
    ring, flank), carried into the plane ``lambda = (ridge - P) . nu / (way . nu)``
    along the way: the pose ``C + lambda way``. The pass holds it only where it runs that
    far from the pose on ``piece`` (its pieces walked, :data:`CARRY_PIECES` at most) with
    no piece turned off the way by more than :data:`CARRY_TURN` (nor back along it) and no
    gap between its pieces (a rapid between two cut runs of one pass): at a pass's end, or
    where it turns to link, the prism carries the cutter into the plane from poses the
    pass never takes.
    """
    cutter = volume.cutter
    a, b, pass_of = volume.piece_a, volume.piece_b, volume.pass_of
    big, small = cutter.radius_mm, cutter.corner_radius_mm
    slant = np.einsum("ij,ij->i", way, across)
    with np.errstate(divide="ignore", invalid="ignore"):
        sup = unit(normal - (np.einsum("ij,ij->i", normal, way) / slant)[:, None] * across)
        up = np.einsum("ij,ij->i", sup, axis)
        support = (centre + small * sup + (big - small) * unit(sup - up[:, None] * axis)
                   + ((cutter.flute_length_mm - small) * (up > 0.0))[:, None] * axis)
        carry = np.einsum("ij,ij->i", ridge - support, across) / slant
    # walked along the piece (forward) or against it, from the pose, towards ``toward``
    forward = (np.einsum("ij,ij->i", way, b[piece] - a[piece]) >= 0.0) == (carry >= 0.0)
    toward = np.where(carry >= 0.0, 1.0, -1.0)[:, None] * way
    step = np.where(forward, 1, -1)
    least_cos = np.cos(CARRY_TURN)
    pos, k, left = centre.copy(), piece.copy(), np.abs(carry)
    held = np.isfinite(left)
    todo = np.flatnonzero(held)
    for _ in range(CARRY_PIECES):
        if not todo.size:
            break
        kt, fw = k[todo], forward[todo, None]
        start, end = np.where(fw, a[kt], b[kt]), np.where(fw, b[kt], a[kt])
        # the piece goes on the way (not back along it), from where the last one ended
        # (a pass's cut runs may be split by a rapid under one pass index)
        held[todo] &= np.einsum("ij,ij->i", unit(end - start), toward[todo]) >= least_cos
        held[todo] &= ((kt == piece[todo])
                       | (np.linalg.norm(start - pos[todo], axis=1) <= LENGTH_SLACK_MM))
        run = np.einsum("ij,ij->i", end - pos[todo], toward[todo])  # along the way
        goes_on = held[todo] & (left[todo] > run)
        on = todo[goes_on]
        pos[on], left[on] = end[goes_on], left[on] - run[goes_on]
        k[on] += step[on]
        # the pass ends short of that pose
        inside = (k[on] >= 0) & (k[on] < len(pass_of))
        inside[inside] = pass_of[k[on][inside]] == pass_of[piece[on][inside]]
        held[on[~inside]] = False
        todo = on[inside]
    held[todo] = False  # farther than CARRY_PIECES pieces
    return held


#: The pass is walked at most this many pieces from the pose to the pose whose cutter
#: leaves the ridge (:func:`_runs_on`; pieces of ``R / 8``: a flank carried into the
#: plane from farther is cast) ...
CARRY_PIECES = 32

#: ... and none of them may turn off the way by more than this, rad: round the lying dev
#: blade's leading edge (3 axes) the passes run down the wall to the lowest reachable
#: point and turn there to link, the next pass's tip 0.45 mm over the seed's plane; the
#: prism carried its cutter into the plane and the estimate read down to 0.07 times the
#: ray cast (flat:6, scallop 0.06 and 0.1 mm). Below 0.4 rad more seeds are cast
#: (0.1: 1 in 7 on the lying blade, flat:6) with no low estimate left.
CARRY_TURN = 0.4

#: A pass whose way runs along its cutter's axis more closely than this cosine is cast:
#: the prism along it squashes the cutter's whole height (the corner's outer rim ``r`` up,
#: the flank) into the section, which the pass sweeps only if it runs on straight over
#: that height. Round the lying dev blade's leading edge, where the 3-axis passes run down
#: the wall (``|way . a|`` 0.8 to 0.95) and stop, the bull-noses' estimates read down to
#: 0.16 times the ray cast (bull:8:1 and bull:10:2, scallop 0.1 mm; 0.8 casts twice as many
#: seeds there with none read low either way).
AXIS_WAY_COSINE = 0.9


def _nearest_in_pass(points: NDArray[np.float64], pass_of: NDArray[np.int64],
                     point: NDArray[np.float64], pass_: NDArray[np.int64]) -> NDArray[np.int64]:
    """The nearest of ``points`` (n, 3) of the pass ``pass_`` (m,) to each ``point`` (m, 3).

    ``pass_of`` (n,): the points' passes. One k-d tree per pass, each queried for its own
    pass's rows, nearest one: the nearest point of that pass (ties aside, the same as the
    first point of that pass among the nearest of all points; round the user's 5-axis
    blade job's bull-nose, where the nearest 16 of all pieces were another pass's for a
    fifth of the seeds, the nearest 64, 256 and 1024 of all took 4.2 of its 4.9 s; this,
    0.3 s). Returns the index, -1 where the pass has no point.
    """
    out = np.full(len(point), -1, dtype=np.int64)
    if not len(point) or not len(points):
        return out
    by_point, by_row = np.argsort(pass_of, kind="stable"), np.argsort(pass_, kind="stable")
    sorted_of, sorted_rows = pass_of[by_point], pass_[by_row]
    passes = np.unique(sorted_rows)
    p_lo, p_hi = (np.searchsorted(sorted_of, passes, side=side) for side in ("left", "right"))
    r_lo, r_hi = (np.searchsorted(sorted_rows, passes, side=side) for side in ("left", "right"))
    for i in np.flatnonzero(p_hi > p_lo):
        own = by_point[p_lo[i]:p_hi[i]]
        rows = by_row[r_lo[i]:r_hi[i]]
        _, idx = cKDTree(points[own]).query(point[rows], k=1)
        out[rows] = own[idx]
    return out


def _nearest_of(tree: cKDTree, pass_of: NDArray[np.int64], point: NDArray[np.float64],
                pass_: NDArray[np.int64], *,
                towards: NDArray[np.float64] | None = None) -> NDArray[np.int64]:
    """The nearest of ``tree``'s points of another pass than ``pass_``.

    Per ``point`` (m, 3), with pass ``pass_`` (m,); ``pass_of`` the tree's points' passes.
    With ``towards`` (m, 3), only points ``p`` with ``(p - point) . towards > 0``. The
    nearest 16, then 64 and so on up to 1024 (a pass's points can crowd round a tight
    edge). Returns the index, -1 where none. (Of the own pass: :func:`_nearest_in_pass`.)
    """
    out = np.full(len(point), -1, dtype=np.int64)
    n = tree.n
    todo, k = np.arange(len(point)), 16
    while todo.size and n:
        dist, idx = tree.query(point[todo], k=min(k, n), workers=query_workers(todo.size))
        dist, idx = dist.reshape(len(todo), -1), idx.reshape(len(todo), -1)
        idx_ok = np.minimum(idx, n - 1)
        pick = pass_of[idx_ok] != pass_[todo, None]
        pick &= np.isfinite(dist)
        if towards is not None:
            ahead = tree.data[idx_ok] - point[todo, None]
            pick &= np.einsum("ijk,ik->ij", ahead, towards[todo]) > 0.0
        hit = pick.any(axis=1)
        out[todo[hit]] = idx_ok[hit, np.argmax(pick[hit], axis=1)]
        todo = todo[~hit]
        if k >= min(n, 1024):
            break
        k *= 4
    return out


def _contact_way(volume: CutVolume, normal: NDArray[np.float64], piece: NDArray[np.int64]
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit way the cutter's point touching a surface of ``normal`` moves along ``piece``.

    The ring centre's way tilts off it as the axis turns, a radius ``R - r`` from the
    contact: ``e - (R - r) (w_b - w_a)`` with ``w`` the ring's inward directions at the
    piece's ends (:func:`~.cutters.radial_directions`). And how fast the axis turns
    along it: the angle between the ends' axes over that way's length, rad/mm (``inf``
    where the cutter turns on the spot).
    """
    ring = volume.cutter.radius_mm - volume.cutter.corner_radius_mm
    ring_a, _ = radial_directions(normal, volume.axes0[piece])
    ring_b, _ = radial_directions(normal, volume.axes1[piece])
    way = volume.piece_b[piece] - volume.piece_a[piece] - ring * (ring_b - ring_a)
    length = np.sqrt(np.einsum("ij,ij->i", way, way))
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", volume.axes0[piece], volume.axes1[piece]),
                             -1.0, 1.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        rate = np.where(turn > 0.0, turn / length, 0.0)
    return unit(way), rate


#: A pass's prism holds only where its cutter turns by less than this many radians while
#: its contact moves as far as the next pass's contact stands from the seed (the own or
#: the next pass's rate, :func:`_contact_way`): a cutter turning round its contact (a
#: bull-nose keeping its lead round the standing dev blade's leading edge) sweeps, off
#: the plane, material that a prism along the way would carry into it deeper than the
#: turning cutter reaches, and the ridge reads low. There the estimate over the ray cast
#: read 0.994 and up below 0.05, down to 0.95 at 0.05 to 0.15 and to -0.8 at 0.2 and
#: more (bull:8:1 and bull:10:2, lead 10 degrees, scallop 0.03 and 0.1 mm, cusps above
#: half the largest).
PIVOT_TURN = 0.05


#: A pass's pose whose contact lies nearest a seed's is sought this many pieces either
#: side of the piece nearest to it (:func:`_contact_poses`): a bull-nose with a lead
#: touches ``(R - r) cos(lead)`` ahead of its axis, two of them on zigzag passes ``2 R``
#: apart along them, 8 to 16 pieces of ``R / 8``.
CONTACT_WINDOW = 24

#: ... and sought again about the nearest, with the target as its axis puts it, until it
#: stays, up to this many windows in all (round the standing dev blade's leading edge,
#: where a bull-nose turns round the edge with a lead, the axis turns 0.6 to 0.9 degrees
#: a piece and the contact lies 21 to 27 pieces of 0.08 mm from the piece nearest the
#: seed).
CONTACT_WALKS = 4

#: ... and found there only where its foot lies across the piece from the target (along
#: it within this share of a piece's length: a bend between pieces, not a pass's end).
CONTACT_ALONG_SHARE = 0.25

#: A walk not found so (its foot beyond its piece's end) that still moved at its last
#: window walks on, up to this many windows in all, and is found only where it stays:
#: there the target, moving with the axis, had not stayed yet. On the user's 5-axis job
#: (standing dev blade, trunnion-ac, bull:8:1, lead 10 degrees, scallop 0.005 mm: pieces
#: of 0.02 to 0.04 mm, the contact some 100 pieces from the piece nearest the seed) 722
#: own and 978 next poses of 221,164 were found so, all within 11 windows, where 4 had
#: left them unfound and their seeds ray cast (seeds cast 7,605 -> 6,071, the measured
#: figures the same); the walks still moving at 40 windows swing between two pieces.
CONTACT_WALKS_ON = 12


def _contact_poses(volume: CutVolume, piece: NDArray[np.int64], corner: NDArray[np.float64],
                   normal: NDArray[np.float64]
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64],
                              NDArray[np.bool_]]:
    """The poses of the passes of ``piece`` whose contacts lie nearest the seeds'.

    A pose (ring centre ``C``, axis ``a``) touches a surface of normal ``n`` at the
    corner-circle centre ``C + (R - r) w``, ``w = -n_perp / |n_perp|``,
    ``n_perp = n - (n . a) a``: over the pieces of the pass within
    :data:`CONTACT_WINDOW` of ``piece``, the foot of ``corner + (R - r) n_perp / |n_perp|``
    (``a`` at the middle of ``piece``, then of the nearest) on the piece nearest to it
    (:func:`~.torus_kernel.window_nearest`),
    sought again about that piece with its axis until it stays (:data:`CONTACT_WALKS`
    windows at most; where the pose so found was not found and the walk still moved, up
    to :data:`CONTACT_WALKS_ON`, found only where it stays). Where the neighbouring poses
    tilt alike, the sections across the pass met at those poses stand as the contacts do
    (a pose's contact can lie a radius ahead of its ring centre, where a curved pass has
    moved on). Returns the pose the pass takes there (``C = tip + r a``, the tip linear
    and ``a`` normalized-linear along the piece, as the ray cast's pieces move: a pose
    inside what the pass removes), the piece and False where the nearest lies at the last
    window's edge or the pass ends short of the target (:data:`CONTACT_ALONG_SHARE`).
    """
    best = piece.copy()
    edge = np.zeros(len(piece), dtype=bool)
    moving = _walk_to_contact(volume, best, edge, np.arange(len(piece)), corner, normal,
                              CONTACT_WALKS)
    centre, axis, found = _pose_at_contact(volume, best, corner, normal)
    late = moving[~found[moving]]
    if late.size:  # (the target had not stayed: walk on, found only where it stays)
        swings = _walk_to_contact(volume, best, edge, late, corner, normal,
                                  CONTACT_WALKS_ON - CONTACT_WALKS)
        centre[late], axis[late], found[late] = _pose_at_contact(volume, best[late],
                                                                 corner[late], normal[late])
        found[swings] = False
    return centre, axis, best, found & ~edge


def _walk_to_contact(volume: CutVolume, best: NDArray[np.int64], edge: NDArray[np.bool_],
                     todo: NDArray[np.int64], corner: NDArray[np.float64],
                     normal: NDArray[np.float64], walks: int) -> NDArray[np.int64]:
    """Walk rows ``todo`` of ``best`` to the piece nearest their targets (in place).

    Up to ``walks`` windows of :data:`CONTACT_WINDOW` pieces (:func:`_contact_poses`),
    each about the piece the last one found, with the target as that piece's axis puts
    it; ``edge`` says where the last window's nearest lay at its edge. Returns the rows
    that still moved at their last window.
    """
    ring = volume.cutter.radius_mm - volume.cutter.corner_radius_mm
    a, e, pass_of = volume.piece_a, volume.piece_b - volume.piece_a, volume.pass_of
    for _ in range(walks):
        if not todo.size:
            break
        start = best[todo]
        # the axis turns little over the window: the target as the piece's axis puts it
        inward, _ = radial_directions(normal[todo], unit(volume.axes0[start]
                                                         + volume.axes1[start]))
        target = corner[todo] + ring * inward
        best[todo] = window_nearest(start, target, a, e, pass_of, CONTACT_WINDOW)
        # moved: the target as the new piece's axis puts it (round a tight edge the axis
        # turns fast along the pass), and at the window's edge the contact lies farther
        edge[todo] = np.abs(best[todo] - start) >= CONTACT_WINDOW
        todo = todo[best[todo] != start]
    return todo


def _pose_at_contact(volume: CutVolume, best: NDArray[np.int64], corner: NDArray[np.float64],
                     normal: NDArray[np.float64]
                     ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.bool_]]:
    """The pose on pieces ``best`` nearest the targets, and whether its foot lies across.

    The target as the piece's axis puts it (:func:`_contact_poses`), its foot on the piece
    and the pose the pass takes there; False where the foot lies along the piece from the
    target by more than :data:`CONTACT_ALONG_SHARE` of a piece (the pass ends short of it).
    """
    ring = volume.cutter.radius_mm - volume.cutter.corner_radius_mm
    a, e = volume.piece_a, volume.piece_b - volume.piece_a
    axis_mid = unit(volume.axes0[best] + volume.axes1[best])
    inward, _ = radial_directions(normal, axis_mid)
    target = corner + ring * inward
    foot, f = _foot_on(a[best], e[best], target)
    # a foot at the pass's end short of the target: that pose's contact lies beyond it
    across = ~(np.abs(np.einsum("ij,ij->i", target - foot, unit(e[best]))) > (
        CONTACT_ALONG_SHARE * volume.step_mm))
    # the pose the pass takes at f: its tip moves linearly, its axis normalized-linearly
    # (the ring centre at ``foot`` stands on the unnormalized axis, r (1 - cos(turn / 2))
    # deep at mid-piece: a pose no pass takes)
    axis = move_axes(volume.axes0[best], volume.axes1[best], f)
    tips0, tips1 = volume.tips0[best], volume.tips1[best]
    centre = tips0 + f[:, None] * (tips1 - tips0) + volume.cutter.corner_radius_mm * axis
    return centre, axis, across


def _foot_on(a: NDArray[np.float64], e: NDArray[np.float64], p: NDArray[np.float64]
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Nearest points to ``p`` on segments ``a + f e`` (``0 <= f <= 1``) and ``f``."""
    f = np.clip(np.einsum("...j,...j->...", p - a, e)
                / np.maximum(np.einsum("...j,...j->...", e, e), TINY), 0.0, 1.0)
    return a + f[..., None] * e, f


def _ridges_widening(volume: CutVolume, seeds: SearchSeeds) -> tuple[NDArray[np.float64], ...]:
    """The ridge between each seed's own pass and the next pass (:func:`~.cusp_kernel.ridges`).

    Among the pieces within :attr:`CutVolume.near_mm` of ``P = Q + R n``; where no other
    pass lies there, within 4 times that, and so on up to ``2 R`` and a piece's length (an
    other pass's piece whose midpoint lies farther from ``P`` leaves its tube apart from
    the own pass's: the tubes do not meet). Returns the ridge points, the depths inside
    the other tubes, the states (``RIDGE_*``) and the two pieces met.
    """
    n_seed = len(seeds.t)
    big = volume.cutter.radius_mm
    centre = seeds.q + big * seeds.n
    seg = volume.piece_vectors
    found = [np.zeros((n_seed, 3)), np.zeros((n_seed, 2)), np.full(n_seed, RIDGE_NO_PASS),
             np.full((n_seed, 2), -1, dtype=np.int64)]

    def search(todo: NDArray[np.int64], radius_mm: float) -> NDArray[np.bool_]:
        if todo.size == n_seed:  # every seed (the first reach): its arrays are the result
            found[:] = ridges(centre, seeds.n, seeds.x_s, seeds.pass_, volume.near_cells,
                              radius_mm, volume.a, seg, volume.pass_of, big)
            return found[2] == RIDGE_NO_PASS
        x, inside, state, pieces = found
        x[todo], inside[todo], state[todo], pieces[todo] = ridges(
            centre[todo], seeds.n[todo], seeds.x_s[todo], seeds.pass_[todo],
            volume.near_cells, radius_mm, volume.a, seg, volume.pass_of, big)
        return state[todo] == RIDGE_NO_PASS

    _widening(volume, np.arange(n_seed), search)
    return tuple(found)


def _widest_reach(volume: CutVolume) -> float:
    """How far the pieces of another pass are sought at most: ``2 R`` and a piece's length, mm."""
    return 2.0 * volume.cutter.radius_mm + volume.step_mm


def _widening(volume: CutVolume, rows: NDArray[np.int64],
              search: Callable[[NDArray[np.int64], float], NDArray[np.bool_]]) -> None:
    """Run ``search(rows, reach_mm)`` over ``rows`` with a reach that widens.

    First within :attr:`CutVolume.near_mm`; the rows ``search`` reports as not found again
    within 4 times that, and so on up to :func:`_widest_reach` (beyond it another pass's
    tube cannot meet the own pass's).
    """
    todo = rows
    reach, limit = volume.near_mm, _widest_reach(volume)
    while todo.size:
        todo = todo[search(todo, reach)]
        if reach >= limit:
            break
        reach = min(4.0 * reach, limit)
