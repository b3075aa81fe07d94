"""``plan_finishing``: streamline finishing passes from a surface to a checked toolpath.

Stages (each timed in the report):

1. **probe**: the surface frame on a grid of columns (more where the normal turns fast)
   by levels, as many as a coarse probe shows the plan needs (:func:`_probe_columns`):
   tool axes, reach (3-axis), local gouge margin, the allowed step in ``s`` from the
   scallop formula (:mod:`~toolpath.planning.scallop`) and the chord density;
2. **spacing**: pass levels in ``s``, worst case along each pass;
3. **passes**: points along each pass from the chord tolerance
   (:mod:`~toolpath.planning.sampling`), axes, tips; 3-axis reach boundaries;
4. **chords**: mid-chord gaps measured against the surface, offending chords split;
5. **gouge**: local (curvature) and global (samples) checks, then ``on_gouge``;
6. **linking**: runs, lead arcs, clearance, rapids (:mod:`~toolpath.planning.linking`),
   and a gouge check of every non-cutting position;
7. **machine**: inverse kinematics, travel (raise or report) and rate limits, time;
8. **measure**: scallop and chord error measured on the result
   (:mod:`~toolpath.planning.chord_measure`, :mod:`~toolpath.planning.measure`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from machines import Machine, load_machine
from machines.errors import UnreachableOrientationError
from machines.kinematics import tilt_reach_deg
from machines.limits import Side, Violation

from ..errors import InvalidParameterError
from ..joint_refine import machine_key, with_solved_joints
from ..path import MoveKind, Toolpath
from ..surface import ParametricSurface, as_surface
from ..tolerances import ANGLE_SLACK_DEG, FLAT_PER_MM, LIMIT_SLACK, TINY
from .avoid import depth_text, gouge_depth_mm, local_depth_mm
from .blunt_edge import blunt_face
from .checks import (
    GougeStats,
    MachineStats,
    check_links,
    concave_remedy,
    gouge_stage,
    machine_stage,
)
from .chord_measure import ChordMeasurement, measure_chord
from .clearance_kernel import points_box
from .cutters import Cutter, CutterKind, parse_cutter
from .errors import GougeError, PlanTravelLimitError, UnreachableRegionError, too_many_points
from .gouge import local_margin, sample_surface
from .linking import ClearancePlane, ClearanceSphere, LinkOptions, Run, extends, link_runs
from .local import PassFrame, pass_frame
from .measure import ScallopMeasurement, measure_scallop
from .options import (
    TILT_MARGIN_DEG,
    AxisMode,
    FinishingOptions,
    Linking,
    OnGouge,
    OnLimit,
    PlannedOptions,
    chosen_linking,
)
from .passes import (
    PassLayout,
    PassPoints,
    evaluate_points,
    final_axes,
    frame_take,
    nominal_axes,
    reach_height,
    reach_split,
    refine_chords,
)
from .report import PlanningReport, UnreachableSpan, merge_spans
from .resolution import rounding_reserve_mm
from .rotary_rate import rotary_rates
from .sampling import (
    chord_length_mm,
    equidistribute,
    pass_densities,
    point_move_gaps,
    split_evenly,
)
from .scallop import (
    cusp_allowance_mm,
    pass_levels,
    shadow_stepover_mm,
    stepover_mm,
    turn_radius_mm,
)
from .tool_axis import angle_deg

__all__ = ["plan_finishing"]

_STAGES = ("probe", "spacing", "passes", "chords", "gouge", "linking", "machine", "measure")


class _Clock:
    """Stage timer that also drives the progress callback."""

    def __init__(self, progress: Any) -> None:
        self.progress = progress
        self.seconds: dict[str, float] = {}
        self._stage: str | None = None
        self._t0 = time.perf_counter()

    def stage(self, name: str) -> None:
        now = time.perf_counter()
        if self._stage is not None:
            self.seconds[self._stage] = now - self._t0
        self._stage, self._t0 = name, now
        if self.progress is not None:
            self.progress(name, _STAGES.index(name) / len(_STAGES))

    def done(self) -> None:
        self.stage_end()
        if self.progress is not None:
            self.progress("done", 1.0)

    def stage_end(self) -> None:
        if self._stage is not None:
            self.seconds[self._stage] = time.perf_counter() - self._t0
            self._stage = None


def _as_cutter(cutter: Any) -> Cutter:
    if isinstance(cutter, Cutter):
        return cutter
    if isinstance(cutter, str):
        return parse_cutter(cutter)
    raise InvalidParameterError(f"cutter must be a Cutter or a spec like 'ball:6', "
                                f"got {cutter!r}")


def _as_machine(machine: Any, opts: FinishingOptions) -> Machine | None:
    if machine is None:
        return None
    mach = machine if isinstance(machine, Machine) else load_machine(machine)
    if not mach.kinematics.is_five_axis:
        if opts.axis_mode is AxisMode.LEAD_TILT:
            raise UnreachableOrientationError(
                f"--axis lead-tilt (axis_mode='lead-tilt') needs a 5-axis machine: machine "
                f"{mach.name!r} is 3-axis and holds the tool along +Z only; use --axis 3 or "
                f"--machine trunnion-ac / head-table-bc", indices=[])
        if not np.allclose(opts.fixed_axis, (0.0, 0.0, 1.0), atol=LIMIT_SLACK):
            raise UnreachableOrientationError(
                f"--fixed-axis {','.join(f'{v:g}' for v in opts.fixed_axis)} is not +Z: the "
                f"3-axis machine {mach.name!r} holds the tool along +Z only; set the part up "
                f"so that axis is +Z (--rotate) or use a 5-axis machine", indices=[])
    return mach


def _reach(opts: FinishingOptions, normal: NDArray[np.float64]) -> NDArray[np.bool_]:
    if opts.axis_mode is not AxisMode.FIXED:
        return np.ones(normal.shape[0], dtype=bool)
    return reach_height(opts, normal) >= 0.0


def _rounding_reserve(surface: ParametricSurface, cutter: Cutter, opts: FinishingOptions,
                      mach: Machine | None) -> float:
    """What the G-code's grid can move the cutter by, at poses on a 17 x 17 grid."""
    if not (opts.coordinate_step_mm or opts.angle_step_deg):
        return 0.0
    g = np.linspace(0.0, 1.0, 17)
    tt, ss = np.meshgrid(g, g, indexing="ij")
    frame = pass_frame(surface, tt.ravel(), ss.ravel())
    axes = nominal_axes(opts, frame.normal, frame.e1)
    tips = cutter.tips_from_contacts(frame.point, frame.normal, axes)
    return rounding_reserve_mm(tips, axes, mach, coordinate_step_mm=opts.coordinate_step_mm,
                               angle_step_deg=opts.angle_step_deg)


