"""What to do with gouging cutter locations: raise, lift or re-tilt (``on_gouge``).

A location gouges where the depth it actually sinks into the surface exceeds the gouge
tolerance: the sample check's depth, or where the curvature says it may (a concave radius
smaller than the cutter at the contact), the depth measured round the contact
(:func:`gouge_depth_mm`). A concave radius alone decides nothing: a ripple narrower than
the data spacing costs a fraction of a micrometre.

* **raise**: :class:`~toolpath.planning.errors.GougeError` naming the first offending point
  in cutting order (pass, point within the pass, ``(t, s)``, contact in mm), the depth and
  its cause: a concave radius smaller than the cutter, or a collision with another part of
  the surface.
* **lift**: the cutter moves up its axis by the measured penetration (the larger of the
  sample check's depth and the measured depth round the contact), re-checked (both) until
  clear (at most :data:`LIFT_ROUNDS` rounds). Material is left there; the report counts it.
* **re-tilt** (5-axis): lead/tilt offsets of 5, 10, ... 30 deg (lead first, both signs) are
  tried at the offending points; the first that passes both checks is kept.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..surface import ParametricSurface
from .cutters import Cutter
from .errors import GougeError
from .gouge import SurfaceSamples, global_clearance, local_margin
from .local import PassFrame
from .passes import PassPoints, frame_take
from .tool_axis import keep_out_of_cone, lead_tilt_axes

__all__ = ["GougeDepth", "Lifted", "depth_text", "gouge_depth_mm", "gouge_error",
           "lift_gouges", "lift_until_clear", "local_depth_mm", "measured_depth",
           "retilt_gouges"]

_RETILT_STEPS_DEG = (5.0, 10.0, 15.0, 20.0, 25.0, 30.0)


def local_depth_mm(frame: PassFrame, cutter: Cutter, axes: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
    """Curvature gouge depth estimate ``max(-margin, 0) R^2 / 2``, mm.

    Where the surface out-curves the cutter by ``-margin`` (1/mm), the two parts within
    the cutter's reach ``R`` of the contact by about that much.
    """
    margin = local_margin(frame, cutter, axes)
    return np.maximum(-margin, 0.0) * cutter.radius_mm**2 / 2.0


#: The local gouge search (:func:`gouge_depth_mm`): a first grid of :data:`DEPTH_FIRST`
#: squared points over the cutter's whole reach (``2 R`` round the contact, where the far
#: side of a ball's sphere can still meet the surface), then :data:`DEPTH_CHAINS` searches
#: from the contact and from the first grid's points nearest to cutting (deepest, or least
#: clear), each refined :data:`DEPTH_LEVELS` times on a :data:`DEPTH_REFINE` square grid
#: one spacing of the previous grid wide round its deepest point so far: 4 R / 24 / 4^7 =
#: 0.00003 mm for a 6 mm ball, far finer than the nose spacing of a CAD export (0.01 -
#: 0.03 mm), so a concave ripple between two points is seen.
DEPTH_FIRST = 25
DEPTH_REFINE = 9
DEPTH_LEVELS = 7
DEPTH_CHAINS = 4
#: Surface evaluations per batch of the search (memory: about 100 bytes each).
_DEPTH_BATCH = 2_000_000
#: Floor of the surface's speed (mm per unit parameter) where a search window's half-width
#: in the parameter is ``reach / speed``: at a pole (a section collapsed to a point) the
#: speed is round-off; the floor keeps the width finite, and the window is clipped to the
#: domain.
_LEAST_SPEED_MM = 1e-12


@dataclass(frozen=True)
class GougeDepth:
    """The deepest penetration of each cutter location into the surface round its contact.

    Attributes
    ----------
    depth_mm : ndarray, shape (n,)
        ``max(-signed distance, 0)`` over the searched surface points, mm.
    t, s : ndarray, shape (n,)
        Surface parameters of the deepest point (the contact's where nothing is inside).
    """

    depth_mm: NDArray[np.float64]
    t: NDArray[np.float64]
    s: NDArray[np.float64]


def gouge_depth_mm(surface: ParametricSurface, cutter: Cutter, t: ArrayLike, s: ArrayLike,
                   tips_mm: ArrayLike, axes: ArrayLike, *, speed_t: ArrayLike,
                   speed_s: ArrayLike, stop_mm: float | None = None) -> GougeDepth:
    """How deep each cutter location sinks into the surface round its contact, mm.

    A measurement, where :func:`local_depth_mm` is only the second-order estimate: the
    largest ``-d`` over surface points ``X(t', s')``, ``d`` the cutter solid's exact signed
    distance (:meth:`~toolpath.planning.cutters.Cutter.signed_distance`) at the location
    ``(tips_mm, axes)``, searched coarse to fine in the parameter box ``|t' - t| <=
    2 R / |X_t|``, ``|s' - s| <= 2 R / |X_s|`` (the speeds at the contact; ``t'`` wraps
    round closed sections, both are clipped to [0, 1] otherwise), see :data:`DEPTH_FIRST`.
    A concave radius ``rho < R`` at the contact costs ``(1/rho - 1/R) w^2 / 2`` over a
    concave stretch ``w`` wide: a ripple narrower than the data spacing costs next to
    nothing, a pocket its full depth; this tells the two apart.

    Parameters
    ----------
    t, s, speed_t, speed_s : array_like, shape (n,)
        The contacts' parameters and ``|X_t|``, ``|X_s|`` there (mm per unit).
    tips_mm, axes : array_like, shape (n, 3)
        The cutter locations and unit axes.
    stop_mm : float, optional
        Stop refining a location once it is found deeper than this (its depth is then a
        lower bound above ``stop_mm``): enough to decide.
    """
    t, s = np.asarray(t, dtype=float), np.asarray(s, dtype=float)
    tips, axes = np.asarray(tips_mm, dtype=float), np.asarray(axes, dtype=float)
    n = t.size
    reach = 2.0 * cutter.radius_mm
    half_t = reach / np.maximum(np.asarray(speed_t, dtype=float), _LEAST_SPEED_MM)
    half_s = reach / np.maximum(np.asarray(speed_s, dtype=float), _LEAST_SPEED_MM)
    closed = bool(surface.closed_t)

    def search(rows: NDArray[np.int64], ct: NDArray[np.float64], cs: NDArray[np.float64],
               ht: NDArray[np.float64], hs: NDArray[np.float64], size: int, keep: int
               ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The ``keep`` largest penetrations on each row's grid, and where (rows x keep)."""
        u = np.linspace(-1.0, 1.0, size)
        per = size * size
        step = max(_DEPTH_BATCH // per, 1)
        value = np.empty((rows.size, keep))
        at_t, at_s = np.empty_like(value), np.empty_like(value)
        for lo in range(0, rows.size, step):
            r, cut = rows[lo:lo + step], slice(lo, lo + step)
            tt = ct[cut, None, None] + ht[cut, None, None] * u[None, :, None]
            ss = cs[cut, None, None] + hs[cut, None, None] * u[None, None, :]
            tt, ss = np.broadcast_arrays(tt, ss)
            tt = (np.mod(tt, 1.0) if closed else np.clip(tt, 0.0, 1.0)).reshape(r.size, per)
            ss = np.clip(ss, 0.0, 1.0).reshape(r.size, per)
            pts = surface(tt.ravel(), ss.ravel()).reshape(r.size, per, 3)
            pen = -cutter.signed_distance(pts, tips[r, None], axes[r, None])
            top = np.argsort(-pen, axis=1)[:, :keep]
            value[cut] = np.take_along_axis(pen, top, axis=1)
            at_t[cut] = np.take_along_axis(tt, top, axis=1)
            at_s[cut] = np.take_along_axis(ss, top, axis=1)
        return value, at_t, at_s

    # the first grid; the chains start at the contact and its best points
    v0, t0, s0 = search(np.arange(n), t, s, half_t, half_s, DEPTH_FIRST, DEPTH_CHAINS - 1)
    owner = np.repeat(np.arange(n), DEPTH_CHAINS)
    c_val = np.c_[np.zeros(n), v0].ravel()
    c_t, c_s = np.c_[t, t0].ravel(), np.c_[s, s0].ravel()
    ht = np.repeat(2.0 * half_t / (DEPTH_FIRST - 1), DEPTH_CHAINS)
    hs = np.repeat(2.0 * half_s / (DEPTH_FIRST - 1), DEPTH_CHAINS)
    active = np.arange(owner.size)
    for _ in range(DEPTH_LEVELS):
        if stop_mm is not None:
            deepest = np.full(n, -np.inf)
            np.maximum.at(deepest, owner, c_val)
            active = active[deepest[owner[active]] <= stop_mm]
        if not active.size:
            break
        v, vt, vs = search(owner[active], c_t[active], c_s[active], ht[active], hs[active],
                           DEPTH_REFINE, 1)
        better = v[:, 0] > c_val[active]
        moved = active[better]
        c_val[moved], c_t[moved], c_s[moved] = v[better, 0], vt[better, 0], vs[better, 0]
        ht, hs = 2.0 * ht / (DEPTH_REFINE - 1), 2.0 * hs / (DEPTH_REFINE - 1)
    pick = np.argmax(c_val.reshape(n, DEPTH_CHAINS), axis=1) + np.arange(n) * DEPTH_CHAINS
    best = np.maximum(c_val[pick], 0.0)
    inside = c_val[pick] > 0.0
    best_t, best_s = np.where(inside, c_t[pick], t), np.where(inside, c_s[pick], s)
    return GougeDepth(depth_mm=best, t=best_t, s=best_s)


def depth_text(depth_mm: float) -> str:
    """A depth for a message: 4 decimals (mm), 6 below a micrometre (never "0.0000")."""
    return f"{depth_mm:.4f} mm" if depth_mm >= 0.001 else f"{depth_mm:.6f} mm"


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
        f"cut {depth_text(depth_mm)} into the surface; {cause}",
        pass_index=int(pts.pid[i]), point_index=j, t=float(pts.t[i]), s=float(pts.s[i]),
        depth_mm=float(depth_mm))


