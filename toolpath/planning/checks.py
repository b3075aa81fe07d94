"""Checks of a finishing plan: gouges at the cutter locations, linking moves, machine.

* :func:`gouge_stage`: the local (curvature) and global (samples) gouge checks of the cut
  points, then ``on_gouge`` (3-axis: points whose tool would hit another part of the
  surface, or that no lift clears, are not reachable: dropped and reported as shadowed);
* :func:`check_links`: every non-cutting position, and points a cutter radius apart along
  the linking moves, must clear the surface;
* :func:`machine_stage`: inverse kinematics, travel (raise or report) and rate limits,
  time at the rate limits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from machines import Machine
from machines.limits import Violation, check_rates, check_travel, min_segment_times

from ..joint_refine import path_joints
from ..path import MoveKind, Toolpath
from ..surface import ParametricSurface
from ..tolerances import LENGTH_SLACK_MM
from ..vectors import move_poses
from .avoid import (
    Lifted,
    depth_text,
    gouge_error,
    lift_gouges,
    lift_until_clear,
    local_depth_mm,
    measured_depth,
    retilt_gouges,
)
from .cutters import Cutter, CutterKind
from .errors import GougeError, PlanTravelLimitError, too_many_points
from .gouge import Clearance, SurfaceSamples, global_clearance, local_margin
from .options import AxisMode, FinishingOptions, OnGouge, OnLimit, PlannedOptions
from .passes import PassPoints, frame_take, insert_move_poses, with_rate_record, with_tips
from .travel import fit_travel

__all__ = ["GougeStats", "MachineStats", "check_links", "concave_remedy", "gouge_stage",
           "machine_stage"]


@dataclass(frozen=True)
class GougeStats:
    """What the gouge stage did (:func:`gouge_stage`).

    Attributes
    ----------
    n_lifted : int
        Kept points lifted clear of a gouge (``on_gouge="lift"``).
    max_lift_mm : float
        The largest lift, mm (0 when none).
    n_retilted : int
        Points whose axis was turned away from a gouge (``on_gouge="retilt"``).
    min_clearance_mm : float
        The smallest clearance of the kept points' tools from the surface samples away
        from the contact, after the fixes (``inf`` when no point is kept).
    n_fold_points : int
        Poses inserted into cutting moves across a fold (:func:`fold_moves`).
    max_fold_lift_mm : float
        The largest lift of those poses along their axes, mm (0 when none).
    """

    n_lifted: int = 0
    max_lift_mm: float = 0.0
    n_retilted: int = 0
    min_clearance_mm: float = float("inf")
    n_fold_points: int = 0
    max_fold_lift_mm: float = 0.0


@dataclass(frozen=True)
class MachineStats:
    """The machine stage's findings (:func:`machine_stage`).

    Its name, the travel and rate violations (travel only with ``on_limit="report"``)
    and the time at the rate limits, s.
    """

    name: str
    travel: tuple[Violation, ...]
    rates: tuple[Violation, ...]
    time_s: float


def gouge_stage(surface: ParametricSurface, cutter: Cutter, opts: FinishingOptions,
                 res: PlannedOptions, pts: PassPoints, keep: NDArray[np.bool_],
                 samples: SurfaceSamples) -> tuple[PassPoints, NDArray[np.bool_], GougeStats]:
    """Gouge checks on the kept points, then ``on_gouge``.

    A location gouges where it sinks deeper than ``gouge_tol_mm`` into the surface: by the
    sample check, or, where the curvature at its contact out-curves the cutter (the local
    check), by the depth measured round the contact (:func:`~.avoid.gouge_depth_mm`); a
    concave radius smaller than the cutter that costs less is no gouge (a ripple of a fit).
    After a lift the cutting moves must keep within the planned chord tolerance
    (``res.planned_chord_tol_mm``, :func:`_lifted_moves`). Then the moves between the
    points are checked (:func:`fold_moves`).
    """
    found, keep = _point_gouges(surface, cutter, opts, pts, keep, samples)
    stats = GougeStats()
    if found.bad.any():
        pts, keep, stats = _fixed_gouges(surface, cutter, opts, res, pts, keep, samples, found)
    idx, far_mm, near_mm = _clearance_after(cutter, opts, pts, keep, samples, found)
    # between the points: moves across a fold, or next to another part of the surface
    near_other = np.zeros(len(pts), dtype=bool)
    near_other[idx] = np.isfinite(far_mm)
    accepted = np.zeros(len(pts))  # gouges within gouge_tol_mm at the points
    accepted[idx] = np.maximum(-np.minimum(far_mm, near_mm), 0.0)
    pts, keep, n_fold_points, max_fold_lift_mm = fold_moves(
        surface, cutter, opts, res, pts, keep, samples, near_other, accepted)
    return pts, keep, replace(
        stats, min_clearance_mm=float(far_mm.min()) if far_mm.size else float("inf"),
        n_fold_points=n_fold_points, max_fold_lift_mm=max_fold_lift_mm)


@dataclass(frozen=True, eq=False)
class _PointGouges:
    """The gouge checks at the kept points (:func:`_point_gouges`), rows ``idx``.

    ``clr``: the sample check; ``depth_mm``: the depth near the contact (measured where
    ``curved``: the curvature there out-curves the cutter); ``far_bad``: another part of
    the surface cuts deeper than the tolerance; ``bad``: a kept point that gouges.
    """

    idx: NDArray[np.int64]
    clr: Clearance
    depth_mm: NDArray[np.float64]
    curved: NDArray[np.bool_]
    far_bad: NDArray[np.bool_]
    bad: NDArray[np.bool_]


def _point_gouges(surface: ParametricSurface, cutter: Cutter, opts: FinishingOptions,
                  pts: PassPoints, keep: NDArray[np.bool_], samples: SurfaceSamples
                  ) -> tuple[_PointGouges, NDArray[np.bool_]]:
    """The sample and local checks at the kept points, and the points kept after them.

    With the fixed axis, a point where another part of the surface is in the way is not
    kept: the axis cannot get there without the tool hitting the part elsewhere.
    """
    tol = opts.gouge_tol_mm
    idx = np.flatnonzero(keep)
    rows = slice(None) if idx.size == len(pts) else idx  # (every point kept: no copies)
    clr = global_clearance(cutter, pts.tips[rows], pts.axes[rows], samples,
                           contacts_mm=pts.frame.point[rows], flutes=opts.check_flutes)
    far_bad = clr.far_mm < -tol
    if opts.axis_mode is AxisMode.FIXED and far_bad.any():
        keep = keep.copy()
        keep[idx[far_bad]] = False
        far_bad = np.zeros_like(far_bad)
    depth = np.maximum(-clr.near_mm, 0.0)
    curved = local_depth_mm(frame_take(pts.frame, idx), cutter, pts.axes[idx]) > tol
    maybe = np.flatnonzero((depth <= tol) & keep[idx] & curved)
    if maybe.size:  # the curvature says it may sink in: measure how deep
        at = idx[maybe]
        depth[maybe] = measured_depth(surface, cutter, pts, at, pts.tips[at], pts.axes[at],
                                      stop_mm=tol).depth_mm
    bad = ((depth > tol) | far_bad) & keep[idx]
    return _PointGouges(idx, clr, depth, curved, far_bad, bad), keep


def _fixed_gouges(surface: ParametricSurface, cutter: Cutter, opts: FinishingOptions,
                  res: PlannedOptions, pts: PassPoints, keep: NDArray[np.bool_],
                  samples: SurfaceSamples, found: _PointGouges
                  ) -> tuple[PassPoints, NDArray[np.bool_], GougeStats]:
    """``on_gouge`` at the gouging points: raise, lift (:func:`_lifted_gouges`) or re-tilt."""
    idx, bad = found.idx, found.bad
    if opts.on_gouge is OnGouge.RAISE:
        k = int(np.flatnonzero(bad)[0])
        raise _gouge_error(surface, cutter, pts, int(idx[k]), found.clr, k, samples,
                           far=bool(found.far_bad[k]))
    if opts.on_gouge is OnGouge.LIFT:
        return _lifted_gouges(surface, cutter, opts, res, pts, keep, samples, found)
    axes, tips, moved = retilt_gouges(
        surface, cutter, pts, idx[bad], samples, lead_deg=opts.lead_deg,
        tilt_deg=opts.tilt_deg, min_cone_deg=opts.min_cone_deg, tol_mm=opts.gouge_tol_mm,
        flutes=opts.check_flutes)
    return with_tips(pts, axes, tips), keep, GougeStats(n_retilted=moved)


def _lifted_gouges(surface: ParametricSurface, cutter: Cutter, opts: FinishingOptions,
                   res: PlannedOptions, pts: PassPoints, keep: NDArray[np.bool_],
                   samples: SurfaceSamples, found: _PointGouges
                   ) -> tuple[PassPoints, NDArray[np.bool_], GougeStats]:
    """The gouging points lifted clear (:func:`~.avoid.lift_gouges`), their moves checked.

    With the fixed axis a point no lift clears (a wall along the axis) is not kept: the
    tool cannot cut there. The lifted points' moves must keep within the planned chord
    tolerance (:func:`_lifted_moves`).
    """
    idx, where = found.idx, found.idx[found.bad]
    depth = _scatter(np.maximum(found.depth_mm, -found.clr.far_mm), idx, len(pts))
    curved = np.zeros(len(pts), dtype=bool)
    curved[idx] = found.curved
    tips, lift, stuck = lift_gouges(surface, cutter, pts, where, depth, samples,
                                    curved=curved, tol_mm=opts.gouge_tol_mm,
                                    flutes=opts.check_flutes,
                                    drop=opts.axis_mode is AxisMode.FIXED)
    pts = with_tips(pts, pts.axes, tips)
    if stuck.size:
        keep = keep.copy()
        keep[stuck] = False
    lifted = np.setdiff1d(where, stuck)
    keep = _lifted_moves(cutter, pts, keep, lifted, samples, opts, res.planned_chord_tol_mm)
    return pts, keep, GougeStats(n_lifted=int(keep[lifted].sum()), max_lift_mm=float(lift.max()))


def _clearance_after(cutter: Cutter, opts: FinishingOptions, pts: PassPoints,
                     keep: NDArray[np.bool_], samples: SurfaceSamples, found: _PointGouges
                     ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """The kept points and their far and near clearances after the fixes, mm.

    Checked again where a point was fixed; without any fix, the first check stands for
    the points still kept.
    """
    if found.bad.any():
        idx = np.flatnonzero(keep)
        final = global_clearance(cutter, pts.tips[idx], pts.axes[idx], samples,
                                 contacts_mm=pts.frame.point[idx], flutes=opts.check_flutes)
        return idx, final.far_mm, final.near_mm
    still = keep[found.idx]
    return found.idx[still], found.clr.far_mm[still], found.clr.near_mm[still]


#: Normals sampled between a contact and the deepest point of its gouge (to tell a fold).
FOLD_SAMPLES = 257

#: Remedies named in gouge messages (command-line flags; the API's ``on_gouge`` and
#: ``gouge_tol_mm`` take the same values).
LIFT_REMEDY = "--on-gouge lift (lifts the cutter clear, leaving material there)"


def concave_remedy(cutter: Cutter, radius_mm: float) -> str:
    """Which cutter fits a concave surface of ``radius_mm``, for a gouge message.

    A ball of a smaller radius touches it at one point. A flat or bull-nose cutter's
    flat end spans the surface wherever it curves up under it, whatever the radius:
    a smaller cutter of the same kind only gouges less, so the advice is a ball.
    """
    if cutter.kind is CutterKind.BALL:
        return f"use a cutter of radius < {radius_mm:.3f} mm"
    return (f"use a ball cutter of radius < {radius_mm:.3f} mm ({cutter.spec}'s flat end "
            "spans the concave surface)")


def _gouge_error(surface: ParametricSurface, cutter: Cutter, pts: PassPoints, i: int,
                 clr: Clearance, k: int, samples: SurfaceSamples, *, far: bool
                 ) -> GougeError:
    """The GougeError for point ``i`` (row ``k`` of the checks): depth, place and cause.

    The depth is the deepest found, by the sample check or measured round the contact;
    the cause names a concave radius only where the contact has one smaller than the
    cutter and the gouge is there, else the place where the surface meets the cutter.
    """
    tips, axes = pts.tips[i:i + 1], pts.axes[i:i + 1]
    if far:
        sample = int(clr.far_sample[k])
        q = samples.points[sample]
        cause = (f"the cutter hits another part of the surface at t={samples.t[sample]:.5f}, "
                 f"s={samples.s[sample]:.5f} (point ({q[0]:.3f}, {q[1]:.3f}, {q[2]:.3f}) mm); "
                 "use --on-gouge retilt, another --lead or --tilt, or " + LIFT_REMEDY)
        return gouge_error(pts, i, cutter, -float(clr.far_mm[k]), cause)
    found = measured_depth(surface, cutter, pts, np.array([i]), tips, axes)
    depth, t_at, s_at = float(found.depth_mm[0]), float(found.t[0]), float(found.s[0])
    sample = int(clr.near_sample[k])
    if sample >= 0 and -float(clr.near_mm[k]) > depth:
        depth, t_at, s_at = -float(clr.near_mm[k]), float(samples.t[sample]), \
            float(samples.s[sample])
    remedy = f"{LIFT_REMEDY}, or --gouge-tol above {depth:.4f} mm if that is acceptable"
    frame = frame_take(pts.frame, np.array([i]))
    margin = float(local_margin(frame, cutter, axes)[0])
    kmax = float(frame.max_concave_curvature[0])
    q = surface(t_at, s_at)
    gap = float(np.linalg.norm(q - frame.point[0]))
    if margin < 0.0 and kmax > 0.0 and gap <= 1.0 / kmax + cutter.radius_mm:
        radius = 1.0 / kmax
        than = ("smaller than the cutter" if radius < cutter.radius_mm else
                "under the cutter's flat end")
        cause = (f"the surface's concave radius there is {radius:.4f} mm, {than} (radius "
                 f"{cutter.radius_mm:g} mm); {concave_remedy(cutter, radius)}, " + remedy)
    else:
        # the largest turn of the normal from the contact's on the way there (parameters
        # straight from the contact's: a fold between them turns it past 90 deg)
        u = np.linspace(0.0, 1.0, FOLD_SAMPLES)
        way_t = float(pts.t[i]) + u * (t_at - float(pts.t[i]))
        way_s = float(pts.s[i]) + u * (s_at - float(pts.s[i]))
        turn = float(np.degrees(np.arccos(np.clip(
            surface.normal(way_t, way_s) @ frame.normal[0], -1.0, 1.0))).max())
        if not surface.closed_t and abs(t_at - float(pts.t[i])) > 0.5:
            what = "the other end of the open sections (a closed contour fitted open?)"
        elif turn > 90.0:
            what = (f"beyond a fold of the surface, its normal turning {turn:.0f} deg from the "
                    "contact's on the way (a fit folding over itself at a sharp edge: refit "
                    "it, e.g. with another --fit-tol)")
        else:
            what = (f"its normal turning up to {turn:.0f} deg from the contact's on the way "
                    "(a concave crease, a ripple or a gap narrower than the cutter)")
        cause = (f"the surface meets the cutter at t={t_at:.5f}, s={s_at:.5f} (point "
                 f"({q[0]:.3f}, {q[1]:.3f}, {q[2]:.3f}) mm, {gap:.3f} mm from the contact), "
                 f"{what}; use " + remedy)
    return gouge_error(pts, i, cutter, depth, cause)


#: Rounds of :func:`_lifted_moves` (each drops the ends of the moves that still gouge).
LIFTED_MOVE_ROUNDS = 8
#: Points checked inside each cutting move after a lift: every 0.1 mm, at least 4 (a move
#: grazing a fold or a sharp nose digs in over a stretch of about the nose's size).
LIFTED_MOVE_POINTS_PER_MM = 10.0
LIFTED_MOVE_MIN_POINTS = 4


def _lifted_moves(cutter: Cutter, pts: PassPoints, keep: NDArray[np.bool_],
                  lifted: NDArray[np.int64], samples: SurfaceSamples, opts: FinishingOptions,
                  chord_tol_mm: float) -> NDArray[np.bool_]:
    """Check the cutting moves once points were lifted; returns ``keep``.

    A lifted location is clear, but the straight move from it to a neighbour (chosen
    before the lift) may still cut through what the lift avoided, and where the surface
    folds (a fit's fold at a sharp edge) the chord check, which measures the gap to the
    surface next to the move, may not see the fold's other side. Points along every
    cutting move (:data:`LIFTED_MOVE_POINTS_PER_MM`) must clear the surface samples by
    ``chord_tol_mm`` (the planned one: a move along a pass may dip that much). 3-axis: both
    ends of such a move are dropped (left uncut, as shadowed), until none is left; 5-axis:
    a GougeError naming it.
    """
    keep = keep.copy()
    if not lifted.size:
        return keep
    for _ in range(LIFTED_MOVE_ROUNDS):
        a_i = np.flatnonzero(keep[:-1] & keep[1:] & pts.same_pass)
        b_i = a_i + 1
        if not a_i.size:
            break
        pieces = np.maximum(np.ceil(np.linalg.norm(pts.tips[b_i] - pts.tips[a_i], axis=1)
                                    * LIFTED_MOVE_POINTS_PER_MM).astype(np.int64),
                            LIFTED_MOVE_MIN_POINTS)
        worst, _, _ = move_clearance(cutter, pts, a_i, pieces, samples, opts.check_flutes)
        bad = worst < -chord_tol_mm
        if not bad.any():
            break
        if opts.axis_mode is not AxisMode.FIXED:
            k = int(np.flatnonzero(bad)[0])
            raise gouge_error(pts, int(a_i[k]), cutter, -float(worst[k]),
                              "with the gouges lifted clear, the cutting move from there to "
                              "the next point still cuts that deep (a fold of the surface, or "
                              "a lifted neighbour); use --on-gouge retilt or a smaller cutter")
        out = np.unique(np.r_[a_i[bad], b_i[bad]])
        keep[out] = False
    return keep


def _move_poses(pts: PassPoints, a_i: NDArray[np.int64], u: NDArray[np.float64]
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Tips and axes at fractions ``u`` of moves ``a_i -> a_i + 1`` (:func:`move_poses`)."""
    return move_poses(pts.tips[a_i], pts.axes[a_i], pts.tips[a_i + 1], pts.axes[a_i + 1], u)


def _pose_clearance(cutter: Cutter, tips: NDArray[np.float64], axes: NDArray[np.float64],
                    samples: SurfaceSamples, flutes: bool
                    ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Each pose's smallest clearance against every sample, and that sample (-1: none)."""
    clr = global_clearance(cutter, tips, axes, samples, flutes=flutes)
    return clr.min_mm, np.where(clr.near_mm <= clr.far_mm, clr.near_sample, clr.far_sample)


def move_clearance(cutter: Cutter, pts: PassPoints, a_i: NDArray[np.int64],
                   pieces: NDArray[np.int64], samples: SurfaceSamples, flutes: bool
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """The cutter's smallest clearance inside moves ``a_i -> a_i + 1``, where, and against.

    ``pieces[k]`` poses at ``u = j / (pieces + 1)``, ``j = 1 .. pieces``, the move's own
    (:func:`_move_poses`), each against every sample (:func:`~.gouge.global_clearance`,
    ``inf`` beyond its horizon); returns the smallest per move, its ``u`` and its sample.
    """
    owner = np.repeat(np.arange(a_i.size), pieces)
    first = np.r_[0, np.cumsum(pieces)[:-1]]
    u = (np.arange(pieces.sum()) - first[owner] + 1) / (pieces[owner] + 1)
    clr, sample = _pose_clearance(cutter, *_move_poses(pts, a_i[owner], u), samples, flutes)
    worst = np.full(a_i.size, np.inf)
    np.minimum.at(worst, owner, clr)
    # the first pose reaching each move's minimum
    hit = np.flatnonzero(clr == worst[owner])[::-1]
    u_at = np.full(a_i.size, 0.5)
    at = np.full(a_i.size, -1)
    u_at[owner[hit]] = u[hit]
    at[owner[hit]] = sample[hit]
    return worst, u_at, at


#: A move is checked between its points (:func:`fold_moves`) where the normal turns
#: between its contacts so far that the cutter, rolled round a sharp edge there, would
#: stand above the move by more than this share of the chord tolerance (``R (1 - cos
#: (theta / 2))``, ``theta`` the turn: the chord of its centre's arc round the edge).
FOLD_SCREEN_SHARE = 0.25
#: The turn counted is what the contacts' curvature along the pass (the larger, times
#: this margin, over the move's length) does not explain: a smooth nose's turn the chord
#: check measures; a fold turns between contacts on flat faces.
FOLD_CURVATURE_MARGIN = 1.5
#: A ball's clearance along a move, sampled ``d`` apart, is missed by at most ``d^2 / 8 r``
#: (``r`` its corner radius, at least :data:`FOLD_MIN_CORNER_MM`) next to its deepest place:
#: this share of the chord tolerance; at most :data:`FOLD_MAX_PIECES` poses a move. Where
#: the smallest sample is within that of touching, the deepest place is searched between
#: its neighbours (golden section, :data:`FOLD_GOLDEN_STEPS`).
FOLD_MISS_SHARE = 0.25
FOLD_MIN_CORNER_MM = 0.25
FOLD_MAX_PIECES = 64
FOLD_GOLDEN_STEPS = 24
#: Rounds of :func:`fold_moves` (each inserts one pose into each move still gouging: the
#: turn left to each part halves, its dip quarters).
FOLD_ROUNDS = 16


def _fold_pieces(cutter: Cutter, pts: PassPoints, a_i: NDArray[np.int64], tol_mm: float
                 ) -> NDArray[np.int64]:
    """Poses to sample inside each move (one at least, :data:`FOLD_MAX_PIECES` at most).

    Its travel (tip, plus the radius times the axis' turn) over the spacing
    :data:`FOLD_MISS_SHARE` needs.
    """
    b_i = a_i + 1
    r = max(cutter.corner_radius_mm, FOLD_MIN_CORNER_MM)
    spacing = math.sqrt(8.0 * r * FOLD_MISS_SHARE * tol_mm)
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", pts.axes[a_i], pts.axes[b_i]), -1.0, 1.0))
    travel = np.linalg.norm(pts.tips[b_i] - pts.tips[a_i], axis=1) + cutter.radius_mm * turn
    return np.clip(np.ceil(travel / spacing).astype(np.int64), 1, FOLD_MAX_PIECES)


def _missed_mm(cutter: Cutter, samples: SurfaceSamples, tol_mm: float) -> float:
    """How much a sampled clearance may overstate the true one along a move, mm.

    The poses' spacing (:data:`FOLD_MISS_SHARE` of ``tol_mm``) and the samples' own: a
    ball passes between samples ``d`` apart missing them by up to ``d^2 / 8 r``.
    """
    r = max(cutter.corner_radius_mm, FOLD_MIN_CORNER_MM)
    return FOLD_MISS_SHARE * tol_mm + samples.spacing_mm ** 2 / (8.0 * r)


def _deepest(cutter: Cutter, pts: PassPoints, a_i: NDArray[np.int64],
             pieces: NDArray[np.int64], samples: SurfaceSamples, flutes: bool, tol_mm: float
             ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """:func:`move_clearance`, its minimum searched between samples near touching."""
    worst, u_at, at = move_clearance(cutter, pts, a_i, pieces, samples, flutes)
    near = np.flatnonzero(worst < _missed_mm(cutter, samples, tol_mm))
    if not near.size:
        return worst, u_at, at
    h = 1.0 / (pieces[near] + 1)
    lo, hi = np.maximum(u_at[near] - h, 0.0), np.minimum(u_at[near] + h, 1.0)
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    rows = a_i[near]

    def clear(u: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
        return _pose_clearance(cutter, *_move_poses(pts, rows, u), samples, flutes)

    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    (f1, s1), (f2, s2) = clear(x1), clear(x2)
    for _ in range(FOLD_GOLDEN_STEPS):
        left = f1 < f2  # the minimum lies in [lo, x2]
        hi = np.where(left, x2, hi)
        lo = np.where(left, lo, x1)
        x2n = np.where(left, x1, lo + g * (hi - lo))
        x1n = np.where(left, hi - g * (hi - lo), x2)
        # the kept interior point moves to the other side (its value with it); the new
        # point's value is evaluated below
        x1, x2, f1, f2, s1, s2 = x1n, x2n, f2, f1, s2, s1
        new = np.where(left, x1, x2)
        f_new, s_new = clear(new)
        f1 = np.where(left, f_new, f1)
        s1 = np.where(left, s_new, s1)
        f2 = np.where(left, f2, f_new)
        s2 = np.where(left, s2, s_new)
    best_u, best_f, best_s = np.where(f1 < f2, x1, x2), np.minimum(f1, f2), np.where(
        f1 < f2, s1, s2)
    better = best_f < worst[near]
    worst[near[better]] = best_f[better]
    u_at[near[better]] = best_u[better]
    at[near[better]] = best_s[better]
    return worst, u_at, at


#: Golden-section steps of :func:`_closest_near` in each of ``s`` and ``t``, twice over.
CLOSEST_STEPS = 20


def _closest_near(surface: ParametricSurface, centres: NDArray[np.float64],
                  at: NDArray[np.int64], samples: SurfaceSamples
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The surface's point nearest each centre, searched round sample ``at``; its ``t, s``.

    The samples stand a spacing apart in ``s`` (a ball between two of them is missed by
    ``spacing^2 / 8 R``); the distance is minimised along ``s`` within a spacing of the
    sample, then along ``t`` within the neighbouring columns (golden section, which needs
    no derivative: across a fold the distance has a kink), twice.
    """
    t, s = samples.t[at].copy(), samples.s[at].copy()
    columns = np.unique(samples.t)
    k = np.searchsorted(columns, t)
    t_lo = columns[np.maximum(k - 1, 0)]
    t_hi = columns[np.minimum(k + 1, columns.size - 1)]
    ds = samples.spacing_mm / max(float(np.linalg.norm(
        surface(0.5, 1.0) - surface(0.5, 0.0))), LENGTH_SLACK_MM)
    s_lo, s_hi = np.maximum(s - 2.0 * ds, 0.0), np.minimum(s + 2.0 * ds, 1.0)
    g = 0.5 * (math.sqrt(5.0) - 1.0)

    def dist(tt: NDArray[np.float64], ss: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.linalg.norm(surface(tt, ss) - centres, axis=1)

    for _ in range(2):
        for along_s in (True, False):
            lo, hi = (s_lo, s_hi) if along_s else (t_lo, t_hi)
            lo, hi = lo.copy(), hi.copy()
            for _step in range(CLOSEST_STEPS):
                x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
                f1 = dist(t, x1) if along_s else dist(x1, s)
                f2 = dist(t, x2) if along_s else dist(x2, s)
                hi = np.where(f1 < f2, x2, hi)
                lo = np.where(f1 < f2, lo, x1)
            mid = 0.5 * (lo + hi)
            if along_s:
                better = dist(t, mid) < dist(t, s)
                s = np.where(better, mid, s)
            else:
                better = dist(mid, s) < dist(t, s)
                t = np.where(better, mid, t)
    return surface(t, s), t, s


#: Where the nearest point lies on a fold, its normal is taken this far (in ``t``) to
#: either side of it too: the verifier measures along either face's normal.
FOLD_SIDE_T = 1e-7


def _normal_depth(surface: ParametricSurface, cutter: Cutter, pts: PassPoints,
                  a_i: NDArray[np.int64], u: NDArray[np.float64], worst: NDArray[np.float64],
                  at: NDArray[np.int64], samples: SurfaceSamples, tol_mm: float
                  ) -> NDArray[np.float64]:
    """How deep each pose cuts below its deepest sample along that sample's normal, mm.

    A gouge is measured along the surface's normal (as the verifier measures it). A ball
    (centre ``c``) holding a point ``P`` (normal ``n``, ``q = P - c``, ``|q| = R - e``)
    cuts it down to ``q.n + sqrt((q.n)^2 - |q|^2 + R^2)``: ``e`` where the centre
    stands on the normal, up to ``sqrt(2 R e)`` at a fold, where it stands on the other
    face's normal (so the normals on both sides of the point are taken,
    :data:`FOLD_SIDE_T`). Other cutters: the clearance itself.
    """
    depth = np.maximum(-worst, 0.0)
    if cutter.kind is not CutterKind.BALL:
        return depth
    rows = np.flatnonzero((at >= 0) & (worst < _missed_mm(cutter, samples, tol_mm)))
    if not rows.size:
        return depth
    tips, axes = _move_poses(pts, a_i[rows], u[rows])
    centres = tips + cutter.radius_mm * axes
    point, t, s = _closest_near(surface, centres, at[rows], samples)
    q = point - centres
    depth[rows] = np.maximum(cutter.radius_mm - np.linalg.norm(q, axis=1), depth[rows])
    qq = np.einsum("ij,ij->i", q, q)
    for side in (-FOLD_SIDE_T, 0.0, FOLD_SIDE_T):  # a fold's two faces, and the point
        n = surface.normal(np.clip(t + side, 0.0, 1.0), s)
        qn = np.einsum("ij,ij->i", q, n)
        inside = qn * qn - qq + cutter.radius_mm ** 2
        depth[rows] = np.maximum(np.where(qq < cutter.radius_mm ** 2, qn + np.sqrt(
            np.maximum(inside, 0.0)), 0.0), depth[rows])
    return depth


def _lift_poses(surface: ParametricSurface, cutter: Cutter, pts: PassPoints,
                idx: NDArray[np.int64], first_mm: NDArray[np.float64],
                samples: SurfaceSamples, tol_mm: float, flutes: bool) -> Lifted:
    """Lift poses ``idx`` along their axes until within ``tol_mm`` of the surface.

    :func:`~.avoid.lift_until_clear`, the depth taken from the samples and, for a ball,
    from the point nearest its centre (:func:`_closest_near`: samples alone miss a ridge
    between them).
    """
    def depth_at(rows: NDArray[np.int64], tips: NDArray[np.float64]) -> NDArray[np.float64]:
        axes = pts.axes[rows]
        clr, at = _pose_clearance(cutter, tips, axes, samples, flutes)
        worst = -clr
        if cutter.kind is CutterKind.BALL:
            near = np.flatnonzero(at >= 0)
            centres = tips[near] + cutter.radius_mm * axes[near]
            point, _, _ = _closest_near(surface, centres, at[near], samples)
            worst[near] = np.maximum(worst[near], cutter.radius_mm - np.linalg.norm(
                point - centres, axis=1))
        return worst

    return lift_until_clear(pts.tips, pts.axes, idx, first_mm, tol_mm, depth_at)


def fold_moves(surface: ParametricSurface, cutter: Cutter, opts: FinishingOptions,
               res: PlannedOptions, pts: PassPoints, keep: NDArray[np.bool_],
               samples: SurfaceSamples, near_other: NDArray[np.bool_],
               accepted_mm: NDArray[np.float64]
               ) -> tuple[PassPoints, NDArray[np.bool_], int, float]:
    """Check the cutting moves between their points where a fold may lie; insert poses.

    Returns the points, the kept mask, the number of poses inserted and their largest
    lift, mm.

    The checks at the points and the chord check (which measures the gap to the surface
    next to the move, found from the parameters between its ends) do not see a sharp
    fold between a move's contacts (a blunt base meeting the flank, a crease): the
    cutter at each end sits on one face, and the straight move between them cuts the
    edge by up to ``R (1 - cos(theta / 2))`` (``theta`` the normals' turn). Moves whose
    contacts' normals turn that far (:data:`FOLD_SCREEN_SHARE`), convex (the normals part
    along the move: ``(n_b - n_a) . (x_b - x_a) > 0``), or whose ends have another
    part of the surface within the clearance horizon (``near_other``) are sampled
    (:func:`_deepest`); one that cuts deeper than the chord tolerance along the surface's
    normal (:func:`_normal_depth`) gets the pose at its deepest place inserted, lifted
    along its axis until it stands within ``tol^2 / 2R`` of the surface (a ball that close
    to a fold cuts its far face no deeper than ``tol``; :func:`~.avoid.lift_gouges`: the
    cutter rolls round the edge), and its two parts are checked again, for
    :data:`FOLD_ROUNDS` rounds. A move is held to the chord tolerance beyond the deeper
    of the gouges accepted at its ends (``accepted_mm``: within ``gouge_tol_mm``). Where
    no lift clears (a wall along a fixed axis) or the
    rounds run out, 3-axis leaves the move's ends uncut (as shadowed), 5-axis raises a
    GougeError naming the move.
    """
    tol = res.planned_chord_tol_mm
    lift_tol = min(opts.gouge_tol_mm, 0.5 * tol * tol / (2.0 * cutter.radius_mm))
    n_fold_points, max_fold_lift_mm = 0, 0.0
    fixed = opts.axis_mode is AxisMode.FIXED
    a_i = _fold_suspects(cutter, pts, keep, near_other, tol)
    for round_ in range(FOLD_ROUNDS + 1):
        if not a_i.size:
            break
        pieces = _fold_pieces(cutter, pts, a_i, tol)
        worst, u_at, at = _deepest(cutter, pts, a_i, pieces, samples, opts.check_flutes, tol)
        depth = _normal_depth(surface, cutter, pts, a_i, u_at, worst, at, samples, tol)
        bad = depth > tol + np.maximum(accepted_mm[a_i], accepted_mm[a_i + 1])
        if not bad.any():
            break
        a_bad = a_i[bad]
        if round_ == FOLD_ROUNDS:
            if not fixed:
                k = int(np.flatnonzero(bad)[0])
                raise gouge_error(pts, int(a_i[k]), cutter, float(depth[k]),
                                  "the cutting move from there to the next point still cuts "
                                  f"that deep after {FOLD_ROUNDS} rounds of poses inserted "
                                  "into it and lifted clear (a fold of the surface); use a "
                                  "smaller cutter")
            out = np.unique(np.r_[a_bad, a_bad + 1])
            keep = keep.copy()
            keep[out] = False
            break
        pts, keep, new_at = insert_move_poses(surface, pts, keep, a_bad, u_at[bad])
        accepted_mm = np.insert(accepted_mm, new_at - np.arange(new_at.size), 0.0)
        if len(pts) > opts.max_points:
            raise too_many_points(opts, len(pts))
        # (lifted first by the sampled depth: the normal's depth at a fold is far more)
        lifted = _lift_poses(surface, cutter, pts, new_at, np.maximum(-worst[bad], 0.0),
                             samples, lift_tol, opts.check_flutes)
        stuck = lifted.stuck
        if stuck.size and not fixed:
            i = int(stuck[0])
            raise gouge_error(pts, i, cutter, float(depth[bad][np.searchsorted(new_at, i)]),
                              f"lifting the cutter {lifted.stuck_lift_mm[0]:.4f} mm along its "
                              "axis inside the move from there did not clear a fold of the "
                              "surface; use a smaller cutter")
        pts = with_tips(pts, pts.axes, lifted.tips)
        n_fold_points += int(new_at.size - stuck.size)
        max_fold_lift_mm = max(max_fold_lift_mm, float(lifted.lift_mm.max()))
        if stuck.size:  # a wall along the fixed axis: the move cannot be cut
            out = np.unique(np.r_[stuck - 1, stuck, stuck + 1])
            keep[out] = False
        near = np.unique(np.r_[new_at - 1, new_at])
        a_i = near[keep[near] & keep[near + 1] & pts.same_pass[near]]
    if n_fold_points:
        pts = with_rate_record(cutter, pts)
    return pts, keep, n_fold_points, max_fold_lift_mm


def _fold_suspects(cutter: Cutter, pts: PassPoints, keep: NDArray[np.bool_],
                   near_other: NDArray[np.bool_], tol_mm: float) -> NDArray[np.int64]:
    """The cutting moves ``a -> a + 1`` a fold may cut (:func:`fold_moves`), their ``a``.

    Those whose contacts' normals turn, beyond what their curvature along the pass
    explains (the chord check's business), by enough for the straight move to dip
    :data:`FOLD_SCREEN_SHARE` of ``tol_mm`` into the edge, and convex (the normals part
    along the move: a concave turn the cutter bridges, its ends' checks see the walls);
    and those with another part of the surface near an end (``near_other``).
    """
    a_i = np.flatnonzero(keep[:-1] & keep[1:] & pts.same_pass)
    cos = np.einsum("ij,ij->i", pts.frame.normal[a_i], pts.frame.normal[a_i + 1])
    turn = np.arccos(np.clip(cos, -1.0, 1.0))
    chord = np.linalg.norm(pts.frame.point[a_i + 1] - pts.frame.point[a_i], axis=1)
    bend = np.maximum(np.abs(pts.frame.s11[a_i]), np.abs(pts.frame.s11[a_i + 1]))
    unexplained = np.maximum(turn - FOLD_CURVATURE_MARGIN * chord * bend, 0.0)
    dip = cutter.radius_mm * (1.0 - np.cos(0.5 * unexplained))
    parting = np.einsum("ij,ij->i", pts.frame.normal[a_i + 1] - pts.frame.normal[a_i],
                        pts.frame.point[a_i + 1] - pts.frame.point[a_i]) > 0.0
    return a_i[((dip > FOLD_SCREEN_SHARE * tol_mm) & parting) | near_other[a_i]
               | near_other[a_i + 1]]


def _scatter(values: NDArray[np.float64], idx: NDArray[np.int64], n: int
             ) -> NDArray[np.float64]:
    out = np.full(n, np.inf)
    out[idx] = values
    return out


def check_links(path: Toolpath, cutter: Cutter, samples: SurfaceSamples,
                opts: FinishingOptions, res: PlannedOptions) -> None:
    """Check non-cutting positions, and points a cutter radius apart along those moves.

    Every toolpath point, and every point inside a rapid or plunge, must clear the surface
    (``gouge_tol_mm``); inside a feed move (lead arc chord, link) the cutter may dip as far
    as along a pass (the planned chord tolerance, ``res.planned_chord_tol_mm``: the
    request less the G-code's rounding, which moves these points as it moves the passes').
    A gouge there is an error, whatever ``on_gouge``.
    """
    kinds = path.kinds
    pos, ax = path.positions_mm, path.tool_axes
    moves = np.flatnonzero(kinds[1:] != MoveKind.CUT) + 1
    if not moves.size:
        return
    a, b = pos[moves - 1], pos[moves]
    length = np.linalg.norm(b - a, axis=1)
    pieces = np.maximum(np.ceil(length / cutter.radius_mm).astype(np.int64), 1)
    owner = np.repeat(np.arange(moves.size), pieces)
    first = np.r_[0, np.cumsum(pieces)[:-1]]
    step = np.arange(pieces.sum()) - first[owner] + 1
    pts, axes = move_poses(a[owner], ax[moves - 1][owner], b[owner], ax[moves][owner],
                           step / pieces[owner])
    clr = global_clearance(cutter, pts, axes, samples, flutes=opts.check_flutes)
    feed = ~np.isin(kinds[moves][owner], (MoveKind.RAPID, MoveKind.PLUNGE))
    inside = step < pieces[owner]
    allowed = np.where(feed & inside, res.planned_chord_tol_mm, opts.gouge_tol_mm)
    bad = clr.min_mm < -allowed
    if bad.any():
        j = int(np.flatnonzero(bad)[0])
        i = int(moves[owner[j]])
        kind = MoveKind(int(kinds[i])).name
        raise gouge_error_link(i, kind, -float(clr.min_mm[j]), pts[j])


def gouge_error_link(i: int, kind: str, depth: float, where: NDArray[np.float64]) -> Exception:
    """A GougeError for a linking move (names the toolpath point and the move kind)."""
    return GougeError(
        f"the {kind} move arriving at toolpath point {i} would cut {depth_text(depth)} into "
        f"the surface near ({where[0]:.3f}, {where[1]:.3f}, {where[2]:.3f}) mm; increase "
        "--clearance or --approach, or reduce --lead-radius", point_index=i,
        depth_mm=depth)


def machine_stage(path: Toolpath, mach: Machine, opts: FinishingOptions) -> MachineStats:
    """Joints, travel and rate violations and the time; raises on travel when asked.

    The joints are those ``path`` carries (:func:`~toolpath.joint_refine.with_solved_joints`),
    else solved here.
    """
    sol = path_joints(path, mach)
    travel = check_travel(mach, sol.joints)
    feeds = path.feeds_mm_per_min[1:]
    lengths = path.segment_lengths_mm
    limit_s = min_segment_times(mach, sol.joints)
    with np.errstate(divide="ignore", invalid="ignore"):
        durations = np.where(feeds > 0.0, 60.0 * lengths / np.where(feeds > 0, feeds, 1.0),
                             limit_s)
    rates = check_rates(mach, sol.joints, durations)
    if travel and opts.on_limit is OnLimit.RAISE:
        i = travel[0].index
        where = (f"toolpath point {i} ({MoveKind(int(path.kinds[i])).name}"
                 + (f", pass {int(path.pass_index[i])}" if path.pass_index[i] >= 0 else "")
                 + f", tip {np.round(path.positions_mm[i], 3).tolist()} mm in the workpiece "
                 f"frame); {_travel_remedy(path, mach)}")
        raise PlanTravelLimitError(travel, where)
    time_s = float(np.maximum(durations, limit_s).sum())
    return MachineStats(name=mach.name, travel=tuple(travel), rates=tuple(rates),
                        time_s=time_s)


def _travel_remedy(path: Toolpath, mach: Machine) -> str:
    """What to do about a travel violation: where the part fits, or which limit binds."""
    fit = fit_travel(mach, path.positions_mm, path.tool_axes,
                     split_moves=path.kinds[1:] != MoveKind.RAPID)
    if fit.fits:
        d = fit.offset_mm
        return (f"the path fits with the part {fit.describe_offset()}: add "
                f"--translate {d[0]:.3f},{d[1]:.3f},{d[2]:.3f} to 'toolpath plan' and "
                "'toolpath verify' ('toolpath run' places the part itself), or plan with "
                "--on-limit report")
    if fit.binding:
        return ("no position of the part on the table keeps the path inside the travel: "
                + "; ".join(r.describe() for r in fit.binding)
                + f" (at the least overrun, the part {fit.describe_offset()}); plan with "
                "--on-limit report to see the whole path")
    return ("a rotary axis leaves its travel, which moving the part cannot change: set the "
            "part up another way (--rotate), change --lead/--tilt, or plan with "
            "--on-limit report")