@dataclass(frozen=True, eq=False)
class ProbeGrid:
    """The surface frame and what the plan reads from it on the probe grid.

    Nodes ``(t[i], s[j])`` are ravelled ``t``-major (row ``i * len(s) + j``) in the
    per-node arrays.

    Attributes
    ----------
    t, s : ndarray
        Probe columns (along the passes) and levels (across them).
    frame : PassFrame
        The surface frame at the nodes.
    axes : ndarray, shape (n, 3)
        The tool axes there (smoothed like passes for a flat face in 5-axis).
    reach : ndarray of bool, shape (n,)
        Reachable by the fixed axis (every node in 5-axis).
    outcurved : ndarray of bool, shape (n,)
        The surface out-curves the cutter there (the cusp formula has no meaning).
    depth_mm : ndarray, shape (n,)
        The gouge depth measured where the curvature flags one, 0 elsewhere.
    gouging : ndarray of bool, shape (n,)
        ``depth_mm`` beyond the gouge tolerance.
    allowed_ds : ndarray, shape (len(s),)
        The allowed step in ``s`` per level (the smallest along it; ``inf``: none).
    area : ndarray, shape (len(t), len(s))
        ``|X_t| |X_s|`` at the nodes (area weights).
    density : ndarray, shape (len(t), len(s))
        Chord density: segments per unit ``t`` the chord tolerance needs.
    advice : tuple of str
        Advice on the cutter (:func:`_flat_advice`).
    """

    t: NDArray[np.float64]
    s: NDArray[np.float64]
    frame: PassFrame
    axes: NDArray[np.float64]
    reach: NDArray[np.bool_]
    outcurved: NDArray[np.bool_]
    depth_mm: NDArray[np.float64]
    gouging: NDArray[np.bool_]
    allowed_ds: NDArray[np.float64]
    area: NDArray[np.float64]
    density: NDArray[np.float64]
    advice: tuple[str, ...]


def _probe(job: _Job, t: NDArray[np.float64], s: NDArray[np.float64]) -> ProbeGrid:
    """Allowed step in ``s`` per probe level, reach and local gouges on the probe grid.

    The stages: the surface frame at the nodes, the tool axes (:func:`_probe_axes`), the
    reach, the local gouges (:func:`_probe_gouges`), the allowed step in ``s``
    (:func:`_allowed_steps`) and the chord density (:func:`_chord_density`).
    """
    tt, ss = np.meshgrid(t, s, indexing="ij")
    frame = pass_frame(job.surface, tt.ravel(), ss.ravel())
    axes = _probe_axes(job, frame, t.size, s.size)
    reach = _reach(job.opts, frame.normal)
    outcurved, depth, gouging = _probe_gouges(job, frame, axes, reach, tt.ravel(), ss.ravel())
    # the cutter's curvature along the pass at the contact
    c11, _, _ = job.cutter.curvature_tensor(frame.normal, axes, frame.e1, frame.e2)
    allowed, advice = _allowed_steps(job, frame, axes, c11, reach & ~outcurved, s)
    density = _chord_density(job, frame, c11, reach, (t.size, s.size))
    area = (frame.speed_t * frame.speed_s).reshape(len(t), len(s))
    return ProbeGrid(t=t, s=s, frame=frame, axes=axes, reach=reach, outcurved=outcurved,
                     depth_mm=depth, gouging=gouging, allowed_ds=allowed.min(axis=0),
                     area=area, density=density, advice=advice)


def _probe_axes(job: _Job, frame: PassFrame, n_t: int, n_s: int) -> NDArray[np.float64]:
    """The tool axes at the ``n_t`` by ``n_s`` probe nodes (ravelled ``t``-major).

    The nominal axes; in 5-axis with a flat face, smoothed like passes: a flat face's
    section depends on the axis it will have, not the nominal one (smoothing a zero lead
    on a convex surface leans the face sideways and moves the contact to its rim). The
    probe's columns (fixed ``s``) are smoothed like passes.
    """
    cutter, opts = job.cutter, job.opts
    axes = nominal_axes(opts, frame.normal, frame.e1)
    if cutter.kind is CutterKind.BALL or opts.axis_mode is not AxisMode.LEAD_TILT:
        return axes
    by_pass = np.arange(n_t * n_s).reshape(n_t, n_s).T.ravel()
    column = np.repeat(np.arange(n_s), n_t)
    smoothed, _, _ = final_axes(cutter, opts, job.res, frame_take(frame, by_pass),
                                axes[by_pass], column, np.ones(column.size, np.int64))
    axes = np.empty_like(axes)
    axes[by_pass] = smoothed
    return axes


def _probe_gouges(job: _Job, frame: PassFrame, axes: NDArray[np.float64],
                  reach: NDArray[np.bool_], t: NDArray[np.float64], s: NDArray[np.float64]
                  ) -> tuple[NDArray[np.bool_], NDArray[np.float64], NDArray[np.bool_]]:
    """Where the surface out-curves the cutter, how deep it sinks in, and where it gouges.

    Where the curvature out-curves the cutter, how deep it actually sinks in is measured
    (:func:`~toolpath.planning.avoid.gouge_depth_mm`): a gouge is a depth beyond the
    tolerance, not a radius (a fit's ripple costs nothing). Out-curved nodes do not set
    the spacing: the cusp formula has no meaning where the cutter bridges the hollow.
    Returns ``outcurved``, ``depth_mm`` (0 where not measured) and ``gouging``.
    """
    surface, cutter, tol_mm = job.surface, job.cutter, job.opts.gouge_tol_mm
    estimate = local_depth_mm(frame, cutter, axes)
    flagged = reach & (estimate > tol_mm)
    outcurved = reach & (estimate > 0.0)
    depth = np.zeros(flagged.size)
    at = np.flatnonzero(flagged)
    if at.size:
        depth[at] = gouge_depth_mm(
            surface, cutter, t[at], s[at],
            cutter.tips_from_contacts(frame.point[at], frame.normal[at], axes[at]), axes[at],
            speed_t=frame.speed_t[at], speed_s=frame.speed_s[at]).depth_mm
    return outcurved, depth, flagged & (depth > tol_mm)


