"""What to do with gouging cutter locations: raise, lift or re-tilt (``on_gouge``).

* **raise**: :class:`~toolpath.planning.errors.GougeError` naming the first offending point
  in cutting order (pass, point within the pass, ``(t, s)``, contact in mm), the depth and
  its cause: a concave radius smaller than the cutter, or a collision with another part of
  the surface.
* **lift**: the cutter moves up its axis by the measured penetration (the larger of the
  sample check's depth and the curvature estimate ``-margin R^2 / 2``), re-checked until
  every sample is clear (at most 10 rounds). Material is left there; the report counts it.
* **re-tilt** (5-axis): lead/tilt offsets of 5, 10, ... 30 deg (lead first, both signs) are
  tried at the offending points; the first that passes both checks is kept.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..surface import ParametricSurface
from .cutters import Cutter
from .errors import GougeError
from .gouge import Clearance, SurfaceSamples, global_clearance, local_margin
from .local import PassFrame, pass_frame
from .passes import PassPoints, frame_take
from .tool_axis import keep_out_of_cone, lead_tilt_axes

__all__ = ["gouge_depth_mm", "gouge_error", "lift_gouges", "local_depth_mm", "retilt_gouges"]

_RETILT_STEPS_DEG = (5.0, 10.0, 15.0, 20.0, 25.0, 30.0)


def local_depth_mm(frame: PassFrame, cutter: Cutter, axes: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
    """Curvature gouge depth estimate ``max(-margin, 0) R^2 / 2``, mm.

    Where the surface out-curves the cutter by ``-margin`` (1/mm), the two parts within
    the cutter's reach ``R`` of the contact by about that much.
    """
    margin = local_margin(frame, cutter, axes)
    return np.maximum(-margin, 0.0) * cutter.radius_mm**2 / 2.0


def gouge_depth_mm(surface: ParametricSurface, cutter: Cutter, t: float, s: float,
                   axis: NDArray[np.float64], *, n: int = 81) -> float:
    """How deep the cutter touching at ``(t, s)`` sinks into the surface around, mm.

    The surface is sampled on an ``n x n`` parameter grid covering the cutter's radius
    around the contact and the largest penetration of the cutter solid is returned
    (0 when clear): a measurement, where :func:`local_depth_mm` is only an estimate.
    """
    frame = pass_frame(surface, np.array([t]), np.array([s]))
    reach = cutter.radius_mm * 1.2
    dt = reach / max(float(frame.speed_t[0]), 1e-12)
    ds = reach / max(float(np.linalg.norm(surface.derivative(t, s, dt=0, ds=1))), 1e-12)
    closed = bool(surface.closed_t)
    tt = np.linspace(t - dt, t + dt, n)
    tt = np.mod(tt, 1.0) if closed else np.clip(tt, 0.0, 1.0)
    ss = np.clip(np.linspace(s - ds, s + ds, n), 0.0, 1.0)
    pts = surface(tt, ss, grid=True).reshape(-1, 3)
    tip = cutter.tips_from_contacts(frame.point, frame.normal, axis[None])
    return float(max(-cutter.signed_distance(pts, tip, axis[None]).min(), 0.0))


def _point_in_pass(pts: PassPoints, i: int) -> int:
    same = np.flatnonzero(pts.pid == pts.pid[i])
    j = i - int(same[0])
    return j if pts.direction[i] > 0 else int(same.size - 1 - j)


def gouge_error(pts: PassPoints, i: int, cutter: Cutter, depth_mm: float, cause: str
                ) -> GougeError:
    """A :class:`GougeError` for point ``i`` of ``pts`` (message names pass and point)."""
    j = _point_in_pass(pts, i)
    p = pts.frame.point[i]
    return GougeError(
        f"gouge on pass {int(pts.pid[i])} point {j} (t={pts.t[i]:.5f}, s={pts.s[i]:.5f}, "
        f"contact ({p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}) mm): the {cutter.spec} cutter would "
        f"cut {depth_mm:.4f} mm into the surface; {cause}",
        pass_index=int(pts.pid[i]), point_index=j, t=float(pts.t[i]), s=float(pts.s[i]),
        depth_mm=float(depth_mm))


def lift_gouges(cutter: Cutter, pts: PassPoints, idx: NDArray[np.int64],
                clearance: Clearance, local_depth: NDArray[np.float64],
                samples: SurfaceSamples, *, tol_mm: float, flutes: bool
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lift the cutter at points ``idx`` along its axis until clear.

    Returns
    -------
    tips : ndarray, shape (n, 3)
        All tips, the lifted ones moved.
    lift_mm : ndarray, shape (n,)
        Lift of each point (0 where untouched).
    """
    tips = pts.tips.copy()
    lift = np.zeros(len(tips))
    todo = np.asarray(idx)
    depth = np.maximum(-clearance.min_mm[todo], local_depth[todo])
    depth = np.where(np.isfinite(depth), depth, 0.0) + tol_mm
    for _ in range(10):
        tips[todo] += depth[:, None] * pts.axes[todo]
        lift[todo] += depth
        check = global_clearance(cutter, tips[todo], pts.axes[todo], samples, flutes=flutes)
        worst = check.min_mm
        still = worst < -tol_mm
        todo, depth = todo[still], -worst[still] + tol_mm
        if not todo.size:
            return tips, lift
    i = int(todo[0])
    raise gouge_error(pts, i, cutter, float(depth[0]),
                      "lifting along the tool axis did not clear it after 10 rounds")


def retilt_gouges(cutter: Cutter, pts: PassPoints, idx: NDArray[np.int64],
                  samples: SurfaceSamples, *, lead_deg: float, tilt_deg: float,
                  min_cone_deg: float | None, tol_mm: float, flutes: bool
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
    """Try other lead/tilt angles at points ``idx``; returns axes, tips and how many moved.

    Raises
    ------
    GougeError
        For the first point no offset up to 30 deg clears.
    """
    axes, tips = pts.axes.copy(), pts.tips.copy()
    todo = np.asarray(idx)
    moved = 0
    offsets = [o for m in _RETILT_STEPS_DEG
               for o in ((m, 0.0), (-m, 0.0), (0.0, m), (0.0, -m))]
    for d_lead, d_tilt in offsets:
        if not todo.size:
            break
        frame = frame_take(pts.frame, todo)
        feed = pts.feed_dirs[todo]
        cand = lead_tilt_axes(frame.normal, feed, lead_deg + d_lead, tilt_deg + d_tilt)
        if min_cone_deg:
            cand, _ = keep_out_of_cone(cand, min_cone_deg, feed)
        cand_tips = cutter.tips_from_contacts(frame.point, frame.normal, cand)
        ok = local_depth_mm(frame, cutter, cand) <= tol_mm
        check = global_clearance(cutter, cand_tips, cand, samples, contacts_mm=frame.point,
                                 flutes=flutes)
        ok &= check.min_mm >= -tol_mm
        axes[todo[ok]] = cand[ok]
        tips[todo[ok]] = cand_tips[ok]
        moved += int(ok.sum())
        todo = todo[~ok]
    if todo.size:
        i = int(todo[0])
        frame = frame_take(pts.frame, todo[:1])
        depth = float(local_depth_mm(frame, cutter, pts.axes[todo[:1]])[0])
        raise gouge_error(pts, i, cutter, depth,
                          "no lead/tilt change up to 30 deg clears it (a ball cannot "
                          "re-tilt out of a concave radius smaller than itself); use a "
                          "smaller cutter or on_gouge='lift'")
    return axes, tips, moved