#: Lift rounds: each lifts by the depth still found; near a wall steeper than the axis a
#: round clears less than it lifts, so a few dozen may be needed.
LIFT_ROUNDS = 30


@dataclass(frozen=True, eq=False)
class Lifted:
    """Poses lifted along their axes until clear (:func:`lift_until_clear`).

    Attributes
    ----------
    tips : ndarray, shape (n, 3)
        All tips, the cleared ones lifted (the stuck ones put back).
    lift_mm : ndarray, shape (n,)
        Lift of each pose (0 where untouched or stuck).
    stuck : ndarray of int
        The poses no lift cleared.
    stuck_depth_mm, stuck_lift_mm : ndarray, shape (len(stuck),)
        The depth still found at each in the last round, and how far it was lifted.
    """

    tips: NDArray[np.float64]
    lift_mm: NDArray[np.float64]
    stuck: NDArray[np.int64]
    stuck_depth_mm: NDArray[np.float64]
    stuck_lift_mm: NDArray[np.float64]


def lift_until_clear(tips_mm: NDArray[np.float64], axes: NDArray[np.float64],
                     idx: NDArray[np.int64], first_mm: NDArray[np.float64], tol_mm: float,
                     depth_at: Callable[[NDArray[np.int64], NDArray[np.float64]],
                                        NDArray[np.float64]]) -> Lifted:
    """Lift poses ``idx`` along their axes until within ``tol_mm`` of the surface.

    Each round lifts a pose by the depth found (``first_mm`` per pose of ``idx`` before
    the first round, then ``depth_at(rows, tips)``: the depth of poses ``rows`` with those
    tips) plus ``tol_mm``, and checks again; a pose still deeper than ``tol_mm`` after
    :data:`LIFT_ROUNDS` rounds (a wall nearly parallel to the axis, which no lift clears)
    is put back where it was and returned as stuck.
    """
    tips = tips_mm.copy()
    lift = np.zeros(len(tips))
    todo = np.asarray(idx)
    step = first_mm + tol_mm
    worst = np.zeros(0)
    for _ in range(LIFT_ROUNDS):
        tips[todo] += step[:, None] * axes[todo]
        lift[todo] += step
        worst = depth_at(todo, tips[todo])
        still = worst > tol_mm
        todo, step, worst = todo[still], worst[still] + tol_mm, worst[still]
        if not todo.size:
            break
    tried = lift[todo]
    tips[todo] -= tried[:, None] * axes[todo]
    lift[todo] = 0.0
    return Lifted(tips, lift, todo, worst, tried)