def _allowed_steps(job: _Job, frame: PassFrame, axes: NDArray[np.float64],
                   c11: NDArray[np.float64], sets_step: NDArray[np.bool_],
                   s: NDArray[np.float64]) -> tuple[NDArray[np.float64], tuple[str, ...]]:
    """The allowed step in ``s`` at each node (``len(t)`` by ``len(s)``) and the advice.

    The stepover the scallop allows (:func:`~toolpath.planning.scallop.stepover_mm` for a
    ball, :func:`~toolpath.planning.scallop.shadow_stepover_mm` for the others) over
    ``|X_s|``; ``inf`` where the node does not set the step (``sets_step`` false). Where
    the pass is concave (``S11 > 0``) the cusp is planned for the scallop minus the
    allowed chord undercut (:data:`~toolpath.planning.options.CONCAVE_UNDERCUT_SHARE`).
    ``c11``: the cutter's curvature along the pass at the contact, 1/mm.
    """
    cutter, opts, res = job.cutter, job.opts, job.res
    shape = (len(frame.s11) // len(s), len(s))  # (the nodes are ravelled t-major)
    h = cusp_allowance_mm(res.planned_scallop_mm, res.undercut_mm, frame.s11,
                          opts.axis_mode is AxisMode.LEAD_TILT)
    if cutter.kind is CutterKind.BALL:
        width = stepover_mm(h, cutter.radius_mm, frame.s22)
    else:
        # the cutter's true section across the pass: its osculating circle alone
        # underestimates the cusp that forms far from the contact (coarse scallops), and
        # a face leaning sideways puts the contact on its rim, a corner on one side and
        # the face on the other; a flat face on a slope leaves a staircase
        mirrored = opts.linking is Linking.ZIGZAG and opts.tilt_deg != 0.0
        turn_radius = None
        if opts.axis_mode is AxisMode.LEAD_TILT:
            # the axis turning along the pass (round an edge) lifts the section's sides
            grid = (*shape, 3)
            turn_radius = turn_radius_mm(*(v.reshape(grid) for v in (
                frame.point, frame.normal, frame.e1, axes))).ravel()
        width = shadow_stepover_mm(h, cutter.radius_mm, cutter.corner_radius_mm,
                                   frame.normal, axes, frame.e2, frame.s22, mirrored=mirrored,
                                   turn_radius_mm=turn_radius, cutter_curvature_along_per_mm=c11)
    allowed = (np.where(sets_step, width, np.inf) / frame.speed_s).reshape(shape)
    if cutter.kind is not CutterKind.FLAT:
        return allowed, ()
    ball = np.where(sets_step, stepover_mm(h, cutter.radius_mm, frame.s22), np.inf)
    return allowed, _flat_advice(allowed, (ball / frame.speed_s).reshape(shape), s)


def _chord_density(job: _Job, frame: PassFrame, c11: NDArray[np.float64],
                   reach: NDArray[np.bool_], shape: tuple[int, int]) -> NDArray[np.float64]:
    """Chord density ``|X_t| / L`` (segments per unit ``t``) at the nodes, ``shape``.

    ``L`` is the chord length the chord tolerance allows
    (:func:`~toolpath.planning.sampling.chord_length_mm`) with the cutter's radius of
    curvature along the pass (``1 / c11``, at most its radius); on concave passes the
    moves stand above the surface and lift the cusps, so the tolerance there is the
    allowed undercut. 3-axis: the far side only needs points enough to end the passes'
    cut runs (the longest moves there), but the full density next to anything reachable.
    """
    surface, cutter, opts, res = job.surface, job.cutter, job.opts, job.res
    big = cutter.radius_mm
    with np.errstate(divide="ignore"):
        rho_f = np.where(c11 > 0.0, np.minimum(1.0 / np.where(c11 > 0.0, c11, 1.0), big), big)
    tol = np.where(frame.s11 > FLAT_PER_MM, res.undercut_mm, res.planned_chord_tol_mm)
    # the axis turns with the normal along the pass (5-axis): |S11| rad per mm
    axis_turn = np.abs(frame.s11) if opts.axis_mode is AxisMode.LEAD_TILT else 0.0
    length = chord_length_mm(frame, rho_f, tol, res.max_segment_mm,
                             lift_mm=cutter.corner_radius_mm, turn_per_mm=axis_turn)
    density = (frame.speed_t / length).reshape(shape)
    if opts.axis_mode is not AxisMode.FIXED:
        return density
    near = _next_to(reach.reshape(shape), bool(surface.closed_t))
    return np.where(near, density, (frame.speed_t / res.max_segment_mm).reshape(shape))


def _next_to(mask: NDArray[np.bool_], closed_t: bool) -> NDArray[np.bool_]:
    """``mask`` grown by one node along both grid directions, diagonals too.

    With ``closed_t`` the first and last rows (``t = 0`` and ``t = 1``, one seam) are
    neighbours of each other's neighbours.
    """
    grown = mask.copy()
    grown[1:] |= mask[:-1]
    grown[:-1] |= mask[1:]
    if closed_t and len(mask) > 2:
        grown[0] |= mask[-2]
        grown[-1] |= mask[1]
    out = grown.copy()
    out[:, 1:] |= grown[:, :-1]
    out[:, :-1] |= grown[:, 1:]
    return out


#: Uniform columns and levels of the coarse probe (:func:`_probe_columns`, and the
#: levels of the probe: three per pass), and the fewest and most columns of the probe.
COARSE_PROBE_T = 129
COARSE_PROBE_S = 33
MIN_PROBE_T = 129
MAX_PROBE_T = 513
#: Uniform probe columns per point of the densest pass.
PROBE_PER_POINT = 3.0


def _probe_columns(t: NDArray[np.float64], density: NDArray[np.float64]) -> int:
    """Uniform probe columns for a plan whose densest pass gets ``n`` points.

    :data:`PROBE_PER_POINT` times ``n``, where ``n`` is the chord density (segments per
    unit ``t``, probe columns ``t`` by levels) integrated along each level, the largest:
    the probe is then several times finer
    along the passes than the points it places, between :data:`MIN_PROBE_T` (1 mm on a
    130 mm blade section) and :data:`MAX_PROBE_T` (0.25 mm). The columns where the normal
    turns fast come on top (:func:`_probe_t`).
    """
    mid = 0.5 * (density[1:] + density[:-1])
    points = float((mid * np.diff(t)[:, None]).sum(axis=0).max())
    if not np.isfinite(points):  # (a degenerate frame somewhere: the finest probe)
        return MAX_PROBE_T
    return int(np.clip(np.ceil(PROBE_PER_POINT * points), MIN_PROBE_T, MAX_PROBE_T))


#: Largest turn of the normal between neighbouring probe columns (at any of
#: :data:`PROBE_LEVELS` levels of ``s``), rad: 2 deg.
MAX_PROBE_TURN = np.radians(2.0)
PROBE_LEVELS = 9
#: The most pieces one probe interval is divided into.
MAX_PROBE_PARTS = 64


def _probe_t(surface: ParametricSurface, n: int) -> NDArray[np.float64]:
    """Probe parameters along the passes: ``n`` uniform, more where the normal turns.

    A leading edge turns the normal by half a turn over a fraction of a millimetre: there
    uniform probes would see it at a few points, and the chord density, the stepover and
    the axis' turn read from them would be coarse. Each interval whose normal turns by
    more than :data:`MAX_PROBE_TURN` (the largest over :data:`PROBE_LEVELS` levels of
    ``s``) is divided evenly in ``t`` into ``ceil(turn / MAX_PROBE_TURN)`` pieces (at most
    :data:`MAX_PROBE_PARTS`); where the turn is uneven inside it, a piece can still turn
    more.
    """
    uniform = np.linspace(0.0, 1.0, n)
    normals = surface.normal(*(v.ravel() for v in np.meshgrid(
        uniform, np.linspace(0.0, 1.0, PROBE_LEVELS), indexing="ij"))).reshape(
            n, PROBE_LEVELS, 3)
    turn = np.radians(angle_deg(normals[1:], normals[:-1])).max(axis=1)
    parts = np.minimum(np.ceil(turn / MAX_PROBE_TURN), MAX_PROBE_PARTS).astype(np.int64)
    if not (parts > 1).any():
        return uniform
    inner, _ = split_evenly(uniform[:-1], uniform[1:], np.maximum(parts, 1))
    return np.sort(np.r_[uniform, inner])


#: A flat end mill needing this many times the passes of a ball of its diameter is told.
FLAT_ADVICE_RATIO = 3.0


def _flat_advice(allowed: NDArray[np.float64], ball_allowed: NDArray[np.float64],
                 s: NDArray[np.float64]) -> tuple[str, ...]:
    """Advice when a flat end mill needs far more passes than a ball of its diameter.

    Passes are estimated as ``int ds / A(s)`` with ``A`` the allowed step of each probe
    level (the smallest along it), for both cutters on the same probe grid.
    """
    def passes(a: NDArray[np.float64]) -> float:
        step = a.min(axis=0)
        step = np.where(np.isfinite(step) & (step > 0.0), step, np.nan)
        lower = np.fmin(step[:-1], step[1:])
        return float(np.nansum(np.diff(s) / lower))

    flat, ball = passes(allowed), passes(ball_allowed)
    if not (ball > 0.0 and flat > FLAT_ADVICE_RATIO * ball):
        return ()
    return (f"a flat end mill needs about {flat / ball:.0f}x the passes of a ball of the "
            f"same diameter here ({flat:.0f} against {ball:.0f}): its face leaves a "
            f"staircase where the surface slopes across the passes; use a ball or bull-nose "
            f"cutter, or 5-axis to stand the face on the surface",)


def _layout(levels: NDArray[np.float64], linking: Linking) -> PassLayout:
    if linking is Linking.SPIRAL:
        s_start = np.r_[0.0, levels[:-1], 1.0]
        s_end = np.r_[0.0, levels[1:], 1.0]
    else:
        s_start = s_end = levels
    n = len(s_start)
    direction = (np.where(np.arange(n) % 2 == 0, 1, -1) if linking is Linking.ZIGZAG
                 else np.ones(n, dtype=np.int64))
    return PassLayout(np.asarray(s_start, float), np.asarray(s_end, float),
                      np.asarray(direction, dtype=np.int64))


def _initial_points(layout: PassLayout, t_probe: NDArray[np.float64],
                    s_probe: NDArray[np.float64], density: NDArray[np.float64]
                    ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Equidistributed contacts per pass from the probe grid's chord density.

    The density (segments per unit ``t``) is interpolated linearly in ``s`` to each pass
    (to each point of a spiral ring); the chord check then adds what this misses.
    """
    return equidistribute(t_probe, pass_densities(t_probe, s_probe, density, layout.s_start,
                                                  layout.s_end))


def _runs_of(keep: NDArray[np.bool_], pts: PassPoints, closed: bool
             ) -> list[NDArray[np.int64]]:
    """Index arrays of maximal kept stretches (at least two points) per pass.

    On closed sections a stretch ending at ``t = 1`` continues into the one starting at
    ``t = 0`` of the same pass (the same point), so the two are joined.
    """
    cont = np.r_[False, (pts.pid[1:] == pts.pid[:-1]) & keep[1:] & keep[:-1]]
    starts = np.flatnonzero(keep & ~cont)
    ends = np.flatnonzero(keep & ~np.r_[cont[1:], False])
    runs = [np.arange(a, b + 1) for a, b in zip(starts, ends, strict=True) if b > a]
    if not closed or len(runs) < 2:
        return runs
    out: list[NDArray[np.int64]] = []
    i = 0
    while i < len(runs):
        first = runs[i]
        j = i
        while j + 1 < len(runs) and pts.pid[runs[j + 1][0]] == pts.pid[first[0]]:
            j += 1
        last = runs[j]
        wraps = (j > i and pts.t[first[0]] == 0.0 and pts.t[last[-1]] == 1.0)
        if wraps:
            out.extend(runs[i + 1:j])
            out.append(np.r_[last, first])  # the repeated point is dropped on linking
        else:
            out.extend(runs[i:j + 1])
        i = j + 1
    return out


def _cut_mask(runs: list[NDArray[np.int64]], n: int) -> NDArray[np.bool_]:
    """Which of ``n`` points the runs cut."""
    cut = np.zeros(n, dtype=bool)
    for run in runs:
        cut[run] = True
    return cut


def _spans(pts: PassPoints, keep: NDArray[np.bool_], faces_away: NDArray[np.bool_],
           cut: NDArray[np.bool_], layout: PassLayout) -> list[UnreachableSpan]:
    """Uncut stretches of each pass, between the cut runs (``cut``: the points they cut).

    A stretch runs from the last cut point before it (or its pass's ``t = 0``) to the
    first cut point after it (or ``t = 1``).
    """
    uncut = ~cut
    first = np.r_[True, pts.pid[1:] != pts.pid[:-1]]  # first and last point of each pass
    last = np.r_[first[1:], True]
    starts = np.flatnonzero(uncut & (first | ~np.r_[False, uncut[:-1]]))
    ends = np.flatnonzero(uncut & (last | ~np.r_[uncut[1:], False]))  # (inclusive)
    lo = np.where(first[starts], 0.0, pts.t[starts - 1])
    hi = np.where(last[ends], 1.0, pts.t[np.minimum(ends + 1, len(pts) - 1)])

    def any_in(mask: NDArray[np.bool_]) -> NDArray[np.bool_]:
        count = np.r_[0, np.cumsum(mask)]
        return count[ends + 1] > count[starts]

    reason = np.where(any_in(faces_away), "faces away",
                      np.where(any_in(~keep), "shadowed", "too short"))
    p = pts.pid[starts]
    s_mid = 0.5 * (layout.s_start[p] + layout.s_end[p])
    return [UnreachableSpan(*row) for row in zip(
        p.tolist(), s_mid.tolist(), lo.tolist(), hi.tolist(), reason.tolist(), strict=True)]


@dataclass(frozen=True, eq=False)
class _RunOrder:
    """The runs in cutting order, as arrays over them (entry ``j``: the ``j``-th cut).

    ``index``: each one's index into the runs; ``first``, ``last``: the rows it cuts
    first and last; ``consecutive``: its rows follow on in ``pts``; ``extend_first``,
    ``extend_last``: its ends lie on an open edge; ``joined``, ``direct``: how it links to
    the one before (:func:`_run_links`); ``rows``, ``offset``, ``length``: the rows of
    every run end to end, where each one's start and how many.
    """

    index: NDArray[np.int64]
    first: NDArray[np.int64]
    last: NDArray[np.int64]
    consecutive: NDArray[np.bool_]
    extend_first: NDArray[np.bool_]
    extend_last: NDArray[np.bool_]
    joined: NDArray[np.bool_]
    direct: NDArray[np.bool_]
    rows: NDArray[np.int64]
    offset: NDArray[np.int64]
    length: NDArray[np.int64]


def _make_runs(surface: ParametricSurface, cutter: Cutter, opts: FinishingOptions,
               res: PlannedOptions, pts: PassPoints, runs: list[NDArray[np.int64]]
               ) -> list[Run]:
    """Runs in cutting order with their lead data and how they link.

    By pass; a pass cut backwards (``direction < 0``) takes its runs last to first, each
    reversed. A run of consecutive rows is handed over as a view; runs that follow on one
    another (joined, or linked directly with no extension between) as one chain, with a
    kind and pass per point (:class:`~toolpath.planning.linking.Run`).
    """
    order = _run_order(surface, cutter, opts, res, pts, runs)
    # a run follows on in the chain of the one before: both consecutive rows, and joined
    # or linked directly with no extension past an edge between them
    extended = (extends(order.extend_last[:-1], res.extend_mm)
                | extends(order.extend_first[1:], res.extend_mm))
    both = order.consecutive[1:] & order.consecutive[:-1]
    follows = np.r_[False, both & (order.joined[1:] | (order.direct[1:] & ~extended))]
    chain_start = np.flatnonzero(~follows)
    chain_end = np.r_[chain_start[1:], len(runs)]  # (exclusive)
    return [_chain(pts, runs, order, j, end)
            for j, end in zip(chain_start.tolist(), chain_end.tolist(), strict=True)]


def _run_order(surface: ParametricSurface, cutter: Cutter, opts: FinishingOptions,
               res: PlannedOptions, pts: PassPoints, runs: list[NDArray[np.int64]]
               ) -> _RunOrder:
    """The runs in cutting order: by pass, a pass cut backwards last to first, reversed."""
    heads = np.array([run[0] for run in runs], dtype=np.int64)
    tails = np.array([run[-1] for run in runs], dtype=np.int64)
    sizes = np.array([len(run) for run in runs], dtype=np.int64)
    back = pts.direction[heads] < 0
    k = np.arange(len(runs))
    index = np.lexsort((np.where(back, -k, k), pts.pid[heads]))
    first = np.where(back, tails, heads)[index]
    last = np.where(back, heads, tails)[index]
    open_edge = not surface.closed_t
    t_first, t_last = pts.t[first], pts.t[last]
    joined, direct = _run_links(surface, cutter, opts, res, pts, first, last, pts.pid[first])
    # the rows of every consecutive run in cutting order, end to end
    length = np.abs(last - first) + 1
    offset = np.cumsum(length) - length
    step = np.where(last >= first, 1, -1)
    rows = (np.repeat(first - step * offset, length)
            + np.repeat(step, length) * np.arange(int(length.sum())))
    return _RunOrder(index=index, first=first, last=last,
                     consecutive=(tails - heads == sizes - 1)[index],
                     extend_first=open_edge & ((t_first == 0.0) | (t_first == 1.0)),
                     extend_last=open_edge & ((t_last == 0.0) | (t_last == 1.0)),
                     joined=joined, direct=direct, rows=rows, offset=offset, length=length)


def _chain(pts: PassPoints, runs: list[NDArray[np.int64]], order: _RunOrder, j: int,
           end: int) -> Run:
    """The :class:`~toolpath.planning.linking.Run` of the runs ``j`` to ``end - 1`` in order.

    A chain of several: their rows end to end, with a kind and pass per point; a run of
    consecutive rows: a view; two stretches joined across a closed section's seam: their
    rows.
    """
    i = int(order.index[j])
    point_kinds = point_passes = None
    offset, length = order.offset, order.length
    if end - j > 1:
        rows: slice | NDArray[np.int64] = order.rows[offset[j]:offset[end - 1]
                                                     + length[end - 1]]
        point_kinds = np.full(rows.size, MoveKind.CUT, dtype=np.uint8)
        point_kinds[offset[j + 1:end] - offset[j]] = np.where(
            order.joined[j + 1:end], MoveKind.CUT, MoveKind.LINK)
        point_passes = np.repeat(pts.pid[order.first[j:end]], length[j:end])
    elif order.consecutive[j]:
        a, b = int(order.first[j]), int(order.last[j])
        rows = slice(a, b + 1) if a <= b else slice(a, b - 1 if b > 0 else None, -1)
    else:
        rows = runs[i][::-1] if pts.direction[runs[i][0]] < 0 else runs[i]
    start, stop = int(order.first[j]), int(order.last[end - 1])
    return Run(
        tips=pts.tips[rows], axes=pts.axes[rows], pass_index=int(pts.pid[start]),
        normal_start=pts.frame.normal[start], normal_end=pts.frame.normal[stop],
        feed_start=pts.frame.e1[start] * pts.direction[start],
        feed_end=pts.frame.e1[stop] * pts.direction[stop],
        extend_start=bool(order.extend_first[j]), extend_end=bool(order.extend_last[end - 1]),
        joined=bool(order.joined[j]), direct_link=bool(order.direct[j]),
        point_kinds=point_kinds, point_passes=point_passes)


#: A spiral's run that starts within this (mm) of where the one before ended continues it:
#: the spiral is one pass cut into runs, whose shared ends are the same point.
_SPIRAL_JOIN_MM = 1e-6


def _run_links(surface: ParametricSurface, cutter: Cutter, opts: FinishingOptions,
               res: PlannedOptions, pts: PassPoints, first: NDArray[np.int64],
               last: NDArray[np.int64], pass_index: NDArray[np.int64]
               ) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """How each run links to the one before: ``joined`` (spiral), ``direct`` (a move).

    A spiral's run starting where the one before ended, on the next pass, is joined; other
    runs on another pass within ``link_max_mm`` link directly unless the cutter half-way
    along the link would cut deeper than the chord tolerance.
    """
    joined = np.zeros(len(first), dtype=bool)
    direct = np.zeros(len(first), dtype=bool)
    step = pts.tips[first[1:]] - pts.tips[last[:-1]]
    gaps_mm = np.sqrt(np.einsum("ij,ij->i", step, step))
    if opts.linking is Linking.SPIRAL:
        joined[1:] = (gaps_mm < _SPIRAL_JOIN_MM) & (pass_index[1:] == pass_index[:-1] + 1)
        return joined, direct
    ks = np.flatnonzero((gaps_mm <= res.link_max_mm)
                        & (pass_index[1:] != pass_index[:-1])) + 1
    if ks.size:
        # the cutter half-way along the link (its search started between the ends'
        # contacts, the short way across a closed section's seam): the links as moves
        # 2j -> 2j + 1 of their ends
        ends = np.column_stack([last[ks - 1], first[ks]]).ravel()
        gap = point_move_gaps(surface, cutter, pts.tips[ends], pts.axes[ends], pts.t[ends],
                              pts.s[ends], np.arange(0, ends.size, 2), np.array([0.5]),
                              newton=3)[0][:, 0]
        direct[ks] = gap >= -res.planned_chord_tol_mm
    return joined, direct


def plan_finishing(surface: ParametricSurface, cutter: Cutter | str, *, scallop_mm: float,
                   chord_tol_mm: float, axis_mode: str = "3", lead_deg: float = 0.0,
                   tilt_deg: float = 0.0, linking: str = "auto",
                   machine: Machine | str | None = None, **options: Any
                   ) -> tuple[Toolpath, PlanningReport]:
    """Plan streamline finishing passes on ``surface`` and report what they achieve.

    Parameters
    ----------
    surface : ParametricSurface
        The surface to finish (normals out of the material).
    cutter : Cutter or str
        The end mill, or a spec like ``"ball:6"`` (the number is the diameter in mm).
    scallop_mm : float
        Largest cusp height between passes, mm.
    chord_tol_mm : float
        Largest deviation of the cutter from the surface along a move, mm.
    axis_mode : {"3", "lead-tilt"}
        Fixed tool axis (``fixed_axis``, default +Z) or 5-axis lead/tilt.
    lead_deg, tilt_deg : float
        Lead and tilt angles for ``"lead-tilt"``, deg.
    linking : {"auto", "zigzag", "oneway", "spiral"}
        How passes follow each other (``spiral`` needs closed sections; ``auto`` takes
        spiral round closed sections under ``lead-tilt``, zigzag otherwise, and says so
        in the report's ``linking_reason``).
    machine : Machine or str, optional
        Check reach, travel and rates on this machine and estimate the time.
    **options
        Any other field of :class:`~toolpath.planning.options.FinishingOptions`.

    Returns
    -------
    toolpath : Toolpath
    report : PlanningReport

    Raises
    ------
    InvalidParameterError
        Bad or unknown options, tolerances <= 0 or not below the cutter radius, spiral on
        open sections.
    GougeError
        A gouge deeper than ``gouge_tol_mm`` with ``on_gouge="raise"`` (where a concave
        radius smaller than the cutter, a fold or another part of the surface costs that
        much, measured), or a linking move that would gouge; names pass and point.
    UnreachableRegionError
        Nothing of the surface can be reached.
    machines.MachineError
        Unknown machine, an orientation the machine cannot make, travel exceeded
        (with ``on_limit="raise"``).
    """
    job = _job(surface, cutter, machine, options, scallop_mm=scallop_mm,
               chord_tol_mm=chord_tol_mm, axis_mode=axis_mode, lead_deg=lead_deg,
               tilt_deg=tilt_deg, linking=linking)
    surface, cutter, opts, res, mach = job.surface, job.cutter, job.opts, job.res, job.machine
    clock = _Clock(opts.progress)

    clock.stage("probe")
    probe = _probe_stage(job)

    clock.stage("spacing")
    layout = _layout(_levels(probe, opts.linking), opts.linking)

    clock.stage("passes")
    pts, keep = _pass_points(job, probe, layout)

    clock.stage("chords")
    refined = refine_chords(surface, cutter, opts, res, layout, pts, keep=keep, machine=mach)
    pts, keep = refined.points, refined.keep
    if opts.on_limit is OnLimit.RAISE:
        _check_tilt_reach(pts, keep, opts, res, mach)

    clock.stage("gouge")
    samples = sample_surface(surface, res.gouge_sample_mm)
    pts, keep, gouge = gouge_stage(surface, cutter, opts, res, pts, keep, samples)
    runs, cut, spans = _cut_runs(job, layout, pts, keep)

    clock.stage("linking")
    path = _linked_path(job, probe, pts, runs, gouge)
    check_links(path, cutter, samples, opts, res)

    clock.stage("machine")
    machined = None
    if mach is not None:  # the joints solved once: the measure, the rates and the post read them
        path = with_solved_joints(path, mach)
        machined = machine_stage(path, mach, opts)

    clock.stage("measure")
    scallop = chord = None
    if opts.measure:
        chord = measure_chord(path, surface, cutter, samples, machine=mach)
        scallop = measure_scallop(path, surface, cutter, opts.scallop_mm, chord, machine=mach)
    clock.done()

    stages = _Stages(probe=probe, points=pts, cut=cut, spans=tuple(spans), gouge=gouge,
                     planned_chord_mm=refined.worst_mm, n_stalled=refined.n_stalled,
                     stalled_mm=refined.stalled_mm, machine=machined, scallop=scallop,
                     chord=chord, seconds=dict(clock.seconds))
    return path, _report(job, stages, path)


@dataclass(frozen=True, eq=False)
class _Job:
    """What a plan is asked for, checked: the surface, cutter, options and machine.

    ``res`` is what the plan works to (the request less ``reserve_mm``, the room the
    G-code's rounding needs), ``linking_reason`` why ``opts.linking`` was chosen.
    """

    surface: ParametricSurface
    cutter: Cutter
    opts: FinishingOptions
    res: PlannedOptions
    machine: Machine | None
    reserve_mm: float
    linking_reason: str


def _job(surface: ParametricSurface, cutter: Cutter | str, machine: Machine | str | None,
         options: dict[str, Any], **request: Any) -> _Job:
    """Check the options (``request``: the named arguments; ``options``: the others)."""
    known = {f for f in FinishingOptions.__dataclass_fields__} - set(request)
    unknown = sorted(set(options) - known)
    if unknown:
        raise InvalidParameterError(f"unknown option(s) {unknown}; known: {sorted(known)}")
    surface = as_surface(surface)
    cutter = _as_cutter(cutter)
    opts = FinishingOptions(**request, **options)
    opts.check_cutter(cutter)
    mach = _as_machine(machine, opts)
    reserve_mm = _rounding_reserve(surface, cutter, opts, mach)
    res = opts.resolved(cutter, reserve_mm, max_tilt_deg=_tilt_limit_deg(opts, mach))
    chosen, why = chosen_linking(opts.linking, bool(surface.closed_t), opts.axis_mode)
    opts = replace(opts, linking=chosen)
    if opts.linking is Linking.SPIRAL and not surface.closed_t:
        raise InvalidParameterError(
            "--linking spiral needs closed sections (surface.closed_t): this surface's "
            "passes are open (fit with --closed if its sections close); use --linking "
            "auto, zigzag or oneway")
    return _Job(surface, cutter, opts, res, mach, reserve_mm, why)


#: Probe levels per pass of the coarse probe's smallest step, and the fewest and most
#: probe levels (the coarse probe tells how many passes the plan will have).
PROBE_LEVELS_PER_PASS = 3.0
MIN_PROBE_S = 65
MAX_PROBE_S = 129
#: Smallest allowed step in ``s`` the probe levels are counted for (a guard against 0).
MIN_ALLOWED_DS = 1e-6


def _probe_stage(job: _Job) -> ProbeGrid:
    """The probe grid as fine as the plan needs, checked for reach and gouges.

    Without ``probe_t``/``probe_s``, a coarse probe (:data:`COARSE_PROBE_T` by
    :data:`COARSE_PROBE_S`) tells how fine: :data:`PROBE_LEVELS_PER_PASS` levels per pass
    of its smallest step, columns by :func:`_probe_columns`.
    """
    surface, cutter, opts = job.surface, job.cutter, job.opts
    n_t, n_s = opts.probe_t, opts.probe_s
    coarse: ProbeGrid | None = None
    if n_t is None or n_s is None:
        coarse = _probe(job, _probe_t(surface, COARSE_PROBE_T),
                        np.linspace(0.0, 1.0, COARSE_PROBE_S))
        if n_s is None:
            allowed = coarse.allowed_ds[np.isfinite(coarse.allowed_ds)]
            n_s = int(np.clip(PROBE_LEVELS_PER_PASS / max(float(allowed.min()), MIN_ALLOWED_DS)
                              + 1, MIN_PROBE_S, MAX_PROBE_S)) if allowed.size else MIN_PROBE_S
        if n_t is None:
            n_t = _probe_columns(coarse.t, coarse.density)
    t_probe = coarse.t if n_t == COARSE_PROBE_T and coarse is not None else \
        _probe_t(surface, n_t)
    probe = _probe(job, t_probe, np.linspace(0.0, 1.0, n_s))
    if not np.isfinite(probe.allowed_ds).any() and not probe.outcurved.any():
        raise UnreachableRegionError(
            f"no part of the surface faces the fixed tool axis {opts.fixed_axis!r} "
            f"(normals at least {opts.reach_margin_deg:g} deg above its plane); use another "
            "--fixed-axis or --axis lead-tilt")
    if probe.gouging.any() and opts.on_gouge is OnGouge.RAISE:
        raise _probe_gouge(probe, cutter, opts.gouge_tol_mm)
    return probe


#: The allowed step in ``s`` of a probe level no node of which sets one (nothing
#: reachable, or the surface out-curves the cutter all along): the whole range.
UNLIMITED_DS = 1.0


def _levels(probe: ProbeGrid, linking: Linking) -> NDArray[np.float64]:
    """Pass levels in ``s`` from the probe's allowed steps (a spiral looks ahead two)."""
    allowed = np.where(np.isfinite(probe.allowed_ds), probe.allowed_ds, UNLIMITED_DS)
    return pass_levels(probe.s, allowed, lookahead=2.0 if linking is Linking.SPIRAL else 1.0)


def _pass_points(job: _Job, probe: ProbeGrid, layout: PassLayout
                 ) -> tuple[PassPoints, NDArray[np.bool_]]:
    """Points along the passes from the probe's chord density, and which are reachable.

    3-axis: the passes are split where they leave the fixed axis' reach
    (:func:`~toolpath.planning.passes.reach_split`).
    """
    opts = job.opts
    t, pid = _initial_points(layout, probe.t, probe.s, probe.density)
    if t.size > opts.max_points:
        raise too_many_points(opts, t.size)
    if opts.axis_mode is AxisMode.FIXED:
        t, pid, keep = reach_split(job.surface, opts, layout, t, pid)
    else:
        keep = np.ones(t.size, dtype=bool)
    pts = evaluate_points(job.surface, job.cutter, opts, job.res, layout, t, pid)
    return pts, keep


def _cut_runs(job: _Job, layout: PassLayout, pts: PassPoints, keep: NDArray[np.bool_]
              ) -> tuple[list[NDArray[np.int64]], NDArray[np.bool_], list[UnreachableSpan]]:
    """The runs cut (index arrays), the points they cut, and the uncut stretches."""
    closed = bool(job.surface.closed_t)
    runs = _runs_of(keep, pts, closed)
    if not runs:
        raise UnreachableRegionError(
            "no stretch of any pass can be cut (every point faces away from the tool axis "
            "or is shadowed by the part)")
    faces_away = (~_reach(job.opts, pts.frame.normal) if job.opts.axis_mode is AxisMode.FIXED
                  else np.zeros(len(pts), dtype=bool))
    cut = _cut_mask(runs, len(pts))
    return runs, cut, _spans(pts, keep, faces_away, cut, layout)


def _linked_path(job: _Job, probe: ProbeGrid, pts: PassPoints,
                 runs: list[NDArray[np.int64]], gouge: GougeStats) -> Toolpath:
    """The runs linked into a toolpath (leads, links, clearance, rapids).

    With a 5-axis machine and no point lifted, retilted or inserted after the chord check, the
    cutting moves were checked as that machine moves them
    (:func:`~toolpath.planning.passes.refine_chords`): the toolpath says so
    (``joints_checked_for``) and the post leaves them whole.
    """
    surface, cutter, opts, res, mach = job.surface, job.cutter, job.opts, job.res, job.machine
    run_list = _make_runs(surface, cutter, opts, res, pts, runs)
    link_opts = LinkOptions(
        clearance=_clearance(opts, probe), feed_mm_per_min=opts.feed_mm_per_min,
        plunge_feed_mm_per_min=res.plunge_feed_mm_per_min,
        lead_radius_mm=res.lead_radius_mm, lead_angle_deg=opts.lead_angle_deg,
        approach_mm=opts.approach_mm, extend_mm=res.extend_mm,
        chord_tol_mm=res.planned_chord_tol_mm)
    positions, axes, kinds, feeds, passes = link_runs(run_list, link_opts)
    metadata = {"planner": "toolpath.planning.plan_finishing", "cutter": cutter.spec,
                "surface": type(surface).__name__, "scallop_mm": f"{opts.scallop_mm:g}",
                "chord_tol_mm": f"{opts.chord_tol_mm:g}", "axis_mode": opts.axis_mode.value,
                "lead_deg": f"{opts.lead_deg:g}", "tilt_deg": f"{opts.tilt_deg:g}",
                "linking": opts.linking.value}
    checked = (machine_key(mach) if mach is not None and mach.kinematics.is_five_axis
               and not (gouge.n_lifted or gouge.n_retilted or gouge.n_fold_points)
               else None)
    return Toolpath(positions, axes, kinds, feeds, passes, metadata,
                    joints_checked_for=checked)


def _clearance(opts: FinishingOptions, probe: ProbeGrid
               ) -> ClearancePlane | ClearanceSphere:
    """The clearance plane (3-axis) or sphere (5-axis) ``clearance_mm`` beyond the part."""
    corners = probe.frame.point
    if opts.axis_mode is AxisMode.FIXED:
        axis = np.asarray(opts.fixed_axis)
        return ClearancePlane(axis, float((corners @ axis).max()) + opts.clearance_mm)
    lo, hi = points_box(corners)
    centre = 0.5 * (lo + hi)
    off = corners - centre
    radius = float(np.sqrt(np.einsum("ij,ij->i", off, off).max()))
    return ClearanceSphere(centre, radius + opts.clearance_mm, up=_working_side(probe))


@dataclass(frozen=True, eq=False)
class _Stages:
    """What the stages found, for the report.

    ``cut``: the points the runs cut; ``planned_chord_mm``: the chord check's largest gap,
    ``n_stalled``, ``stalled_mm`` the moves it left whole as stalled and their largest gap
    (:class:`~toolpath.planning.passes.RefinedChords`); ``scallop``, ``chord``: the
    measurement (None with ``measure=False``); ``machine``: None without a machine.
    """

    probe: ProbeGrid
    points: PassPoints
    cut: NDArray[np.bool_]
    spans: tuple[UnreachableSpan, ...]
    gouge: GougeStats
    planned_chord_mm: float
    n_stalled: int
    stalled_mm: float
    machine: MachineStats | None
    scallop: ScallopMeasurement | None
    chord: ChordMeasurement | None
    seconds: dict[str, float]


def _tilt_limit_deg(opts: FinishingOptions, mach: Machine | None) -> float:
    """Largest angle of a tool axis from +Z, deg (``inf``: none; 3-axis axes are fixed)."""
    if opts.axis_mode is not AxisMode.LEAD_TILT:
        return float("inf")
    if opts.max_tilt_deg is not None:
        return opts.max_tilt_deg
    if mach is None or not mach.kinematics.is_five_axis:
        return float("inf")
    reach = tilt_reach_deg(mach)
    return float("inf") if reach >= 180.0 else reach - TILT_MARGIN_DEG


def _check_tilt_reach(pts: PassPoints, keep: NDArray[np.bool_], opts: FinishingOptions,
                      res: PlannedOptions, mach: Machine | None) -> None:
    """Refuse a plan with cutter locations no allowed tool axis reaches.

    There the surface normal is further from +Z than the tilt joint reaches plus the lean
    the tool may take from the normal (``max_lean_deg``): the axes were leaned as far as
    allowed (:func:`~toolpath.planning.tool_axis.lean_within_tilt`) and the tilt joint
    still leaves its travel. The error names the first such point, the joint and the best
    value it could take.
    """
    cap = res.max_tilt_deg
    if not np.isfinite(cap) or mach is None or not mach.kinematics.is_five_axis:
        return
    reach_n = angle_deg(pts.frame.normal, np.array([0.0, 0.0, 1.0])) - opts.max_lean_deg
    bad = np.flatnonzero(keep & (reach_n > cap + ANGLE_SLACK_DEG))
    if not bad.size:
        return
    i = int(bad[0])
    letter = mach.kinematics.tilt_letter or ""
    axis = mach.axis(letter)
    negative = -axis.min >= axis.max
    best = float(reach_n[i])
    violation = Violation(index=i, axis=letter, value=-best if negative else best,
                          limit=axis.min if negative else axis.max,
                          side=Side.MIN if negative else Side.MAX, unit=axis.unit,
                          count=int(bad.size),
                          worst=float(-reach_n[bad].max() if negative else reach_n[bad].max()))
    j = int(i - np.flatnonzero(pts.pid == pts.pid[i])[0])
    p = pts.frame.point[i]
    raise PlanTravelLimitError([violation], (
        f"cutter location {i} is pass {int(pts.pid[i])} point {j} (t={pts.t[i]:.5f}, "
        f"s={pts.s[i]:.5f}, contact ({p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}) mm): the surface "
        f"normal there is {best + opts.max_lean_deg:.2f} deg from +Z, and even leaned "
        f"{opts.max_lean_deg:g} deg toward +Z (the most the tool may lean from the normal) "
        f"the tool axis needs axis {letter!r} = {violation.value:.3f} deg at best; set the "
        "part up another way (--placement, or --rotate for toolpath plan), or plan with "
        "--on-limit report"))


#: The mean surface normal must be at least this long to tell the side a part is worked
#: from (a closed blade's normals point all round and cancel).
WORKING_SIDE_MIN = 0.3


def _working_side(probe: ProbeGrid) -> NDArray[np.float64] | None:
    """Area-weighted mean normal of the probe grid (unit), or None when they cancel."""
    weights = probe.area.ravel()
    mean = (weights @ probe.frame.normal) / max(weights.sum(), TINY)
    size = float(np.linalg.norm(mean))
    return mean / size if size >= WORKING_SIDE_MIN else None


def _probe_gouge(probe: ProbeGrid, cutter: Cutter, tol_mm: float) -> Exception:
    """The GougeError for the deepest gouge on the probe grid (a measured depth).

    It names the depth and its place, and the smallest concave radius among the probe
    points that gouge (the largest cutter that fits there).
    """
    gouging, frame, t, s = probe.gouging, probe.frame, probe.t, probe.s
    i = int(np.argmax(np.where(gouging, probe.depth_mm, -1.0)))
    kmax = frame.max_concave_curvature
    j = int(np.argmax(np.where(gouging, kmax, -np.inf)))
    ti, si = np.unravel_index(i, (t.size, s.size))
    tj, sj = np.unravel_index(j, (t.size, s.size))
    p = frame.point[i]
    depth_mm = float(probe.depth_mm[i])
    smallest = 1.0 / float(kmax[j])
    return GougeError(
        f"cutter {cutter.spec} (radius {cutter.radius_mm:g} mm) would cut "
        f"{depth_text(depth_mm)} into the surface at t={t[ti]:.5f}, s={s[si]:.5f} (point "
        f"({p[0]:.3f}, {p[1]:.3f}, {p[2]:.3f}) mm), where the surface's concave radius is "
        f"{1.0 / float(kmax[i]):.4f} mm; it cuts deeper than the gouge tolerance "
        f"{tol_mm:g} mm at {int(gouging.sum())} of {gouging.size} probe points, the smallest "
        f"concave radius among them {smallest:.4f} mm at t={t[tj]:.5f}, s={s[sj]:.5f}; "
        f"{concave_remedy(cutter, smallest)}, --on-gouge lift (lifts the cutter clear, "
        f"leaving material there), or --gouge-tol above {depth_mm:.4f} mm if that is "
        "acceptable",
        t=float(t[ti]), s=float(s[si]), depth_mm=depth_mm)


def _concave_radius(cutter: Cutter, stages: _Stages) -> tuple[float, float]:
    """The smallest concave radius the cutter meets, mm, and the cutter's radius there.

    At its locations and on the probe grid where it cuts (the grid holds the extremes the
    locations may step over); the cutter's curvature there is the local margin plus the
    surface's. ``(inf, cutter radius)`` where nothing is concave.
    """
    pts, probe = stages.points, stages.probe
    cut_at, reach_at = np.flatnonzero(stages.cut), np.flatnonzero(probe.reach)
    kmax = np.r_[pts.frame.max_concave_curvature_at(cut_at),
                 probe.frame.max_concave_curvature_at(reach_at)]
    if not (kmax.size and kmax.max() > 0.0):
        return float("inf"), cutter.radius_mm
    i = int(np.argmax(kmax))
    frame, axes, at = ((pts.frame, pts.axes, cut_at[i]) if i < cut_at.size else
                       (probe.frame, probe.axes, reach_at[i - cut_at.size]))
    margin = float(local_margin(frame_take(frame, np.array([at])), cutter, axes[at][None])[0])
    return 1.0 / float(kmax[i]), 1.0 / max(margin + float(kmax[i]), FLAT_PER_MM)


def _report(job: _Job, stages: _Stages, path: Toolpath) -> PlanningReport:
    """The planning report: the request, what the stages found and the measurement."""
    cutter, opts, res, mach = job.cutter, job.opts, job.res, job.machine
    pts, probe, gouge, machined = stages.points, stages.probe, stages.gouge, stages.machine
    scallop, chord, smoothing = stages.scallop, stages.chord, pts.smoothing
    min_radius, c_there = _concave_radius(cutter, stages)
    area = probe.area.ravel()
    five_axis = opts.axis_mode is AxisMode.LEAD_TILT
    return PlanningReport(
        cutter=str(cutter.spec), axis_mode=opts.axis_mode.value, linking=opts.linking.value,
        scallop_request_mm=opts.scallop_mm, chord_tol_mm=opts.chord_tol_mm,
        n_passes=path.n_passes, n_points=len(path),
        n_cut_points=int((path.pass_index >= 0).sum()),
        max_scallop_mm=None if scallop is None else scallop.max_mm,
        scallop_interior_mm=None if scallop is None else scallop.interior_max_mm,
        scallop_at=None if scallop is None else (scallop.t, scallop.s),
        uncut_fraction=None if scallop is None else scallop.uncut_fraction,
        max_chord_error_mm=None if chord is None else chord.max_mm,
        chord_overcut_mm=None if chord is None else chord.overcut_mm,
        chord_undercut_mm=None if chord is None else chord.undercut_mm,
        chord_worst_point=None if chord is None else chord.worst_point,
        planned_chord_error_mm=stages.planned_chord_mm,
        min_clearance_mm=gouge.min_clearance_mm,
        min_concave_radius_mm=min_radius, cutter_radius_there_mm=c_there,
        n_lifted=gouge.n_lifted, max_lift_mm=gouge.max_lift_mm,
        n_retilted=gouge.n_retilted, n_fold_points=gouge.n_fold_points,
        max_fold_lift_mm=gouge.max_fold_lift_mm, unreachable_spans=stages.spans,
        unreachable_regions=merge_spans(list(stages.spans)),
        unreachable_fraction=float(area[~probe.reach].sum() / max(area.sum(), TINY)),
        max_axis_rate_deg_per_mm=(smoothing.max_rate_deg_per_mm
                                  if five_axis and smoothing is not None else None),
        cone_pushed=pts.cone_pushed,
        machine=None if machined is None else machined.name,
        travel_violations=() if machined is None else machined.travel,
        rate_violations=() if machined is None else machined.rates,
        estimated_time_s=None if machined is None else machined.time_s,
        length_mm=path.length_mm, cutting_length_mm=path.cutting_length_mm,
        seconds=dict(stages.seconds), gouge_tol_mm=opts.gouge_tol_mm,
        axis_rate_limit_deg_per_mm=opts.max_axis_rate_deg_per_mm if five_axis else None,
        tilt_leaned_points=0 if smoothing is None else smoothing.tilt_leaned_points,
        max_tilt_lean_deg=0.0 if smoothing is None else smoothing.max_tilt_lean_deg,
        max_tilt_deg=res.max_tilt_deg if np.isfinite(res.max_tilt_deg) else None,
        rounding_reserve_mm=job.reserve_mm, planned_scallop_mm=res.planned_scallop_mm,
        planned_chord_tol_mm=res.planned_chord_tol_mm, advice=probe.advice,
        linking_reason=job.linking_reason,
        rotary_rates=(rotary_rates(path, mach) if mach is not None
                      and mach.kinematics.is_five_axis else None),
        blunt_face=blunt_face(job.surface, opts.chord_tol_mm),
        n_stalled_moves=stages.n_stalled, stalled_gap_mm=stages.stalled_mm)
