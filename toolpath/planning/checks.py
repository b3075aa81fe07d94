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

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from machines import Machine
from machines.kinematics import solve_inverse
from machines.limits import Violation, check_rates, check_travel, min_segment_times

from ..path import MoveKind, Toolpath
from ..surface import ParametricSurface
from .avoid import (
    depth_text,
    gouge_error,
    lift_gouges,
    local_depth_mm,
    measured_depth,
    retilt_gouges,
)
from .cutters import Cutter
from .errors import GougeError, PlanTravelLimitError
from .gouge import Clearance, SurfaceSamples, global_clearance, local_margin
from .options import AxisMode, FinishingOptions, OnGouge, OnLimit, PlannedOptions
from .passes import PassPoints, frame_take, with_tips
from .travel import fit_travel

__all__ = ["GougeStats", "MachineStats", "check_links", "gouge_stage", "machine_stage"]


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
    """

    n_lifted: int = 0
    max_lift_mm: float = 0.0
    n_retilted: int = 0
    min_clearance_mm: float = float("inf")


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
    (``res.planned_chord_tol_mm``, :func:`_lifted_moves`).
    """
    tol = opts.gouge_tol_mm
    idx = np.flatnonzero(keep)
    rows = slice(None) if idx.size == len(pts) else idx  # (every point kept: no copies)
    clr = global_clearance(cutter, pts.tips[rows], pts.axes[rows], samples,
                           contacts_mm=pts.frame.point[rows], flutes=opts.check_flutes)
    n_lifted, max_lift_mm, n_retilted = 0, 0.0, 0
    far_bad = clr.far_mm < -tol
    if opts.axis_mode is AxisMode.FIXED and far_bad.any():
        # the fixed axis cannot get there without the tool hitting the part elsewhere
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
    near_bad = depth > tol
    bad = (near_bad | far_bad) & keep[idx]
    if bad.any():
        where = idx[bad]
        if opts.on_gouge is OnGouge.RAISE:
            k = int(np.flatnonzero(bad)[0])
            raise _gouge_error(surface, cutter, pts, int(idx[k]), clr, k, samples,
                               far=bool(far_bad[k]))
        if opts.on_gouge is OnGouge.LIFT:
            found = _scatter(np.maximum(depth, -clr.far_mm), idx, len(pts))
            fixed = opts.axis_mode is AxisMode.FIXED
            curved_all = np.zeros(len(pts), dtype=bool)
            curved_all[idx] = curved
            tips, lift, stuck = lift_gouges(surface, cutter, pts, where, found, samples,
                                            curved=curved_all, tol_mm=tol,
                                            flutes=opts.check_flutes, drop=fixed)
            pts = with_tips(pts, pts.axes, tips)
            if stuck.size:
                # a wall along the fixed axis: no lift clears it, the tool cannot cut there
                keep = keep.copy()
                keep[stuck] = False
            lifted = np.setdiff1d(where, stuck)
            keep, _ = _lifted_moves(cutter, pts, keep, lifted, samples, opts,
                                    res.planned_chord_tol_mm)
            n_lifted, max_lift_mm = int(keep[lifted].sum()), float(lift.max())
        else:
            axes, tips, moved = retilt_gouges(
                surface, cutter, pts, where, samples, lead_deg=opts.lead_deg,
                tilt_deg=opts.tilt_deg, min_cone_deg=opts.min_cone_deg, tol_mm=tol,
                flutes=opts.check_flutes)
            pts = with_tips(pts, axes, tips)
            n_retilted = moved
    # clearance for the report, after the fixes (without any, the first check stands for
    # the points still kept)
    if bad.any():
        idx = np.flatnonzero(keep)
        final = global_clearance(cutter, pts.tips[idx], pts.axes[idx], samples,
                                 contacts_mm=pts.frame.point[idx], flutes=opts.check_flutes)
        far_mm = final.far_mm
    else:
        far_mm = clr.far_mm[keep[idx]]
    return pts, keep, GougeStats(
        n_lifted=n_lifted, max_lift_mm=max_lift_mm, n_retilted=n_retilted,
        min_clearance_mm=float(far_mm.min()) if far_mm.size else float("inf"))


#: Normals sampled between a contact and the deepest point of its gouge (to tell a fold).
FOLD_SAMPLES = 257

#: Remedies named in gouge messages (command-line flags; the API's ``on_gouge`` and
#: ``gouge_tol_mm`` take the same values).
LIFT_REMEDY = "--on-gouge lift (lifts the cutter clear, leaving material there)"


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
        cause = (f"the surface's concave radius there is {radius:.4f} mm, smaller than the "
                 f"cutter (radius {cutter.radius_mm:g} mm); use a cutter of radius < "
                 f"{radius:.3f} mm, " + remedy)
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
                  chord_tol_mm: float) -> tuple[NDArray[np.bool_], int]:
    """Check the cutting moves once points were lifted; returns ``keep`` and drops.

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
    dropped = 0
    if not lifted.size:
        return keep, dropped
    for _ in range(LIFTED_MOVE_ROUNDS):
        a_i = np.flatnonzero(keep[:-1] & keep[1:] & pts.same_pass)
        b_i = a_i + 1
        if not a_i.size:
            break
        a, b = pts.tips[a_i], pts.tips[b_i]
        pieces = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) * LIFTED_MOVE_POINTS_PER_MM)
                            .astype(np.int64), LIFTED_MOVE_MIN_POINTS)
        owner = np.repeat(np.arange(a_i.size), pieces)
        first = np.r_[0, np.cumsum(pieces)[:-1]]
        u = ((np.arange(pieces.sum()) - first[owner] + 1) / (pieces[owner] + 1))[:, None]
        along = a[owner] * (1 - u) + b[owner] * u
        axes = pts.axes[a_i][owner] * (1 - u) + pts.axes[b_i][owner] * u
        axes /= np.linalg.norm(axes, axis=1, keepdims=True)
        clr = global_clearance(cutter, along, axes, samples, flutes=opts.check_flutes)
        worst = np.full(a_i.size, np.inf)
        np.minimum.at(worst, owner, clr.min_mm)
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
        dropped += int(out.size)
    return keep, dropped


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
    u = (step / pieces[owner])[:, None]
    pts = a[owner] * (1 - u) + b[owner] * u
    axes = ax[moves - 1][owner] * (1 - u) + ax[moves][owner] * u
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
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
    """Joints, travel and rate violations and the time; raises on travel when asked."""
    sol = solve_inverse(mach, path.positions_mm, path.tool_axes)
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
