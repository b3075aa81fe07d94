"""Linking cut runs into one toolpath: lead arcs, extensions, clearance, rapids, plunges.

A *run* is a stretch of one pass cut without lifting (or a chain of them that follow on
one another with no lift between: :class:`Run`). Between two runs the tool either

* continues directly (spiral rings join end to start; zig-zag and one-way runs whose
  ends are within ``link_max_mm`` and whose straight link stays on the surface get one
  ``LINK`` feed move, between the extensions past open edges when there are any), or
* lifts: lead-out arc, rapid retract to the clearance, rapid traverse, rapid down to
  ``approach_mm`` above the lead-in, ``PLUNGE`` at the plunge feed, lead-in arc.

**Lead arcs** are quarter circles (``lead_angle_deg``) of radius ``lead_radius_mm`` in the
plane of the feed direction ``f`` and the surface normal ``n`` at the run's end, tangent to
the pass: lead-out ``E + rho (sin th f + (1 - cos th) n)``, lead-in
``S + rho (-sin th f + (1 - cos th) n)``, ``th`` from 0 to the lead angle, with as many points
as the chord tolerance needs (``2 acos(1 - tol / rho)`` per step). An **extension** is a
straight ``extend_mm`` continuation of an open edge before the lead arc.

**Clearance.** With a fixed tool axis ``a`` (3-axis) the clearance is the plane
``p.a = H`` above the part (retract along ``a``, traverse in the plane). With a varying axis
it is a sphere around the part's bounding box: retract along the tool axis to the sphere,
traverse on the great circle between the two points (axis interpolated, a point every
10 deg), descend along the next tool axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..path import MoveKind
from ..tolerances import LIMIT_SLACK, NO_MEAN_AXIS
from ..vectors import unit

__all__ = ["ClearancePlane", "ClearanceSphere", "LinkOptions", "Run", "distinct_rows", "extends",
           "link_runs"]

_TRAVERSE_STEP_DEG = 10.0
#: Two directions closer than this (rad) are one: their great circle is undefined (the
#: interpolation divides by its sine), and the path stays on the one direction.
_SAME_DIRECTION_RAD = 1e-9
#: Squared distance (mm^2, 1 nm apart) below which a link point repeats the one before.
_SAME_TIP_MM2 = 1e-18
#: Least angle step (rad) of a lead arc: a tolerance far above the radius asks for one
#: step of pi/2 at most, and a step of 0 would divide by zero.
_LEAST_ARC_STEP_RAD = 1e-6


@dataclass(frozen=True)
class ClearancePlane:
    """Plane ``p . axis = height_mm`` (3-axis)."""

    axis: NDArray[np.float64]
    height_mm: float

    def retract(self, p: NDArray[np.float64], a: NDArray[np.float64]) -> NDArray[np.float64]:
        """Point of the plane above ``p`` along the fixed axis."""
        return p + (self.height_mm - float(p @ self.axis)) * self.axis

    def traverse(self, p: NDArray[np.float64], a: NDArray[np.float64], q: NDArray[np.float64],
                 b: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Intermediate points and axes from ``p`` to ``q`` (none: a straight rapid)."""
        return np.zeros((0, 3)), np.zeros((0, 3))


def _great_circle(u: NDArray[np.float64], v: NDArray[np.float64]
                  ) -> tuple[NDArray[np.float64], float]:
    """Directions from ``u`` to ``v`` on their great circle, and its angle (rad).

    Unit vectors every :data:`_TRAVERSE_STEP_DEG` at most, both ends included.
    """
    ang = float(np.arctan2(np.linalg.norm(np.cross(u, v)), u @ v))
    steps = max(int(np.ceil(np.degrees(ang) / _TRAVERSE_STEP_DEG)), 1)
    frac = np.arange(steps + 1) / steps
    if ang > _SAME_DIRECTION_RAD:
        dirs = (np.sin((1.0 - frac) * ang)[:, None] * u
                + np.sin(frac * ang)[:, None] * v) / np.sin(ang)
    else:
        dirs = np.broadcast_to(u, (frac.size, 3))
    return unit(dirs), ang