def lift_gouges(surface: ParametricSurface, cutter: Cutter, pts: PassPoints,
                idx: NDArray[np.int64], depth_mm: NDArray[np.float64],
                samples: SurfaceSamples, *, curved: NDArray[np.bool_], tol_mm: float,
                flutes: bool, drop: bool = False
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """Lift the cutter at points ``idx`` along its axis until clear (:func:`lift_until_clear`).

    ``depth_mm`` (all points) is the depth found at each (the larger of the sample check's
    and :func:`gouge_depth_mm`'s); after each lift the sample check is made again, and the
    measurement where ``curved`` (all points) says the curvature at the
    contact out-curves the cutter (elsewhere the samples see what it would). A point
    still gouging after :data:`LIFT_ROUNDS` (a wall nearly parallel to the axis, which no
    lift clears) raises, or with ``drop`` is returned for the caller to leave uncut.

    Returns
    -------
    tips : ndarray, shape (n, 3)
        All tips, the lifted ones moved.
    lift_mm : ndarray, shape (n,)
        Lift of each point (0 where untouched).
    stuck : ndarray of int
        The points no lift cleared (empty unless ``drop``).
    """
    def depth_at(rows: NDArray[np.int64], tips: NDArray[np.float64]) -> NDArray[np.float64]:
        worst = -global_clearance(cutter, tips, pts.axes[rows], samples, flutes=flutes).min_mm
        near = np.flatnonzero((worst <= tol_mm) & curved[rows])
        if near.size:
            worst[near] = measured_depth(surface, cutter, pts, rows[near], tips[near],
                                         pts.axes[rows[near]], tol_mm).depth_mm
        return worst

    first = depth_mm[np.asarray(idx)]
    lifted = lift_until_clear(pts.tips, pts.axes, idx, np.where(np.isfinite(first), first, 0.0),
                              tol_mm, depth_at)
    if drop or not lifted.stuck.size:
        return lifted.tips, lifted.lift_mm, lifted.stuck
    raise gouge_error(pts, int(lifted.stuck[0]), cutter, float(lifted.stuck_depth_mm[0]),
                      f"lifting it {lifted.stuck_lift_mm[0]:.4f} mm along the tool axis did "
                      f"not clear it after {LIFT_ROUNDS} rounds (the surface there is nearly "
                      "parallel to the axis); use a smaller cutter, or --on-gouge retilt on a "
                      "5-axis machine")


def measured_depth(surface: ParametricSurface, cutter: Cutter, pts: PassPoints,
              rows: NDArray[np.int64], tips: NDArray[np.float64], axes: NDArray[np.float64],
              stop_mm: float | None = None) -> GougeDepth:
    """:func:`gouge_depth_mm` of locations ``(tips, axes)`` touching at points ``rows``."""
    return gouge_depth_mm(surface, cutter, pts.t[rows], pts.s[rows], tips, axes,
                          speed_t=pts.frame.speed_t[rows], speed_s=pts.frame.speed_s[rows],
                          stop_mm=stop_mm)


def retilt_gouges(surface: ParametricSurface, cutter: Cutter, pts: PassPoints,
                  idx: NDArray[np.int64],
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
        check = global_clearance(cutter, cand_tips, cand, samples, contacts_mm=frame.point,
                                 flutes=flutes)
        ok = check.min_mm >= -tol_mm
        maybe = np.flatnonzero(ok & (local_depth_mm(frame, cutter, cand) > tol_mm))
        if maybe.size:  # the curvature says it may sink in: measure it
            ok[maybe] = measured_depth(surface, cutter, pts, todo[maybe], cand_tips[maybe],
                                  cand[maybe], tol_mm).depth_mm <= tol_mm
        axes[todo[ok]] = cand[ok]
        tips[todo[ok]] = cand_tips[ok]
        moved += int(ok.sum())
        todo = todo[~ok]
    if todo.size:
        i = int(todo[0])
        rows = todo[:1]
        near = global_clearance(cutter, pts.tips[rows], pts.axes[rows], samples,
                                contacts_mm=pts.frame.point[rows], flutes=flutes).min_mm
        depth = max(float(-near[0]), float(measured_depth(
            surface, cutter, pts, rows, pts.tips[rows], pts.axes[rows]).depth_mm[0]))
        raise gouge_error(pts, i, cutter, depth,
                          "no lead/tilt change up to 30 deg clears it (a ball cannot "
                          "re-tilt out of a concave radius smaller than itself); use a "
                          "smaller cutter, or --on-gouge lift (leaves material there)")
    return axes, tips, moved
