"""Checks of a finishing plan: gouges at the cutter locations, linking moves, machine.

* :func:`gouge_stage`: the local (curvature) and global (samples) gouge checks of the cut
  points, then ``on_gouge`` (3-axis: points whose tool would hit another part of the
  surface are not reachable, they are dropped and reported as shadowed);
* :func:`check_links`: every non-cutting position, and points a cutter radius apart along
  the linking moves, must clear the surface;
* :func:`machine_stage`: inverse kinematics, travel (raise or report) and rate limits,
  time at the rate limits.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from machines import Machine
from machines.kinematics import solve_inverse
from machines.limits import check_rates, check_travel, min_segment_times

from ..path import MoveKind, Toolpath
from ..surface import ParametricSurface
from .avoid import gouge_depth_mm, gouge_error, lift_gouges, local_depth_mm, retilt_gouges
from .cutters import Cutter
from .errors import GougeError, PlanTravelLimitError
from .gouge import SurfaceSamples, global_clearance
from .options import AxisMode, FinishingOptions, OnGouge, OnLimit
from .passes import PassPoints, with_tips
from .travel import fit_travel

__all__ = ["check_links", "gouge_stage", "machine_stage"]


def gouge_stage(surface: ParametricSurface, cutter: Cutter, opts: FinishingOptions,
                 res: dict[str, float], pts: PassPoints, keep: NDArray[np.bool_],
                 samples: SurfaceSamples) -> tuple[PassPoints, NDArray[np.bool_],
                                                   dict[str, Any]]:
    """Local and global gouge checks on the kept points, then ``on_gouge``."""
    tol = opts.gouge_tol_mm
    idx = np.flatnonzero(keep)
    rows = slice(None) if idx.size == len(pts) else idx  # (every point kept: no copies)
    clr = global_clearance(cutter, pts.tips[rows], pts.axes[rows], samples,
                           contacts_mm=pts.frame.point[rows], flutes=opts.check_flutes)
    depth = local_depth_mm(pts.frame, cutter, pts.axes)
    stats: dict[str, Any] = {"n_lifted": 0, "max_lift_mm": 0.0, "n_retilted": 0}
    far_bad = clr.far_mm < -tol
    if opts.axis_mode is AxisMode.FIXED and far_bad.any():
        # the fixed axis cannot get there without the tool hitting the part elsewhere
        keep = keep.copy()
        keep[idx[far_bad]] = False
        stats["shadowed"] = int(far_bad.sum())
        far_bad = np.zeros_like(far_bad)
    near_bad = (clr.near_mm < -tol) | (depth[idx] > tol)
    bad = (near_bad | far_bad) & keep[idx]
    if bad.any():
        where = idx[bad]
        if opts.on_gouge is OnGouge.RAISE:
            i = int(where[0])
            k = int(np.flatnonzero(bad)[0])
            sample = clr.far_sample[k] if far_bad[k] else clr.near_sample[k]
            kmax = float(pts.frame.max_concave_curvature[i])
            if far_bad[k]:
                cause = (f"the cutter hits the surface at t={samples.t[sample]:.5f}, "
                         f"s={samples.s[sample]:.5f} (another part of the surface); "
                         "re-tilt (on_gouge='retilt') or change lead/tilt")
                amount = -float(clr.far_mm[k])
            else:
                radius = 1.0 / kmax if kmax > 0 else float("inf")
                cause = (f"the surface's concave radius there is {radius:.4f} mm, smaller "
                         f"than the cutter (radius {cutter.radius_mm:g} mm); use a cutter "
                         f"of radius < {radius:.3f} mm, or on_gouge='lift'")
                amount = gouge_depth_mm(surface, cutter, float(pts.t[i]), float(pts.s[i]),
                                        pts.axes[i])
            raise gouge_error(pts, i, cutter, amount, cause)
        clr_all = type(clr)(
            near_mm=_scatter(clr.near_mm, idx, len(pts)), far_mm=_scatter(clr.far_mm, idx,
                                                                          len(pts)),
            near_sample=np.zeros(len(pts), dtype=np.int64),
            far_sample=np.zeros(len(pts), dtype=np.int64))
        if opts.on_gouge is OnGouge.LIFT:
            tips, lift = lift_gouges(cutter, pts, where, clr_all, depth, samples, tol_mm=tol,
                                     flutes=opts.check_flutes)
            pts = with_tips(pts, pts.axes, tips)
            stats["n_lifted"], stats["max_lift_mm"] = int(where.size), float(lift.max())
        else:
            axes, tips, moved = retilt_gouges(
                cutter, pts, where, samples, lead_deg=opts.lead_deg, tilt_deg=opts.tilt_deg,
                min_cone_deg=opts.min_cone_deg, tol_mm=tol, flutes=opts.check_flutes)
            pts = with_tips(pts, axes, tips)
            stats["n_retilted"] = moved
    # clearance for the report, after the fixes (without any, the first check stands for
    # the points still kept)
    if bad.any():
        idx = np.flatnonzero(keep)
        final = global_clearance(cutter, pts.tips[idx], pts.axes[idx], samples,
                                 contacts_mm=pts.frame.point[idx], flutes=opts.check_flutes)
        far_mm, near_mm = final.far_mm, final.near_mm
    else:
        still = keep[idx]
        far_mm, near_mm = clr.far_mm[still], clr.near_mm[still]
    stats["min_clearance_mm"] = float(far_mm.min()) if far_mm.size else float("inf")
    stats["min_contact_clearance_mm"] = float(near_mm.min()) if near_mm.size else 0.0
    return pts, keep, stats


def _scatter(values: NDArray[np.float64], idx: NDArray[np.int64], n: int
             ) -> NDArray[np.float64]:
    out = np.full(n, np.inf)
    out[idx] = values
    return out


def check_links(path: Toolpath, cutter: Cutter, samples: SurfaceSamples,
                 opts: FinishingOptions) -> None:
    """Check non-cutting positions, and points a cutter radius apart along those moves.

    Every toolpath point, and every point inside a rapid or plunge, must clear the surface
    (``gouge_tol_mm``); inside a feed move (lead arc chord, link) the cutter may dip as far
    as along a pass (``chord_tol_mm``). A gouge there is an error, whatever ``on_gouge``.
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
    allowed = np.where(feed & inside, opts.chord_tol_mm, opts.gouge_tol_mm)
    bad = clr.min_mm < -allowed
    if bad.any():
        j = int(np.flatnonzero(bad)[0])
        i = int(moves[owner[j]])
        kind = MoveKind(int(kinds[i])).name
        raise gouge_error_link(i, kind, -float(clr.min_mm[j]), pts[j])


def gouge_error_link(i: int, kind: str, depth: float, where: NDArray[np.float64]) -> Exception:
    """A GougeError for a linking move (names the toolpath point and the move kind)."""
    return GougeError(
        f"the {kind} move arriving at toolpath point {i} would cut {depth:.4f} mm into the "
        f"surface near ({where[0]:.3f}, {where[1]:.3f}, {where[2]:.3f}) mm; increase "
        "clearance_mm or approach_mm, or reduce lead_radius_mm", point_index=i,
        depth_mm=depth)


def machine_stage(path: Toolpath, mach: Machine, opts: FinishingOptions
                   ) -> dict[str, Any]:
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
    return {"travel": tuple(travel), "rates": tuple(rates), "time_s": time_s,
            "name": mach.name}


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