@dataclass(frozen=True)
class ClearanceSphere:
    """Sphere ``|p - centre| = radius_mm`` around the part (5-axis).

    ``up`` (unit, optional) is the side the tool works from (the mean surface normal of
    an open part): a traverse whose shorter great circle would dip below its ends (under
    the part, e.g. from one edge of a convex patch to the other) goes over the pole
    ``centre + radius_mm * up`` instead.
    """

    centre: NDArray[np.float64]
    radius_mm: float
    up: NDArray[np.float64] | None = None

    def retract(self, p: NDArray[np.float64], a: NDArray[np.float64]) -> NDArray[np.float64]:
        """Where the ray ``p + l a`` (``l >= 0``) leaves the sphere."""
        d = p - self.centre
        b = float(d @ a)
        c = float(d @ d) - self.radius_mm**2
        lam = -b + np.sqrt(max(b * b - c, 0.0))
        return p + max(lam, 0.0) * a

    def traverse(self, p: NDArray[np.float64], a: NDArray[np.float64], q: NDArray[np.float64],
                 b: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Points on the sphere from ``p`` to ``q`` every 10 deg, axes interpolated.

        On the great circle through both, or over the ``up`` pole when that circle passes
        under the part.
        """
        u, v = unit(p - self.centre), unit(q - self.centre)
        dirs, _ = _great_circle(u, v)
        if self.up is not None and (dirs @ self.up).min() < min(u @ self.up,
                                                                v @ self.up) - LIMIT_SLACK:
            first, ang1 = _great_circle(u, self.up)
            second, ang2 = _great_circle(self.up, v)
            dirs = np.concatenate([first, second[1:]])
            steps = [len(first) - 1, len(second) - 1]
            frac = np.r_[np.arange(steps[0]) / steps[0] * ang1,
                         ang1 + np.arange(steps[1] + 1) / steps[1] * ang2] / (ang1 + ang2)
        else:
            frac = np.linspace(0.0, 1.0, len(dirs))
        if len(dirs) <= 2:
            return np.zeros((0, 3)), np.zeros((0, 3))
        dirs, frac = dirs[1:-1], frac[1:-1]
        pts = self.centre + self.radius_mm * dirs
        mix = (1.0 - frac)[:, None] * a + frac[:, None] * b
        axes = unit(mix)
        bad = np.linalg.norm(mix, axis=1) < NO_MEAN_AXIS
        axes[bad] = dirs[bad]
        return pts, axes


@dataclass
class Run:
    """One stretch of a pass in cutting order, or a chain of stretches that follow on.

    Attributes
    ----------
    tips, axes : ndarray, shape (m, 3)
        Cutter locations and unit tool axes.
    pass_index : int
        The pass it belongs to (a chain: its first stretch's).
    normal_start, normal_end, feed_start, feed_end : ndarray, shape (3,)
        Surface normal and unit feed direction at the two ends (for the lead arcs).
    extend_start, extend_end : bool
        Whether the end is an open edge to extend past.
    joined : bool
        The run starts where the previous one ended (spiral): no link move.
    direct_link : bool
        The previous run may link to this one by a straight ``LINK`` move.
    point_kinds, point_passes : ndarray or None
        A chain of runs that follow on one another (joined, or linked directly with no
        extension between): each point's kind (``CUT``, ``LINK`` where a run begins; the
        first point's is the linking's) and pass. ``None`` for a single run: cuts of
        ``pass_index``.
    """

    tips: NDArray[np.float64]
    axes: NDArray[np.float64]
    pass_index: int
    normal_start: NDArray[np.float64]
    normal_end: NDArray[np.float64]
    feed_start: NDArray[np.float64]
    feed_end: NDArray[np.float64]
    extend_start: bool = False
    extend_end: bool = False
    joined: bool = False
    direct_link: bool = False
    point_kinds: NDArray[np.uint8] | None = None
    point_passes: NDArray[np.int64] | None = None


@dataclass(frozen=True)
class LinkOptions:
    """Linking geometry and feeds (validated by the planner's options)."""

    clearance: ClearancePlane | ClearanceSphere
    feed_mm_per_min: float
    plunge_feed_mm_per_min: float
    lead_radius_mm: float
    lead_angle_deg: float
    approach_mm: float
    extend_mm: float
    chord_tol_mm: float
    metadata: dict[str, str] = field(default_factory=dict)


class _Builder:
    """Accumulates points, axes, kinds, feeds and pass indices.

    Blocks are kept as added and joined once (:meth:`arrays`), where points repeating the
    position before them (zero-length moves) are dropped.
    """

    def __init__(self, feed: float, plunge: float) -> None:
        self.pts: list[NDArray[np.float64]] = []
        self.axes: list[NDArray[np.float64]] = []
        self.kinds: list[int] = []
        self.first_kinds: list[int] = []
        self.passes: list[int] = []
        self.feed, self.plunge = feed, plunge
        self.last: NDArray[np.float64] | None = None
        # blocks with a kind and pass per point: block -> (kinds, passes)
        self.per_point: dict[int, tuple[NDArray[np.uint8], NDArray[np.int64]]] = {}

    def add(self, pts: NDArray[np.float64], axes: NDArray[np.float64], kind: MoveKind,
            pass_index: int = -1, first_kind: MoveKind | None = None) -> None:
        """A block of points of one ``kind`` (its first point ``first_kind``, if given)."""
        if pts.ndim == 1:
            pts = pts[None, :]
        if not len(pts):
            return
        self.pts.append(pts)
        # (a run's own axes as they are; one axis for the block repeated, as a view)
        self.axes.append(axes if axes.shape == pts.shape else
                         np.broadcast_to(axes.reshape(-1, 3), pts.shape))
        self.kinds.append(int(kind))
        self.first_kinds.append(int(kind if first_kind is None else first_kind))
        self.passes.append(pass_index)
        self.last = pts[-1]

    def add_run(self, run: Run, first_kind: MoveKind) -> None:
        """A run's points: the first one ``first_kind`` (how the cutter gets there), cuts."""
        blocks = len(self.pts)
        self.add(run.tips, run.axes, MoveKind.CUT, run.pass_index, first_kind)
        if run.point_kinds is not None and len(self.pts) > blocks:
            # a chain: its own kinds and passes
            passes = run.point_passes if run.point_passes is not None else np.full(
                len(run.tips), run.pass_index)
            self.per_point[blocks] = (run.point_kinds, passes)

    def arrays(self) -> tuple[NDArray[np.float64], ...]:
        pts = np.concatenate(self.pts)
        axes = np.concatenate(self.axes)
        counts = np.array([len(p) for p in self.pts], dtype=np.int64)
        starts = np.cumsum(counts) - counts
        kinds = np.repeat(np.array(self.kinds, dtype=np.uint8), counts)
        passes = np.repeat(np.array(self.passes, dtype=np.int32), counts)
        for block, (block_kinds, block_passes) in self.per_point.items():
            at = slice(starts[block], starts[block] + counts[block])
            kinds[at] = block_kinds
            passes[at] = block_passes
        kinds[starts] = self.first_kinds
        kept = np.empty(len(pts), dtype=np.int64)
        m = distinct_rows(pts, axes, kept)
        pts, axes, kinds, passes = pts[:m], axes[:m], kinds[kept[:m]], passes[kept[:m]]
        feeds = np.where(kinds == MoveKind.RAPID, 0.0,
                         np.where(kinds == MoveKind.PLUNGE, self.plunge, self.feed))
        return pts, axes, kinds, feeds, passes


@numba.njit(cache=True)
def distinct_rows(pts, axes, kept):
    """Drop points repeating the one before (within 1 nm), in place; axes made unit.

    ``kept[:m]``: the indices of the ``m`` points left (returned), moved to the front.
    """
    m = 0
    for i in range(pts.shape[0]):
        if i > 0:
            d2 = 0.0
            for k in range(3):
                d2 += (pts[i, k] - pts[i - 1, k]) ** 2
            if d2 <= _SAME_TIP_MM2:
                continue
        size = math.sqrt(axes[i, 0] * axes[i, 0] + axes[i, 1] * axes[i, 1]
                         + axes[i, 2] * axes[i, 2])
        if size <= 0.0:
            size = 1.0
        for k in range(3):
            axes[m, k] = axes[i, k] / size
        kept[m] = i
        m += 1
    for j in range(m):
        if kept[j] != j:
            for k in range(3):
                pts[j, k] = pts[kept[j], k]
    return m


def _arc(centre_pt: NDArray[np.float64], f: NDArray[np.float64], n: NDArray[np.float64],
         radius: float, angle_deg: float, tol: float, *, lead_in: bool) -> NDArray[np.float64]:
    """Lead arc points (excluding the run's end itself), in travel order."""
    if radius <= 0.0 or angle_deg <= 0.0:
        return np.zeros((0, 3))
    step = 2.0 * np.arccos(max(1.0 - tol / radius, -1.0)) if tol < radius else np.pi / 2
    count = max(int(np.ceil(np.radians(angle_deg) / max(step, _LEAST_ARC_STEP_RAD))), 1)
    th = np.linspace(0.0, np.radians(angle_deg), count + 1)[1:]
    sign = -1.0 if lead_in else 1.0
    pts = centre_pt + radius * (sign * np.sin(th)[:, None] * f
                                + (1.0 - np.cos(th))[:, None] * n)
    return pts[::-1] if lead_in else pts


#: No points (read-only: shared by every run without an extension).
_NO_POINTS = np.zeros((0, 3))
_NO_POINTS.setflags(write=False)


def extends(at_edge: ArrayLike, extend_mm: float) -> NDArray[np.bool_]:
    """Whether run ends ``at_edge`` (on an open edge) get an extension ``extend_mm`` long.

    A direct link between two runs adds nothing else: runs that link directly with no
    extension between them follow on as one block (a chain, :class:`Run`).
    """
    return np.logical_and(at_edge, extend_mm > 0.0)


def _extension_before(run: Run, opt: LinkOptions) -> NDArray[np.float64]:
    """The extension's start past an open edge before the run (0 or 1 points)."""
    if extends(run.extend_start, opt.extend_mm):
        return (run.tips[0] - opt.extend_mm * run.feed_start)[None, :]
    return _NO_POINTS


def _extension_after(run: Run, opt: LinkOptions) -> NDArray[np.float64]:
    """The extension's end past an open edge after the run (0 or 1 points)."""
    if extends(run.extend_end, opt.extend_mm):
        return (run.tips[-1] + opt.extend_mm * run.feed_end)[None, :]
    return _NO_POINTS


def _approach(run: Run, opt: LinkOptions) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lead-in points (extension and arc, travel order) and the point they start from."""
    start = run.tips[0]
    line = _extension_before(run, opt)
    base = line[0] if len(line) else start
    arc = _arc(base, run.feed_start, run.normal_start, opt.lead_radius_mm,
               opt.lead_angle_deg, opt.chord_tol_mm, lead_in=True)
    pts = np.concatenate([arc, line]) if len(arc) or len(line) else np.zeros((0, 3))
    first = pts[0] if len(pts) else start
    return pts, first


def _departure(run: Run, opt: LinkOptions) -> NDArray[np.float64]:
    """Lead-out points (extension and arc) in travel order."""
    line = _extension_after(run, opt)
    base = line[0] if len(line) else run.tips[-1]
    arc = _arc(base, run.feed_end, run.normal_end, opt.lead_radius_mm, opt.lead_angle_deg,
               opt.chord_tol_mm, lead_in=False)
    return np.concatenate([line, arc])


def link_runs(runs: list[Run], opt: LinkOptions) -> tuple[NDArray[np.float64], ...]:
    """Assemble the runs into toolpath arrays (positions, axes, kinds, feeds, passes).

    Returns
    -------
    positions_mm, tool_axes, kinds, feeds_mm_per_min, pass_index : ndarray
        Ready for :class:`~toolpath.path.Toolpath`.
    """
    out = _Builder(opt.feed_mm_per_min, opt.plunge_feed_mm_per_min)
    clear = opt.clearance
    prev: Run | None = None
    for run in runs:
        a0 = run.axes[0]
        linked = prev is not None and (run.joined or run.direct_link)
        if prev is not None and not linked:
            a_end = prev.axes[-1]
            dep = _departure(prev, opt)
            out.add(dep, a_end, MoveKind.LEAD_OUT)
            here = dep[-1] if len(dep) else prev.tips[-1]
            up = clear.retract(here, a_end)
            out.add(up, a_end, MoveKind.RAPID)
        if prev is None or not linked:
            lead, first = _approach(run, opt)
            above = first + opt.approach_mm * a0
            top = clear.retract(above, a0)
            if prev is not None:
                mid_pts, mid_axes = clear.traverse(out.last, prev.axes[-1], top, a0)
                if len(mid_pts):
                    out.add(mid_pts, mid_axes, MoveKind.RAPID)
            out.add(top, a0, MoveKind.RAPID)
            out.add(above, a0, MoveKind.RAPID)
            out.add(first, a0, MoveKind.PLUNGE)
            if len(lead) > 1:
                out.add(lead[1:], a0, MoveKind.LEAD_IN)
            out.add_run(run, MoveKind.LEAD_IN if len(lead) else MoveKind.PLUNGE)
        elif run.joined:
            out.add_run(run, MoveKind.CUT)
        else:
            # a direct link keeps the extensions past open edges: without them the side
            # of a flat or bull-nose cutter that leaves the cusps stops short of the edge
            out.add(_extension_after(prev, opt), prev.axes[-1], MoveKind.LEAD_OUT)
            before = _extension_before(run, opt)
            if len(before):
                out.add(before, run.axes[0], MoveKind.LINK)
                out.add_run(run, MoveKind.LEAD_IN)
            else:
                out.add_run(run, MoveKind.LINK)
        prev = run
    if prev is not None:
        dep = _departure(prev, opt)
        out.add(dep, prev.axes[-1], MoveKind.LEAD_OUT)
        here = dep[-1] if len(dep) else prev.tips[-1]
        out.add(clear.retract(here, prev.axes[-1]), prev.axes[-1], MoveKind.RAPID)
    return out.arrays()
