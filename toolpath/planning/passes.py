"""Cutter locations along the passes: contacts, tool axes, tips, chord refinement, reach.

A pass ``k`` runs over ``t`` in [0, 1] at ``s = s_start[k] + (s_end[k] - s_start[k]) t``
(constant for zig-zag and one-way; rising by one level gap per ring for a spiral), in the
direction ``direction[k]`` (+1: increasing ``t``). Points are kept sorted by pass, then
``t``; :class:`PassPoints` holds their geometry and is rebuilt by merging when points are
inserted (chord splits, reach boundaries), so nothing already evaluated is recomputed.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, fields, replace

import numba
import numpy as np
from numpy.typing import NDArray

from machines import Machine
from machines.kinematics import InverseSolution, forward, solve_inverse

from ..surface import ParametricSurface
from ..tolerances import ROUND_OFF, TINY
from ..vectors import move_poses
from .cutters import Cutter, CutterKind
from .errors import PlanningError, too_many_points
from .local import PassFrame, pass_frame, tangent_frame
from .one_way import one_way_azimuth
from .options import TILT_MARGIN_DEG, AxisMode, FinishingOptions, Linking, PlannedOptions
from .roots import illinois_roots
from .sampling import (
    CHORD_FRACTIONS,
    ball_end_slopes,
    chord_extremes,
    joint_moves,
    point_move_gaps,
    split_evenly,
)
from .scallop import undercut_limit_mm
from .tool_axis import (
    Z_AXIS,
    AxisSmoothing,
    TiltLean,
    angle_deg,
    keep_out_of_cone,
    lead_tilt_axes,
    lean_interpolated,
    lean_within_tilt,
    limit_lean,
    segment_turn_rates,
    slerp,
    smooth_axes,
)

__all__ = [
    "PassLayout",
    "PassPoints",
    "RefinedChords",
    "evaluate_points",
    "final_axes",
    "frame_take",
    "insert_points",
    "insert_rows",
    "middle_past_tilt",
    "nominal_axes",
    "reach_height",
    "refine_chords",
    "reach_split",
    "with_tips",
]


#: Where the chord check measures a ball's gap when the end slopes complete the model
#: (:func:`~toolpath.planning.sampling.ball_end_slopes`).
BALL_FRACTIONS = (0.5,)

#: A model's extreme this close (in ``u``) to a measured gap is not measured again: the
#: gap there differs from the one measured by about ``|g''| du^2 / 2``, 1 % of a
#: parabola's depth, and the model, through the measurement, carries even that.
MEASURED_NEAR_U = 0.05

#: Refinement rounds; each halves the offending chords, so 12 rounds shrink one 4096-fold.
MAX_CHORD_ROUNDS = 12
#: A move :data:`STALLED_SPLITS` splits down a line whose gap's excess over its limit is
#: still above this share of the line's first move's is not split again
#: (:func:`_not_shrunk`; flat and bull-nose cutters). A chord's gap falls with the square
#: of its length (a part of ``p`` keeps ``1 / p^2 <= 1/4`` of it; where the cutter's
#: lowest point jumps, a kink, ``1 / p <= 1/2``); where a flat end's lowest point moves
#: along with the split, slower (dev_rotor_dca flat:6: 0.8-0.9 a split, 0.6 over three,
#: then it settles). One that does not fall at all is not the chord's: the cutter there
#: stands off or sinks in whatever the length (a gap measured beside an edge: dev_prop
#: flat:6 read 1 mm over five splits), and splitting it multiplies points 8-fold a round.
STALLED_SHARE = 0.8
STALLED_SPLITS = 3
#: ... and only once the splits have shrunk the move to at most this share of its line's
#: first move (its travel: tip path plus ``R`` times the axis turn, :func:`_travel_mm`).
#: Splits are even in ``t``; where the turn is gathered at one end of a move (a blunt
#: leading edge's small circle under joint interpolation: C turning 16 degrees, 13.5 of
#: them over the last quarter) the first splits leave most of it, and the gap, in one
#: part: dev_rotor_blunt bull:6:1 on trunnion-ac was left whole at 0.085 mm (tolerance
#: 0.05) three splits down, its travel still 70 % of the first move's (another, 0.069
#: mm, between a quarter and half). A gap that stands whatever the length still stops
#: three splits down: the move is then an eighth of its first or less.
STALLED_TRAVEL_SHARE = 0.25
#: ... and only where the move's own ends read at least this share of its gap (the cutter
#: at the points themselves, a move of length 0): a gap that does not fall with the length
#: is there at length 0 too. Where the ends sit on the surface the gap is the chord's, and
#: splitting shrinks it with the square of the length however it grew on the way (a joint
#: move whose axes turn where the splits gathered: dev_rotor_dca flat:6 on head-table-bc
#: read 0.127 mm against 0.05, its ends 0, three splits down; left whole, it cut 0.79 mm).
STALLED_END_SHARE = 0.5
#: With a 5-axis machine, the most a cutting move's joint interpolation may carry the tip
#: sideways, across the pass (it widens the stepover: 0.002 mm on a 0.35 mm stepover raises
#: the cusp by 1 %); along the normal the gap check sees it, along the feed it is harmless.
JOINT_SIDEWAYS_MM = 0.002
#: The tilt cap's and the sideways criteria (:func:`_moves_to_split`) split a line of moves
#: at most this many times: a split at least halves a part's turn and joint bow, so what
#: they measure falls at least 4-fold a split (6 splits: 4096-fold). One still there
#: deeper lies across a jump of the axes between neighbouring contacts, which no split
#: shrinks: a 4-section cut of dev_rotor_dca (flat:6, head-table-bc, the leading edge
#: leaned back to the B cap) split such moves in two every round, 0.45 million points to
#: 0.93 million in the last two rounds looked at (15 minutes in the chord check), their
#: ends 1.6e-5 apart in t and still turning C 4.5 degrees. Left whole, the post and the
#: check judge the move against the machine's travel.
MOTION_SPLITS = 6
#: An offending move is split into parts whose gap, scaling with the square of the
#: length, is this share of its limit (at least 2 parts, at most :data:`MAX_PARTS`).
SPLIT_TARGET = 0.8
MAX_PARTS = 8
#: Moves shorter than this (mm, a G-code program's 3-decimal resolution; the tip's travel
#: plus the cutter radius times the axis turn) are not split.
MIN_SPLIT_MM = 1e-3
#: A checked chord is checked again when its ends move (tip, plus the cutter radius times
#: the axis change) by more than this share of the chord tolerance.
MOVED_SHARE = 0.01


@dataclass(frozen=True)
class PassLayout:
    """Where the passes lie and which way they run (arrays of length ``n_passes``)."""

    s_start: NDArray[np.float64]
    s_end: NDArray[np.float64]
    direction: NDArray[np.int64]

    def s_of(self, t: NDArray[np.float64], pid: NDArray[np.int64]) -> NDArray[np.float64]:
        """``s`` of points ``t`` on passes ``pid``."""
        return self.s_start[pid] + (self.s_end[pid] - self.s_start[pid]) * t

    @property
    def n_passes(self) -> int:
        """Number of passes."""
        return len(self.s_start)


@dataclass(frozen=True, eq=False)
class PassPoints:
    """Contacts and cutter locations, sorted by pass then ``t``.

    Attributes
    ----------
    t, s : ndarray, shape (n,)
        Surface parameters of the contacts.
    pid : ndarray of int, shape (n,)
        Pass of each point.
    frame : PassFrame
        Surface geometry at the contacts.
    nominal, axes : ndarray, shape (n, 3)
        Lead/tilt (or fixed) axes, and the final ones after smoothing and the cone.
    tips : ndarray, shape (n, 3)
        Cutter locations, mm.
    direction : ndarray of int, shape (n,)
        Travel direction of each point's pass (+1: increasing ``t``).
    smoothing : AxisSmoothing or None
        What the 5-axis smoothing did.
    cone_pushed : int
        Axes moved out of the singular cone.
    """

    t: NDArray[np.float64]
    s: NDArray[np.float64]
    pid: NDArray[np.int64]
    frame: PassFrame
    nominal: NDArray[np.float64]
    axes: NDArray[np.float64]
    tips: NDArray[np.float64]
    direction: NDArray[np.int64]
    smoothing: AxisSmoothing | None = None
    cone_pushed: int = 0

    def __len__(self) -> int:
        return len(self.t)

    @property
    def same_pass(self) -> NDArray[np.bool_]:
        """Whether point ``i`` and ``i + 1`` are on the same pass (length ``n - 1``)."""
        return self.pid[1:] == self.pid[:-1]

    @property
    def feed_dirs(self) -> NDArray[np.float64]:
        """Unit feed directions (``e1`` times the pass direction)."""
        return self.frame.e1 * self.direction[:, None]


def frame_take(frame: PassFrame, idx: NDArray[np.int64]) -> PassFrame:
    """The frame at points ``idx``."""
    return PassFrame(**{f.name: getattr(frame, f.name)[idx] for f in fields(frame)})


def insert_rows(old: NDArray[np.float64], new: NDArray[np.float64],
                new_at: NDArray[np.int64]) -> NDArray[np.float64]:
    """``new``'s rows at the (increasing) rows ``new_at`` of the result, ``old``'s between.

    In one compiled pass copying the runs of old rows whole: a few new rows among many
    cost about a copy (numpy's scatter of (n, 3) rows is four times slower).
    """
    _check_places(new_at, new.shape[0], old.shape[0] + new.shape[0])
    return _merge_checked(old, new, new_at)


def _check_places(new_at: NDArray[np.int64], n_new: int, size: int) -> None:
    """``new_at``: ``n_new`` increasing rows among ``size``, or a ValueError."""
    if new_at.size != n_new or (new_at.size and not (
            new_at[0] >= 0 and new_at[-1] < size and (np.diff(new_at) > 0).all())):
        raise ValueError(f"{n_new} new rows at {new_at.size} increasing places "
                         f"among {size} rows")


def _merge_checked(old: NDArray[np.float64], new: NDArray[np.float64],
                   new_at: NDArray[np.int64]) -> NDArray[np.float64]:
    """:func:`insert_rows` of places already checked."""
    if new.shape[1:] != old.shape[1:]:
        raise ValueError(f"rows of shape {new.shape[1:]} cannot go among rows of shape "
                         f"{old.shape[1:]}")
    size = old.shape[0] + new.shape[0]
    out = np.empty((size, *old.shape[1:]), dtype=old.dtype)
    width = 1
    for extent in old.shape[1:]:  # (single values: rows of one)
        width *= extent
    if width == 0:
        return out
    # copied as 8-byte words whatever they hold (float or integer: one compiled kernel),
    # bytes where the values are not 8 bytes wide
    word = np.dtype(np.int64 if old.dtype.itemsize == 8 else np.uint8)
    words = width * (old.dtype.itemsize // word.itemsize)
    _merge_rows(np.ascontiguousarray(old).reshape(-1).view(word),
                np.ascontiguousarray(new, dtype=old.dtype).reshape(-1).view(word),
                np.ascontiguousarray(new_at, dtype=np.int64), out.reshape(-1).view(word), words)
    return out


#: Merged rows per block of :func:`_merge_rows` (each block finds its first new row).
MERGE_BLOCK = 16384


@numba.njit(cache=True)
def _merge_rows(old, new, new_at, out, width):
    """The rows of ``width`` words of flat arrays: runs of old rows copied whole."""
    size = out.size // width
    for block in range((size + MERGE_BLOCK - 1) // MERGE_BLOCK):
        lo = block * MERGE_BLOCK
        hi = min(lo + MERGE_BLOCK, size)
        j = _first_at_least(new_at, lo)  # the first new row at or after lo
        row, j_old = lo, lo - j
        while j < new_at.size and new_at[j] < hi:
            run = new_at[j] - row  # old rows before new row j
            _copy_words(old, j_old * width, out, row * width, run * width)
            j_old += run
            _copy_words(new, j * width, out, new_at[j] * width, width)
            row = new_at[j] + 1
            j += 1
        _copy_words(old, j_old * width, out, row * width, (hi - row) * width)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _first_at_least(ascending, value):
    """The first index whose entry is >= ``value``: ``np.searchsorted`` of integers.

    Bisection. (numba's ``np.searchsorted`` compiles its generic comparison, complex
    numbers' included: about 0.5 CPU s of a cold start, issue 27.)
    """
    lo, hi = 0, ascending.size
    while lo < hi:
        mid = (lo + hi) >> 1
        if ascending[mid] < value:
            lo = mid + 1
        else:
            hi = mid
    return lo


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _copy_words(src, src_at, dst, dst_at, count):
    """``dst[dst_at:dst_at + count] = src[src_at:src_at + count]`` as a loop.

    (numba's slice assignment compiles its general broadcasting copy: about 3 CPU s of
    a cold start, issue 27.)
    """
    for k in range(count):
        dst[dst_at + k] = src[src_at + k]


def _kept_with_new(mask: NDArray[np.bool_], where_new: NDArray[np.int64]
                   ) -> NDArray[np.bool_]:
    """``mask`` of the points before an insertion, on the merged points: new ones kept."""
    out = np.ones(len(mask) + len(where_new), dtype=bool)
    old = np.ones(out.size, dtype=bool)
    old[where_new] = False
    out[old] = mask
    return out


def nominal_axes(opts: FinishingOptions, normals: NDArray[np.float64],
                 feed_dirs: NDArray[np.float64]) -> NDArray[np.float64]:
    """The tool axes the options ask for before any smoothing, shape (n, 3).

    ``--fixed-axis``: that axis everywhere; else the surface ``normals`` led by
    ``opts.lead_deg`` along the unit ``feed_dirs`` and tilted by ``opts.tilt_deg``
    (:func:`~toolpath.planning.tool_axis.lead_tilt_axes`).
    """
    if opts.axis_mode is AxisMode.FIXED:
        return np.broadcast_to(np.asarray(opts.fixed_axis), normals.shape).copy()
    return lead_tilt_axes(normals, feed_dirs, opts.lead_deg, opts.tilt_deg)


@numba.njit(cache=True)
def _arclen_rows(points, normals, lift, pid, out):
    """Polyline length from the start of each pass of the points lifted along the normals."""
    for i in range(points.shape[0]):
        if i == 0 or pid[i] != pid[i - 1]:
            out[i] = 0.0
            continue
        out[i] = out[i - 1] + _lifted_distance(points, normals, i - 1, points, normals, i, lift)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _lifted_distance(points_a, normals_a, i, points_b, normals_b, j, lift):
    """Distance from row ``i`` of one set to row ``j`` of another, both lifted ``lift``."""
    size2 = 0.0
    for k in range(3):
        d = ((points_b[j, k] + lift * normals_b[j, k])
             - (points_a[i, k] + lift * normals_a[i, k]))
        size2 += d * d
    return math.sqrt(size2)


def _split_fractions(old: PassFrame, new: PassFrame, after_old: NDArray[np.int64],
                     lift_mm: float) -> NDArray[np.float64]:
    """Where each new point lies along the move it splits, as a share of the rate's path.

    New points (sorted) go before the old rows ``after_old``; those sharing one split the
    move from old row ``after_old - 1`` to it. The path is that of the points moved
    ``lift_mm`` along the normals (:func:`_rate_path`), through the new points in order
    (0 for new points before the first or after the last old row).
    """
    out = np.zeros(len(after_old))
    _split_fraction_rows(*(np.ascontiguousarray(v, dtype=float) for v in (
        old.point, old.normal, new.point, new.normal)), float(lift_mm),
        np.ascontiguousarray(after_old, dtype=np.int64), out)
    return out


@numba.njit(cache=True)
def _split_fraction_rows(old_points, old_normals, new_points, new_normals, lift, after_old,
                         out):
    # (np.int64: a bare 0 is typed Literal[int](0) at first, and _lifted_distance was
    # compiled for that too)
    j = np.int64(0)
    while j < after_old.size:
        end = j  # new points j .. end split the move ending at old row after_old[j]
        while end + 1 < after_old.size and after_old[end + 1] == after_old[j]:
            end += 1
        a = after_old[j]
        if 0 < a < old_points.shape[0]:  # (not between two points: callers avoid it)
            total = _lifted_distance(old_points, old_normals, a - 1, new_points, new_normals,
                                     j, lift)
            out[j] = total
            for q in range(j + 1, end + 1):
                total += _lifted_distance(new_points, new_normals, q - 1, new_points,
                                          new_normals, q, lift)
                out[q] = total
            total += _lifted_distance(new_points, new_normals, end, old_points, old_normals,
                                      a, lift)
            for q in range(j, end + 1):
                out[q] /= max(total, TINY)
        j = end + 1


@numba.njit(cache=True)
def _insertion_rows(pid, t, pid_new, t_new):
    """For each new point, the old points ordered before it: (pass, t) no greater.

    Both sorted by pass then ``t``; a binary search per new point.
    """
    out = np.empty(pid_new.size, dtype=np.int64)
    for j in range(pid_new.size):
        lo, hi = 0, pid.size
        while lo < hi:
            mid = (lo + hi) // 2
            if pid[mid] < pid_new[j] or (pid[mid] == pid_new[j] and t[mid] <= t_new[j]):
                lo = mid + 1
            else:
                hi = mid
        out[j] = lo
    return out


def _rate_path(cutter: Cutter, frame: PassFrame, pid: NDArray[np.int64]
               ) -> NDArray[np.float64]:
    """The path the axis turn rate is measured on.

    Per mm of the corner-circle centre's path (a ball's centre): what the machine moves at
    the feed.
    """
    out = np.empty(len(pid))
    _arclen_rows(np.ascontiguousarray(frame.point, dtype=float),
                 np.ascontiguousarray(frame.normal, dtype=float),
                 float(cutter.corner_radius_mm), np.ascontiguousarray(pid), out)
    return out


def _off_cone(opts: FinishingOptions, axes: NDArray[np.float64], frame: PassFrame,
              direction: NDArray[np.int64]) -> tuple[NDArray[np.float64], int]:
    """Axes pushed out of the singular cone (when asked), the lean limit still kept."""
    if not opts.min_cone_deg:
        return axes, 0
    axes, pushed = keep_out_of_cone(axes, opts.min_cone_deg, frame.e1 * direction[:, None])
    # pushing must not break the lean limit: where it would, the lean wins
    axes, _ = limit_lean(axes, frame.normal, opts.max_lean_deg)
    return axes, pushed


def final_axes(cutter: Cutter, opts: FinishingOptions, res: PlannedOptions,
               frame: PassFrame, nominal: NDArray[np.float64], pid: NDArray[np.int64],
               direction: NDArray[np.int64]
               ) -> tuple[NDArray[np.float64], AxisSmoothing | None, int]:
    """The axes the cutter will have, from the nominal ones.

    In 5-axis, smoothed along each pass, rate and lean limited, kept off the singular cone,
    and for a spiral turned about +Z one way only (:mod:`~toolpath.planning.one_way`)
    (unchanged in 3-axis). Points in pass order (``pid`` contiguous, ``t`` ascending).
    Returns the axes, the smoothing record and how many axes were pushed off the cone.
    """
    if opts.axis_mode is not AxisMode.LEAD_TILT or len(pid) < 2:
        return nominal, None, 0
    smoothing = smooth_axes(nominal, frame.normal, frame.e1 * direction[:, None],
                            _rate_path(cutter, frame, pid), pid,
                            smoothing_mm=res.axis_smoothing_mm,
                            max_rate_deg_per_mm=opts.max_axis_rate_deg_per_mm,
                            max_lean_deg=opts.max_lean_deg,
                            keep_lead=cutter.kind is not CutterKind.BALL)
    axes, pushed = _off_cone(opts, smoothing.axes, frame, direction)
    lean = _within_tilt(opts, res, axes, frame, pid, cutter, smooth=True)
    if lean is not None:
        axes = lean.axes
        smoothing = replace(smoothing, tilt_leaned_points=int((lean.lean_deg > 0.0).sum()),
                            max_tilt_lean_deg=float(lean.lean_deg.max()))
    if opts.linking is Linking.SPIRAL:
        # one continuous cut: the table turns one way (the points are in cutting order)
        axes = one_way_azimuth(axes, frame.normal, opts.max_lean_deg).axes
    return axes, smoothing, pushed


def _within_tilt(opts: FinishingOptions, res: PlannedOptions, axes: NDArray[np.float64],
                 frame: PassFrame, pid: NDArray[np.int64], cutter: Cutter, *, smooth: bool
                 ) -> TiltLean | None:
    """Axes leaned back within the machine's tilt reach (``res.max_tilt_deg``), if any.

    Smoothed along the passes (:func:`~toolpath.planning.tool_axis.lean_within_tilt`)
    when ``smooth`` (the points are whole passes); else each point leans by its own need
    (points inserted between two axes within the reach need little or none).
    """
    cap = res.max_tilt_deg
    if not math.isfinite(cap) or not (angle_deg(axes, Z_AXIS) > cap).any():
        return None
    lean = lean_within_tilt(axes, frame.normal, _rate_path(cutter, frame, pid), pid,
                            max_tilt_deg=cap, max_lean_deg=opts.max_lean_deg,
                            smoothing_mm=res.axis_smoothing_mm if smooth else 0.0,
                            max_rate_deg_per_mm=opts.max_axis_rate_deg_per_mm,
                            moves=smooth)
    return lean


def _finish(cutter: Cutter, opts: FinishingOptions, res: PlannedOptions, layout: PassLayout,
            t: NDArray[np.float64], s: NDArray[np.float64], pid: NDArray[np.int64],
            frame: PassFrame, nominal: NDArray[np.float64]) -> PassPoints:
    """Axes (smoothing, cone) and tips for evaluated contacts."""
    direction = layout.direction[pid]
    axes, smoothing, pushed = final_axes(cutter, opts, res, frame, nominal, pid, direction)
    tips = cutter.tips_from_contacts(frame.point, frame.normal, axes)
    return PassPoints(t=t, s=s, pid=pid, frame=frame, nominal=nominal, axes=axes, tips=tips,
                      direction=direction, smoothing=smoothing,
                      cone_pushed=pushed)


def evaluate_points(surface: ParametricSurface, cutter: Cutter, opts: FinishingOptions,
                    res: PlannedOptions, layout: PassLayout, t: NDArray[np.float64],
                    pid: NDArray[np.int64]) -> PassPoints:
    """Evaluate contacts ``(t, pid)`` (sorted by pass then ``t``) from scratch."""
    s = layout.s_of(t, pid)
    frame = pass_frame(surface, t, s)
    nominal = nominal_axes(opts, frame.normal, frame.e1 * layout.direction[pid][:, None])
    return _finish(cutter, opts, res, layout, t, s, pid, frame, nominal)


def insert_points(surface: ParametricSurface, cutter: Cutter, opts: FinishingOptions,
                  res: PlannedOptions, layout: PassLayout, pts: PassPoints,
                  t_new: NDArray[np.float64], pid_new: NDArray[np.int64]
                  ) -> tuple[PassPoints, NDArray[np.int64], bool]:
    """Merge new contacts into ``pts``.

    Returns the points, the new ones' indices and whether the old points kept their axes
    and tips.

    In 5-axis the points already there keep their axes (and tips): new points strictly
    inside a move take the axis slerped between the move's ends in proportion to the
    corner-circle centre's path (the rate's path, so no piece turns faster than the move),
    lean-limited and kept off the cone like the others. A flat or bull-nose face's axis
    goes round the normal instead, keeping its lean (:func:`lean_interpolated`): its
    contact stays on the rim, so the tip moves as far as the axis turns and a move split
    often enough is cut as planned. Smoothing and rate limiting
    everything again would move every other tip by a little and make the chord check
    start over.

    The smoothing record's rate figures (``max_rate_deg_per_mm``, ``worst_point``) are
    then stale: callers measure them once their insertions are done
    (:func:`with_rate_record`).
    """
    order = np.lexsort((t_new, pid_new))
    t_new, pid_new = t_new[order], pid_new[order]  # sorted by pass then t, like pts
    s_new = layout.s_of(t_new, pid_new)
    frame = pass_frame(surface, t_new, s_new)
    direction = layout.direction[pid_new]
    nominal = nominal_axes(opts, frame.normal, frame.e1 * direction[:, None])
    # where each new point goes: after the old points of its pass up to its t
    after_old = _insertion_rows(pts.pid, pts.t, pid_new, t_new)
    new_at = after_old + np.arange(t_new.size)  # (in the merged points, increasing)
    where_new = np.empty_like(new_at)
    where_new[order] = new_at  # in the caller's order
    # the old points on either side of each new one (several new ones may share a move)
    before, after = np.maximum(after_old - 1, 0), np.minimum(after_old, len(pts) - 1)
    between = ((after_old > 0) & (after_old < len(pts)) & (pts.pid[before] == pid_new)
               & (pts.pid[after] == pid_new))
    smoothing, pushed = pts.smoothing, 0
    if opts.axis_mode is not AxisMode.LEAD_TILT:
        axes = nominal  # fixed axes: the old points keep theirs and their tips
    elif pts.smoothing is None or not between.all():
        # smoothed again: the old points' axes may move (the tips are replaced)
        merged = _merge_points(pts, PassPoints(
            t=t_new, s=s_new, pid=pid_new, frame=frame, nominal=nominal, axes=nominal,
            tips=frame.point, direction=direction), new_at)
        return (_finish(cutter, opts, res, layout, merged.t, merged.s, merged.pid,
                        merged.frame, merged.nominal), where_new, False)
    else:
        # by arc length of the path the turn rate is measured on, turning at a uniform
        # rate (spherical interpolation): the pieces of a move then turn no faster than it
        w = _split_fractions(pts.frame, frame, after_old, cutter.corner_radius_mm)
        if cutter.kind is CutterKind.BALL:
            axes = slerp(pts.axes[before], pts.axes[after], w)
        else:
            # a flat face keeps its lean: where the normal turns faster than the axes (a
            # leading edge) a slerp leans less, and the contact jumps across the face
            axes = lean_interpolated(
                pts.axes[before], pts.frame.normal[before],
                pts.frame.e1[before] * pts.direction[before][:, None],
                pts.axes[after], pts.frame.normal[after],
                pts.frame.e1[after] * pts.direction[after][:, None], w, frame.normal,
                frame.e1 * direction[:, None])
        axes, limited = limit_lean(axes, frame.normal, opts.max_lean_deg)
        axes, pushed = _off_cone(opts, axes, frame, direction)
        # (the rate figures are measured once the insertions are done: with_rate_record)
        smoothing = replace(pts.smoothing,
                            limited_points=pts.smoothing.limited_points + int(limited.sum()))
        lean = _within_tilt(opts, res, axes, frame, pid_new, cutter, smooth=False)
        if lean is not None:
            axes = lean.axes
            smoothing = replace(
                smoothing, tilt_leaned_points=smoothing.tilt_leaned_points
                + int((lean.lean_deg > 0.0).sum()), max_tilt_lean_deg=max(
                    smoothing.max_tilt_lean_deg, float(lean.lean_deg.max())))
    tips = cutter.tips_from_contacts(frame.point, frame.normal, axes)
    new = PassPoints(t=t_new, s=s_new, pid=pid_new, frame=frame, nominal=nominal, axes=axes,
                     tips=tips, direction=direction, smoothing=smoothing,
                     cone_pushed=pts.cone_pushed + pushed)
    return _merge_points(pts, new, new_at), where_new, True


def insert_move_poses(surface: ParametricSurface, pts: PassPoints, keep: NDArray[np.bool_],
                      after: NDArray[np.int64], u: NDArray[np.float64]
                      ) -> tuple[PassPoints, NDArray[np.bool_], NDArray[np.int64]]:
    """The cutter's poses inside moves ``after -> after + 1`` (increasing, one each) merged in.

    At fraction ``u`` of each move the pose is the move's own: tip and axis interpolated
    linearly (the axis normalised: :func:`~toolpath.vectors.move_poses`), as the controller
    cuts the move; its surface parameters ``(t, s)`` interpolated too (the frame there
    stands for the contact). Returns the points, ``keep`` on them (the new ones kept) and
    the new points' rows.
    """
    b = after + 1
    tips, axes = move_poses(pts.tips[after], pts.axes[after], pts.tips[b], pts.axes[b], u)
    t = pts.t[after] * (1.0 - u) + pts.t[b] * u
    s = pts.s[after] * (1.0 - u) + pts.s[b] * u
    new = PassPoints(t=t, s=s, pid=pts.pid[after], frame=pass_frame(surface, t, s),
                     nominal=axes, axes=axes, tips=tips,
                     direction=pts.direction[after], smoothing=pts.smoothing,
                     cone_pushed=pts.cone_pushed)
    new_at = after + 1 + np.arange(after.size)
    return _merge_points(pts, new, new_at), _kept_with_new(keep, new_at), new_at


#: The per-point arrays of :class:`PassPoints` (the frame apart).
_ROW_FIELDS = tuple(f.name for f in fields(PassPoints)
                    if f.name not in ("frame", "smoothing", "cone_pushed"))


def _merge_points(pts: PassPoints, new: PassPoints, new_at: NDArray[np.int64]
                  ) -> PassPoints:
    """``new``'s points at rows ``new_at`` (increasing) of the result, ``pts``' between.

    The smoothing record and the cone count are ``new``'s (they hold the totals), the
    record's axes the merged ones.
    """
    _check_places(new_at, len(new), len(pts) + len(new))
    rows = {name: _merge_checked(getattr(pts, name), getattr(new, name), new_at)
            for name in _ROW_FIELDS}
    frame = PassFrame(**{f.name: _merge_checked(getattr(pts.frame, f.name),
                                                getattr(new.frame, f.name), new_at)
                         for f in fields(pts.frame)})
    smoothing = None if new.smoothing is None else replace(new.smoothing, axes=rows["axes"])
    return PassPoints(frame=frame, smoothing=smoothing, cone_pushed=new.cone_pushed, **rows)


def _take_points(pts: PassPoints, rows: NDArray[np.int64]) -> PassPoints:
    """The points ``rows`` (increasing), with the smoothing record and cone count."""
    taken = {name: getattr(pts, name)[rows] for name in _ROW_FIELDS}
    smoothing = (None if pts.smoothing is None
                 else replace(pts.smoothing, axes=taken["axes"]))
    return PassPoints(frame=frame_take(pts.frame, rows), smoothing=smoothing,
                      cone_pushed=pts.cone_pushed, **taken)


def _travel_mm(cutter: Cutter, tips_a: NDArray[np.float64], tips_b: NDArray[np.float64],
               axes_a: NDArray[np.float64], axes_b: NDArray[np.float64]) -> NDArray[np.float64]:
    """How far the cutter goes from pose ``a`` to ``b``: the tip, plus ``R`` times the axis."""
    return (np.linalg.norm(tips_b - tips_a, axis=1)
            + cutter.radius_mm * np.linalg.norm(axes_b - axes_a, axis=1))


def _sideways_mm(machine: Machine, pts: PassPoints, joints: NDArray[np.float64],
                 idx: NDArray[np.int64]) -> NDArray[np.float64]:
    """How far joint interpolation moves the tip sideways (across the pass) at mid-move."""
    middle, _ = forward(machine, 0.5 * (joints[idx] + joints[idx + 1]))
    chord = pts.tips[idx + 1] - pts.tips[idx]
    side = np.cross(pts.axes[idx] + pts.axes[idx + 1], chord)
    side /= np.maximum(np.linalg.norm(side, axis=1, keepdims=True), TINY)
    off = middle - 0.5 * (pts.tips[idx] + pts.tips[idx + 1])
    return np.abs(np.einsum("ij,ij->i", off, side))


@dataclass(frozen=True, eq=False)
class RefinedChords:
    """What the chord check hands on: the points, their mask and the planned chord error.

    Attributes
    ----------
    points : PassPoints
        The points with the split moves' new points merged in.
    keep : ndarray of bool or None
        The reachable-points mask on ``points`` (new points kept), None when none was given.
    worst_mm : float
        The largest ``|gap|`` (the model's extreme, measured where near a limit) over the
        moves left whole, in whichever round they were checked: every final move (an upper
        bound where an insertion smoothed the axes again and moved a checked move's ends).
        Stalled moves' gaps count.
    n_stalled : int
        Moves beyond the tolerance left whole because splitting did not shrink their gap
        and their ends read it too (:data:`STALLED_SHARE`, :data:`STALLED_END_SHARE`).
    stalled_mm : float
        The largest ``|gap|`` among them (0 when none).
    """

    points: PassPoints
    keep: NDArray[np.bool_] | None
    worst_mm: float
    n_stalled: int = 0
    stalled_mm: float = 0.0


def refine_chords(surface: ParametricSurface, cutter: Cutter, opts: FinishingOptions,
                  res: PlannedOptions, layout: PassLayout, pts: PassPoints,
                  keep: NDArray[np.bool_] | None = None, machine: Machine | None = None,
                  *, max_rounds: int = MAX_CHORD_ROUNDS) -> RefinedChords:
    """Split chords whose mid-chord cutter-to-surface gap exceeds the chord tolerance.

    Each round measures the moves still to check (:func:`_gap_extremes`), picks those to
    split (:func:`_moves_to_split`), splits them into equal parameter steps, as many as the
    gap's excess needs (:data:`SPLIT_TARGET`), and checks again only the new moves and
    those whose ends moved (:func:`_checked_again`). ``keep`` (reachable points) travels
    along: a chord between two kept points is checked; an inserted point is kept. After
    ``max_rounds`` rounds (:data:`MAX_CHORD_ROUNDS`) the parts of the moves split last go
    unchecked, and the gaps of the whole moves stand for them in ``worst_mm``.

    A part of a split move whose gap did not shrink with its length, several splits running
    (:func:`_not_shrunk`: flat and bull-nose cutters), and stands at its own ends too
    (:func:`_end_gaps_mm`), is left whole: its gap is not the chord's, and it counts in
    ``worst_mm`` and ``n_stalled``; so the points grow only where splitting helps.

    After the first round the split moves go on alone (``pts`` then holds their ends and
    new points, ``origin`` the rows of the starting points the ends are, -1 for new points)
    and are merged into the others once, at the end: merging each round copies every point
    (memory-bound, 0.1 us a point). Joints along a 5-axis machine's path are solved along
    the whole path: its tips and axes alone are merged for them (:func:`_joints_along`).
    Not where an insertion would smooth the axes again (lead/tilt axes without a
    smoothing record): every point may then move.
    """
    tol = res.planned_chord_tol_mm
    start, keep_start = pts, keep
    five_axis = machine is not None and machine.kinematics.is_five_axis
    defer = opts.axis_mode is not AxisMode.LEAD_TILT or pts.smoothing is not None
    origin: NDArray[np.int64] | None = None
    start_joints: InverseSolution | None = None
    check = np.ones(max(len(pts) - 1, 0), dtype=bool)
    worst = unchecked = stalled_mm = 0.0
    n_stalled = 0
    # per point: the excess and travel of the move its line of splits started from (0:
    # none), and how many splits deep it is
    first_over, first_travel = np.zeros(len(pts)), np.zeros(len(pts))
    depth = np.zeros(len(pts), dtype=np.int64)
    for _ in range(max_rounds):
        seg_ok = pts.same_pass & check
        if keep is not None:
            seg_ok &= keep[:-1] & keep[1:]
        idx = np.flatnonzero(seg_ok)
        if not idx.size:
            break
        q = None
        if five_axis:
            solved = _joints_along(machine, start, pts, origin, start_joints)
            if pts is start:  # (the later rounds' merged paths keep its rows' joints)
                start_joints = solved
            q = solved.joints
        low, high = _gap_extremes(surface, cutter, res, pts, idx, machine, q)
        travel = _travel_mm(cutter, pts.tips[idx], pts.tips[idx + 1], pts.axes[idx],
                            pts.axes[idx + 1])
        deep = np.maximum(depth[idx], depth[idx + 1])
        bad = _moves_to_split(res, pts, idx, low, high, travel, machine, q, deep)
        gap = np.maximum(-low, high)
        over = over_all = np.maximum(-low / tol, high / _undercut_limit(res, pts, idx))
        origin_over = np.maximum(first_over[idx], first_over[idx + 1])
        origin_travel = np.maximum(first_travel[idx], first_travel[idx + 1])
        stalled = bad & _not_shrunk(cutter, over, origin_over, deep, travel, origin_travel)
        if stalled.any():
            # (a move whose ends sit on the surface is a chord: split on)
            k = np.flatnonzero(stalled)
            stalled[k] = _end_gaps_mm(surface, cutter, pts, idx[k]) >= STALLED_END_SHARE * gap[k]
        if stalled.any():
            n_stalled += int(stalled.sum())
            stalled_mm = max(stalled_mm, float(gap[stalled].max()))
            bad &= ~stalled
        if not bad.all():  # the moves left whole are final: the worst of them is reported
            worst = max(worst, float(gap[~bad].max()))
        if not bad.any():
            break
        # (if the rounds run out, the last split moves' parts go unchecked: their whole
        # moves' gaps, larger, stand for them)
        unchecked = float(gap[bad].max())
        j = idx[bad]
        over = over[bad]
        parts = np.clip(np.ceil(np.sqrt(over / SPLIT_TARGET)), 2, MAX_PARTS).astype(np.int64)
        new_t, which = split_evenly(pts.t[j], pts.t[j + 1], parts)
        new_pid = pts.pid[j][which]
        if defer and origin is None:
            origin = np.unique(np.r_[j, j + 1])
            pts = _take_points(pts, origin)
            keep = None if keep is None else keep[origin]
        before = pts
        pts, where_new, kept = insert_points(surface, cutter, opts, res, layout, pts, new_t,
                                             new_pid)
        if origin is not None:
            if not kept:
                raise PlanningError(
                    "internal error in the chord check: inserting points inside moves moved "
                    "the moves' ends (the axes were smoothed again); please report it")
            origin = insert_rows(origin, np.full(where_new.size, -1), np.sort(where_new))
        n_points = len(pts) if origin is None else len(start) + int((origin < 0).sum())
        if n_points > opts.max_points:
            raise too_many_points(opts, n_points)
        keep = None if keep is None else _kept_with_new(keep, where_new)
        check = _checked_again(cutter, tol, before, pts, where_new, kept)
        line = origin_over > 0.0
        first_over, first_travel, depth = _split_lines(
            len(pts), where_new, which, np.where(line, origin_over, over_all)[bad],
            np.where(line, origin_travel, travel)[bad], deep[bad])
    else:
        worst = max(worst, unchecked)
    if origin is not None:
        pts, keep = _merged_back(start, keep_start, pts, origin)
    return RefinedChords(with_rate_record(cutter, pts) if len(pts) > len(start) else pts,
                         keep, worst, n_stalled, stalled_mm)


def _not_shrunk(cutter: Cutter, over: NDArray[np.float64], origin_over: NDArray[np.float64],
                depth: NDArray[np.int64], travel: NDArray[np.float64],
                origin_travel: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Moves whose gap did not fall over :data:`STALLED_SPLITS` splits of their line.

    ``over``: each move's gap over its limit (a ratio, > 1 beyond it); ``origin_over``:
    that of the move its line of splits started from (0: a move never split), ``depth``
    how many splits ago; ``travel``, ``origin_travel`` the moves' and their lines' first
    moves' travel (mm, :func:`_travel_mm`). Stalled: at least :data:`STALLED_SPLITS` deep,
    beyond the limit, still above :data:`STALLED_SHARE` of where it started, though
    split down to at most :data:`STALLED_TRAVEL_SHARE` of the first move's travel (a
    move the even splits have not shrunk yet goes on being split).

    Flat and bull-nose cutters only. A ball's gap at its own locations is 0 by
    construction (its centre stands ``R`` off the contact along the normal), so its moves'
    gaps fall to 0 with their length (a 5-axis part may first measure more than its whole
    move, up to twice, where the axes were smoothed again: it settles in the next rounds).
    A flat end's gap at its location is the lowest point of its disc, which the surface
    can meet anywhere under it (or be measured beside an edge): it need not fall.
    """
    if cutter.kind is CutterKind.BALL:
        return np.zeros(over.size, dtype=bool)
    return ((depth >= STALLED_SPLITS) & (origin_over > 1.0) & (over > 1.0)
            & (over > STALLED_SHARE * origin_over)
            & (travel <= STALLED_TRAVEL_SHARE * origin_travel))


def _end_gaps_mm(surface: ParametricSurface, cutter: Cutter, pts: PassPoints,
                 idx: NDArray[np.int64]) -> NDArray[np.float64]:
    """The larger ``|gap|`` (mm) of the cutter at the two ends of moves ``idx -> idx + 1``.

    The poses at the points themselves (fractions 0 and 1 of the move, whatever its
    interpolation), measured as :func:`_gap_extremes` measures inside moves: what a
    move's gap tends to as splitting shrinks it (:data:`STALLED_END_SHARE`).
    """
    gaps, _, _ = point_move_gaps(surface, cutter, pts.tips, pts.axes, pts.t, pts.s, idx,
                                 np.array([0.0, 1.0]), newton=1, refine_rim=True)
    return np.abs(gaps).max(axis=1)


def _split_lines(n_points: int, where_new: NDArray[np.int64], which: NDArray[np.int64],
                 origin_over: NDArray[np.float64], origin_travel: NDArray[np.float64],
                 depth: NDArray[np.int64]
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """Per point, the line of splits a new point belongs to (:func:`_not_shrunk`).

    ``where_new``: the new points' rows, ``which``: the split move each was inserted into
    (rows of ``origin_over``, ``origin_travel`` and ``depth``, the split moves' lines).
    Old points: none.
    """
    first_over, first_travel = np.zeros(n_points), np.zeros(n_points)
    first_over[where_new] = origin_over[which]
    first_travel[where_new] = origin_travel[which]
    deep = np.zeros(n_points, dtype=np.int64)
    deep[where_new] = depth[which] + 1
    return first_over, first_travel, deep


def _joints_along(machine: Machine, start: PassPoints, pts: PassPoints,
                  origin: NDArray[np.int64] | None,
                  start_joints: InverseSolution | None = None) -> InverseSolution:
    """The joints at ``pts``' rows (the solution's rows), solved along the whole path.

    ``pts`` is the path itself (``origin`` None) or the split moves going on alone: their
    ends (``origin``: rows of ``start``) and new points (-1), merged into ``start`` for the
    solve as :func:`_merged_back` merges them (tips and axes only). ``start_joints``:
    ``start``'s own joints, solved before: the merged path's rows of ``start`` keep theirs
    where C comes out the same (``solve_inverse``'s ``previous``: the same joints, computed
    for the new points only).
    """
    if origin is None:
        return solve_inverse(machine, pts.tips, pts.axes)
    added = np.flatnonzero(origin < 0)
    before = _insertion_rows(start.pid, start.t, pts.pid[added], pts.t[added])
    new_at = before + np.arange(added.size)
    previous = None
    if start_joints is not None:
        was = np.full(len(start) + added.size, -1, dtype=np.int64)
        old = np.ones(was.size, dtype=bool)
        old[new_at] = False
        was[old] = np.arange(len(start))
        previous = (start_joints, was)
    solved = solve_inverse(machine, insert_rows(start.tips, pts.tips[added], new_at),
                           insert_rows(start.axes, pts.axes[added], new_at),
                           previous=previous)
    rows = np.empty(len(pts), dtype=np.int64)
    rows[added] = new_at
    ends = np.flatnonzero(origin >= 0)  # start's row r, after the new points before it
    rows[ends] = origin[ends] + np.searchsorted(before, origin[ends], side="right")
    return InverseSolution(solved.joints[rows], solved.in_cone[rows],
                           solved.axis_error_deg[rows])


def _gap_extremes(surface: ParametricSurface, cutter: Cutter, res: PlannedOptions,
                  pts: PassPoints, idx: NDArray[np.int64], machine: Machine | None,
                  q: NDArray[np.float64] | None
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The deepest cut and the highest stand of the cutter along moves ``idx -> idx + 1``.

    The cutter inside each move (tip and axis interpolated; with a 5-axis ``machine``, its
    joints ``q``, as its control moves it: :func:`~toolpath.planning.sampling.move_gaps`)
    is measured against the surface at three places (one Newton step from the parameters
    between the move's ends: the foot point is then off by the fourth order of the move's
    length; a ball moved linearly in the middle only, its gap's slopes at the ends known:
    :func:`~toolpath.planning.sampling.ball_end_slopes`) and its extremes estimated
    (:func:`~toolpath.planning.sampling.chord_extremes`); an extreme within 10 % of its
    limit (``res.planned_chord_tol_mm`` below; above, how far the move may stand up,
    :func:`_undercut_limit`: the concave allowance or, where the axis turns along a convex
    pass, :data:`~toolpath.planning.scallop.TURNING_UNDERCUT_SHARE` of the scallop) is
    measured there.

    Returns ``low`` (<= 0), ``high`` (>= 0) per move. ``q``: the points' joints along the
    whole path with a 5-axis ``machine`` (:func:`_joints_along`), else None.
    """
    slopes = (ball_end_slopes(cutter.radius_mm, pts.tips, pts.axes, pts.frame.normal, idx)
              if cutter.kind is CutterKind.BALL and q is None else None)
    fractions = np.asarray(CHORD_FRACTIONS if slopes is None else BALL_FRACTIONS)
    gaps, _, _ = point_move_gaps(surface, cutter, pts.tips, pts.axes, pts.t, pts.s, idx,
                                 fractions, newton=1, refine_rim=True,
                                 joints=joint_moves(machine, q, idx))
    low, u_low, high, u_high = chord_extremes(gaps, fractions, end_slopes=slopes,
                                              with_samples=True)
    # the model is close, not exact: where an extreme is within 10 % of its limit,
    # measure there (a move can both cut in and stand above: both sides are checked)
    sides = ((low, u_low, res.planned_chord_tol_mm, -1.0, np.minimum),
             (high, u_high, _undercut_limit(res, pts, idx), 1.0, np.maximum))
    for value, u_at, limit, sign, further in sides:
        # (next to a measured place the model is pinned to the measurement)
        off_sample = np.abs(u_at[:, None] - fractions).min(axis=1) > MEASURED_NEAR_U
        close = np.flatnonzero((np.abs(value) > 0.9 * limit) & (np.abs(value) <= limit)
                               & (np.sign(value) == sign) & off_sample)
        if close.size:
            j = idx[close]
            exact, _, _ = point_move_gaps(surface, cutter, pts.tips, pts.axes, pts.t,
                                          pts.s, j, u_at[close, None], newton=1,
                                          refine_rim=True, joints=joint_moves(machine, q, j))
            value[close] = further(value[close], exact[:, 0])
    return low, high


def _undercut_limit(res: PlannedOptions, pts: PassPoints, idx: NDArray[np.int64]
                    ) -> NDArray[np.float64]:
    """How far moves ``idx -> idx + 1`` may stand above the surface (:func:`undercut_limit_mm`)."""
    return undercut_limit_mm(res.undercut_mm, res.planned_scallop_mm, pts.frame.s11[idx],
                             pts.frame.s11[idx + 1], pts.axes[idx], pts.axes[idx + 1])


def middle_past_tilt(res: PlannedOptions, pts: PassPoints, idx: NDArray[np.int64]
                    ) -> NDArray[np.bool_]:
    """Moves ``idx -> idx + 1`` whose middle axis leans past the tilt cap by half its margin.

    The post splits a 5-axis move at its middle with the normalized mean of the ends' axes
    (:mod:`toolpath.joint_refine`); beyond 90 deg from +Z that axis lies further from +Z
    than either end (``cos(tilt_mid) = cos(tilt) / cos(turn / 2)`` for two ends at one
    tilt), so two ends leaned back to the cap ``res.max_tilt_deg`` and turned 7 deg apart
    put the middle past the joint's travel (the cap keeps :data:`TILT_MARGIN_DEG` from it).
    Split, each half's middle bulges a quarter as far.
    """
    if not math.isfinite(res.max_tilt_deg):
        return np.zeros(idx.size, dtype=bool)
    mean = pts.axes[idx] + pts.axes[idx + 1]
    size = np.linalg.norm(mean, axis=1)
    cos_tilt = mean[:, 2] / np.maximum(size, TINY)
    limit = math.cos(math.radians(min(res.max_tilt_deg + 0.5 * TILT_MARGIN_DEG, 180.0)))
    return (size > TINY) & (cos_tilt < limit)


def _moves_to_split(res: PlannedOptions, pts: PassPoints, idx: NDArray[np.int64],
                    low: NDArray[np.float64], high: NDArray[np.float64],
                    travel: NDArray[np.float64], machine: Machine | None,
                    q: NDArray[np.float64] | None, depth: NDArray[np.int64]
                    ) -> NDArray[np.bool_]:
    """Which moves ``idx`` to split.

    Those cutting deeper than the chord tolerance, standing higher than they may
    (:func:`_undercut_limit`), whose middle leans past the tilt cap
    (:func:`middle_past_tilt`), or (5-axis, joints ``q``) carrying the tip more than
    :data:`JOINT_SIDEWAYS_MM` across the pass (the post then leaves them whole); the last
    two only less than :data:`MOTION_SPLITS` splits deep (``depth``, per move).

    A move shorter than the program's resolution (:data:`MIN_SPLIT_MM` of ``travel``: the
    tip, plus the cutter radius times the axis turn, :func:`_travel_mm`) is not split: its
    gap is not the chord's (its ends themselves stand off), and the report carries it.
    """
    bad = (low < -res.planned_chord_tol_mm) | (high > _undercut_limit(res, pts, idx))
    motion = middle_past_tilt(res, pts, idx)
    if q is not None and machine is not None:
        motion |= _sideways_mm(machine, pts, q, idx) > JOINT_SIDEWAYS_MM
    return (bad | (motion & (depth < MOTION_SPLITS))) & (travel > MIN_SPLIT_MM)


def _checked_again(cutter: Cutter, tol_mm: float, before: PassPoints, pts: PassPoints,
                   where_new: NDArray[np.int64], kept: bool) -> NDArray[np.bool_]:
    """The moves to check in the next round.

    Those next to the new points, and those whose ends moved by more than
    :data:`MOVED_SHARE` of the tolerance (where the insertion smoothed the axes again,
    which shifts the tips and axes of their neighbours: a chord checked before is then
    another chord).
    """
    moved = np.zeros(len(pts), dtype=bool)
    moved[where_new] = True
    if not kept:
        old_at = np.flatnonzero(~moved)
        shift = _travel_mm(cutter, before.tips, pts.tips[old_at], before.axes,
                           pts.axes[old_at])
        moved[old_at[shift > MOVED_SHARE * tol_mm]] = True
    at = np.flatnonzero(moved)
    check = np.zeros(len(pts) - 1, dtype=bool)
    check[np.clip(at - 1, 0, None)] = True
    check[np.clip(at, None, len(pts) - 2)] = True
    return check


def _merged_back(start: PassPoints, keep_start: NDArray[np.bool_] | None, pts: PassPoints,
                 origin: NDArray[np.int64]
                 ) -> tuple[PassPoints, NDArray[np.bool_] | None]:
    """The split moves' new points (``origin < 0``) merged into the starting points."""
    added = np.flatnonzero(origin < 0)
    new = _take_points(pts, added)  # (with the totals of the smoothing record)
    new_at = _insertion_rows(start.pid, start.t, new.pid, new.t) + np.arange(added.size)
    merged = _merge_points(start, new, new_at)
    return merged, None if keep_start is None else _kept_with_new(keep_start, new_at)


def reach_split(surface: ParametricSurface, opts: FinishingOptions, layout: PassLayout,
                t: NDArray[np.float64], pid: NDArray[np.int64]
                ) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.bool_]]:
    """3-axis: the contacts ``(t, pid)`` and their reach boundaries; which are reachable.

    A contact is reachable when ``n . a >= sin(reach_margin_deg)``: the cutter touches it
    with its cutting end, not its shank. Between a reachable and an unreachable neighbour
    the boundary ``t`` (to :data:`REACH_T_SHARE` of their distance) is added as a
    reachable point (:func:`_reach_boundary`). Normals are all it takes (the tangent
    frame): the contacts are evaluated once, afterwards, boundaries included.
    """
    def height(t: NDArray[np.float64], pid: NDArray[np.int64]) -> NDArray[np.float64]:
        return reach_height(opts, surface.normal(t, layout.s_of(t, pid)))

    up = reach_height(opts, tangent_frame(surface, t, layout.s_of(t, pid)).normal)
    ok = up >= 0.0
    edge = np.flatnonzero((pid[1:] == pid[:-1]) & (ok[:-1] != ok[1:]))
    if not edge.size:
        return t, pid, ok
    good = np.where(ok[edge], edge, edge + 1)
    bad = np.where(ok[edge], edge + 1, edge)
    edge_pid = pid[edge]
    boundary = _reach_boundary(lambda t, rows: height(t, edge_pid[rows]), t[good], t[bad],
                               up[good], up[bad])
    moved = boundary != t[good]  # (a reachable point on the boundary is the boundary)
    at = edge[moved] + 1  # strictly between the edge's two points
    return (np.insert(t, at, boundary[moved]), np.insert(pid, at, edge_pid[moved]),
            np.insert(ok, at, True))


def reach_height(opts: FinishingOptions, normals: NDArray[np.float64]) -> NDArray[np.float64]:
    """``n . a - sin(reach_margin_deg)`` of the fixed axis ``a``, less ``ROUND_OFF`` of slack.

    At least 0 where the cutting end reaches the contact (3-axis).
    """
    return normals @ np.asarray(opts.fixed_axis) - (np.sin(np.radians(opts.reach_margin_deg))
                                                    - ROUND_OFF)


#: The reach boundary is found to this share of the distance (in ``t``) between the
#: reachable and the unreachable point it lies between, or where ``n . a`` is within
#: :data:`REACH_HEIGHT_TOL` above its limit: 1e-9 rad of the normal's turn, under a
#: nanometre along any surface curving with a radius under a metre (and round-off, some
#: 1e-15 of ``n . a``, stalls the secant well above 1e-12: bisection would then take over).
REACH_T_SHARE = 2.0 ** -40
REACH_HEIGHT_TOL = 1e-9


def _reach_boundary(height: Callable[[NDArray[np.float64], NDArray[np.int64]],
                                     NDArray[np.float64]],
                    good_t: NDArray[np.float64], bad_t: NDArray[np.float64],
                    good_h: NDArray[np.float64], bad_h: NDArray[np.float64]
                    ) -> NDArray[np.float64]:
    """The last reachable ``t`` in each bracket, where ``height`` crosses 0.

    ``height(t, rows)`` is ``n . a`` less its limit at parameters ``t`` of brackets
    ``rows``; ``good_h >= 0 > bad_h`` at the ends. Regula falsi with the Illinois rule
    (:func:`~.roots.illinois_roots`) for :data:`SECANT_STEPS`, a few evaluations where the
    height is smooth; then bisection, which no crease or flat zero slows, until
    :data:`REACH_T_SHARE` of the bracket or :data:`REACH_HEIGHT_TOL` of the height (at a
    point evaluated here: never an end itself).
    """
    good, _ = illinois_roots(height, good_t, bad_t, good_h, bad_h,
                             secant_steps=SECANT_STEPS, bisect_steps=40,
                             x_tol=REACH_T_SHARE * np.abs(bad_t - good_t),
                             f_tol=REACH_HEIGHT_TOL)
    return good


#: Regula falsi steps of :func:`_reach_boundary` before it bisects (at most 40 more).
SECANT_STEPS = 12


def with_rate_record(cutter: Cutter, pts: PassPoints) -> PassPoints:
    """``pts`` with the largest turn rate (and where) of its axes in the smoothing record.

    Per mm of the rate's path (:func:`_rate_path`); :func:`insert_points` leaves them to
    this, once all its insertions are done.
    """
    if pts.smoothing is None or len(pts) < 2:
        return pts
    rates = segment_turn_rates(pts.axes, _rate_path(cutter, pts.frame, pts.pid),
                               pts.same_pass)
    return replace(pts, smoothing=replace(pts.smoothing, max_rate_deg_per_mm=float(rates.max()),
                                          worst_point=int(np.argmax(rates))))


def with_tips(pts: PassPoints, axes: NDArray[np.float64], tips: NDArray[np.float64]
              ) -> PassPoints:
    """A copy with other axes and tips (gouge handling)."""
    return replace(pts, axes=axes, tips=tips)
