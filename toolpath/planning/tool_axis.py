"""Tool axes: fixed (3-axis) or from the surface frame with lead and tilt (5-axis).

Lead and tilt are given in the pass frame at the contact: ``f`` the feed direction (unit,
along the direction of travel), ``n`` the outward normal and ``b = n x f`` (to the left of
the feed, seen from the spindle). The nominal axis is

``a = cos(lead) (cos(tilt) n + sin(tilt) b) + sin(lead) f``

so a positive lead leans the tool forward, towards the feed, and a positive tilt leans it
to the left. The axes are then smoothed along each pass by a moving average over arc
length (a box filter of half-width ``w`` applied twice, i.e. a triangular window of
half-width ``2w``, computed from cumulative integrals, renormalized, centred so that the
ends keep their nominal axes); a smoothed axis leaning more than ``max_lean_deg`` from the
surface normal is turned back towards the normal onto that cone (the contact must stay on
the cutting end, well below the shank). On passes still turning faster than
``max_axis_rate_deg_per_mm`` (round a leading edge tighter than the rate allows) the
axis is rate limited within the lean cone (:func:`rate_limited_axes`): it starts turning
before the edge and finishes after it; where even that cannot keep the rate, the smallest
rate that fits is used and reported. Finally axes can be pushed out of the singular cone
(angle from the workpiece +Z) along the great circle through +Z, and axes further from +Z
than the machine's tilt joint reaches are leaned back toward +Z (:func:`lean_within_tilt`,
PowerMill's tool-axis limits, NX's tilt avoidance): by a lean smoothed along the pass,
bounded by the lean from the normal.

The row kernels here run on one thread: each takes a millisecond or so on a job's
points, while a parallel loop costs a second or more of compiling on a cold start
(issue 27; where the work is, projection, clearance, measure, the rows run in
threads: :mod:`toolpath.row_threads`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..tolerances import ANGLE_SLACK_DEG, LIMIT_SLACK, ROUND_OFF, SAME_POINT_MM
from ..vectors import unit
from .rate_limit import angle_deg_at, rate_limited_axes, segment_rate

__all__ = [
    "LEAN_RATE_SHARE",
    "Z_AXIS",
    "AxisSmoothing",
    "TiltLean",
    "angle_deg",
    "box_window",
    "keep_out_of_cone",
    "lead_tilt_axes",
    "lean_interpolated",
    "lean_within_tilt",
    "limit_lean",
    "segment_turn_rates",
    "slerp",
    "smooth_axes",
    "window_average",
]

#: The workpiece +Z (the axis tilt and the singular cone are measured from).
Z_AXIS = np.array([0.0, 0.0, 1.0])


def angle_deg(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Angle between unit vectors, deg (``atan2(|a x b|, a.b)``, accurate near 0)."""
    a, b = np.broadcast_arrays(np.asarray(a, dtype=float), np.asarray(b, dtype=float))
    out = np.empty(a.shape[:-1])
    _angles_deg(np.ascontiguousarray(a).reshape(-1, 3), np.ascontiguousarray(b).reshape(-1, 3),
                out.reshape(-1))
    return out


@numba.njit(cache=True)
def _angles_deg(a, b, out):
    for i in range(a.shape[0]):
        out[i] = angle_deg_at(a, b, i, i)


def lead_tilt_axes(normals: ArrayLike, feed_dirs: ArrayLike, lead_deg: float,
                   tilt_deg: float) -> NDArray[np.float64]:
    """Nominal tool axes ``cos L (cos T n + sin T b) + sin L f`` with ``b = n x f``.

    Parameters
    ----------
    normals : array_like, shape (n, 3)
        Unit outward normals.
    feed_dirs : array_like, shape (n, 3)
        Unit feed directions (tangent, in the direction of travel).
    lead_deg, tilt_deg : float
        Lead (forward lean) and tilt (lean to the left), deg.
    """
    n, f = np.broadcast_arrays(np.asarray(normals, dtype=float),
                               np.asarray(feed_dirs, dtype=float))
    lead, tilt = np.radians(lead_deg), np.radians(tilt_deg)
    out = np.empty(n.shape)
    _lead_tilt_rows(np.ascontiguousarray(n).reshape(-1, 3), np.ascontiguousarray(f).reshape(-1, 3),
                    np.cos(lead), np.sin(lead), np.cos(tilt), np.sin(tilt), out.reshape(-1, 3))
    return out


@numba.njit(cache=True)
def _lead_tilt_rows(n, f, cos_lead, sin_lead, cos_tilt, sin_tilt, out):
    """:func:`lead_tilt_axes` row by row."""
    for i in range(n.shape[0]):
        b0 = n[i, 1] * f[i, 2] - n[i, 2] * f[i, 1]
        b1 = n[i, 2] * f[i, 0] - n[i, 0] * f[i, 2]
        b2 = n[i, 0] * f[i, 1] - n[i, 1] * f[i, 0]
        v0 = cos_lead * (cos_tilt * n[i, 0] + sin_tilt * b0) + sin_lead * f[i, 0]
        v1 = cos_lead * (cos_tilt * n[i, 1] + sin_tilt * b1) + sin_lead * f[i, 1]
        v2 = cos_lead * (cos_tilt * n[i, 2] + sin_tilt * b2) + sin_lead * f[i, 2]
        size = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        if size <= 0.0:
            size = 1.0
        out[i, 0], out[i, 1], out[i, 2] = v0 / size, v1 / size, v2 / size


#: Unit vectors whose angle has a sine below this are parallel: :func:`slerp` then
#: interpolates linearly (off the great circle by ``theta^2 / 8``, below 1e-18), and a
#: vector this close to +Z has no horizontal direction of its own.
PARALLEL_SIN = 1e-9


def slerp(a: NDArray[np.float64], b: NDArray[np.float64], w: NDArray[np.float64]
          ) -> NDArray[np.float64]:
    """Unit vectors a fraction ``w`` of the angle from unit ``a`` to ``b`` (rows)."""
    theta = np.radians(angle_deg(a, b))[:, None]
    w = np.asarray(w, dtype=float).reshape(-1, 1)
    sin = np.sin(theta)
    small = sin < PARALLEL_SIN
    safe = np.where(small, 1.0, sin)
    out = np.where(small, (1.0 - w) * a + w * b,
                   (np.sin((1.0 - w) * theta) * a + np.sin(w * theta) * b) / safe)
    return unit(out)


def segment_turn_rates(axes: NDArray[np.float64], arclen_mm: NDArray[np.float64],
                       same_pass: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Turn rate of the axis on each segment, deg per mm along the pass (0 across passes).

    A segment shorter than :data:`~toolpath.tolerances.SAME_POINT_MM` turning by more than
    :data:`~toolpath.tolerances.ANGLE_SLACK_DEG` turns at ``inf``.
    """
    out = np.empty(max(len(axes) - 1, 0))
    _turn_rates(np.ascontiguousarray(axes, dtype=float),
                np.ascontiguousarray(arclen_mm, dtype=float), np.ascontiguousarray(same_pass),
                out)
    return out


@numba.njit(cache=True)
def _turn_rates(axes, arclen, same, out):
    for i in range(out.size):
        out[i] = segment_rate(axes, i, arclen[i + 1] - arclen[i]) if same[i] else 0.0


def _pass_coordinate(arclen_mm: NDArray[np.float64], pass_id: NDArray[np.int64]
                     ) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.int64],
                                NDArray[np.int64]]:
    """A strictly increasing coordinate over the passes, mm, and their first and last rows.

    Each pass's arc length shifted past the previous pass plus a 1 mm gap (windows never
    reach across), plus :data:`~toolpath.tolerances.SAME_POINT_MM` per row (repeated
    points). Returns ``x``, the first and last row of each pass and the pass of each row
    (0-based, in order).
    """
    n = len(pass_id)
    starts = np.flatnonzero(np.r_[True, pass_id[1:] != pass_id[:-1]])
    ends = np.r_[starts[1:], n] - 1
    which = np.repeat(np.arange(len(starts)), ends - starts + 1)
    local = arclen_mm - arclen_mm[starts][which]
    offsets = np.concatenate([[0.0], np.cumsum(local[ends] + 1.0)[:-1]])
    return local + offsets[which] + np.arange(n) * SAME_POINT_MM, starts, ends, which


def box_window(x: NDArray[np.float64], lo_x: NDArray[np.float64], hi_x: NDArray[np.float64],
               half_width: NDArray[np.float64], centred: NDArray[np.bool_]
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The window ``[x - w, x + w]`` of each point, within its pass.

    Where ``centred``, ``w`` is at most the distance to the nearer pass end (no lag: a
    window cut short on one side leans the axis towards the inside, 3 deg off the nominal
    at the end of a pass over a sphere); elsewhere the window is clipped to the pass. ``x``
    is a strictly increasing global coordinate (passes separated by gaps), ``lo_x``,
    ``hi_x`` the pass ends of each point.
    """
    half = np.where(centred, np.minimum(half_width, np.minimum(x - lo_x, hi_x - x)),
                    half_width)
    return np.maximum(x - half, lo_x), np.minimum(x + half, hi_x)


def window_average(values: NDArray[np.float64], x: NDArray[np.float64],
                   window: tuple[NDArray[np.float64], NDArray[np.float64]]
                   ) -> NDArray[np.float64]:
    """Mean of the piecewise-linear ``values(x)`` over each point's window (a box filter).

    From the cumulative trapezoid integral (:func:`_window_means`).
    """
    out = np.empty_like(values)
    _window_means(np.ascontiguousarray(values, dtype=float), np.ascontiguousarray(x),
                  window[0], window[1], out)
    return out


#: A box-averaged axis shorter than this (its window spans opposite normals) is not
#: normalized: the nominal axis is kept.
WEAK_AVERAGE = 0.2


@numba.njit(cache=True)
def _unit_or_nominal(averaged, nominal, weak):
    """``averaged`` normalized in place; rows shorter than ``weak`` take ``nominal``."""
    for i in range(averaged.shape[0]):
        size = math.sqrt(averaged[i, 0] * averaged[i, 0] + averaged[i, 1] * averaged[i, 1]
                         + averaged[i, 2] * averaged[i, 2])
        for k in range(3):
            averaged[i, k] = nominal[i, k] if size < weak else averaged[i, k] / size


# (kernel-only, not exported: no Python wrapper, so a call from Python crashes the process)
@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def segment_index(x, v):
    """``j`` with ``x[j] <= v < x[j + 1]`` (clamped to ``[0, x.size - 2]``), by bisection."""
    lo, hi = 0, x.size - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if x[mid] <= v:
            lo = mid
        else:
            hi = mid
    return lo


@numba.njit(cache=True)
def _walk(x, v, j):
    """:func:`segment_index` from a guess ``j`` at or before it."""
    if x[j] > v:
        return segment_index(x, v)
    while j < x.size - 2 and x[j + 1] <= v:
        j += 1
    return j


#: Points per block of :func:`_window_means` (each block starts by bisection).
_WINDOW_BLOCK = 8192


@numba.njit(cache=True)
def _window_means(values, x, lo, hi, out):
    """``out[i]``: mean of the piecewise-linear ``values(x)`` over ``[lo[i], hi[i]]``.

    From the cumulative trapezoid integral, interpolated linearly (``np.interp``). The
    window ends grow with ``i`` (within a pass they are ``x`` moved by a width that the
    pass ends clip, and passes follow each other), so their segments are found by walking
    on from the previous ones (in blocks of points, each starting by bisection).
    """
    n, m = values.shape
    if n < 2:
        for i in range(n):
            for k in range(m):
                out[i, k] = values[i, k]
        return
    cum = np.zeros((n, m))
    for i in range(1, n):
        for k in range(m):
            cum[i, k] = cum[i - 1, k] + 0.5 * (values[i, k] + values[i - 1, k]) * (x[i]
                                                                                   - x[i - 1])
    for block in range((n + _WINDOW_BLOCK - 1) // _WINDOW_BLOCK):
        first = block * _WINDOW_BLOCK
        j_lo, j_hi = segment_index(x, lo[first]), segment_index(x, hi[first])
        for i in range(first, min(first + _WINDOW_BLOCK, n)):
            width = hi[i] - lo[i]
            if width <= SAME_POINT_MM:
                for k in range(m):
                    out[i, k] = values[i, k]
                continue
            j_lo, j_hi = _walk(x, lo[i], j_lo), _walk(x, hi[i], j_hi)
            f_hi = (hi[i] - x[j_hi]) / (x[j_hi + 1] - x[j_hi])
            f_lo = (lo[i] - x[j_lo]) / (x[j_lo + 1] - x[j_lo])
            for k in range(m):
                top = cum[j_hi, k] + f_hi * (cum[j_hi + 1, k] - cum[j_hi, k])
                bottom = cum[j_lo, k] + f_lo * (cum[j_lo + 1, k] - cum[j_lo, k])
                out[i, k] = (top - bottom) / width


@dataclass(frozen=True)
class AxisSmoothing:
    """Result of :func:`smooth_axes`.

    Attributes
    ----------
    axes : ndarray, shape (n, 3)
        Smoothed unit axes.
    max_rate_deg_per_mm : float
        Largest turn rate left on any segment.
    worst_point : int
        Index of the first point of that segment (``-1`` if there are none).
    limited_points : int
        Points whose smoothed axis was turned back onto the ``max_lean_deg`` cone.
    rate_limited_passes : int
        Passes whose axes were turned ahead of the surface to keep the rate limit.
    tilt_leaned_points : int
        Points whose axis was leaned toward +Z to keep the tilt joint in its travel
        (:func:`lean_within_tilt`).
    max_tilt_lean_deg : float
        The largest such lean, deg.
    """

    axes: NDArray[np.float64]
    max_rate_deg_per_mm: float
    worst_point: int
    limited_points: int
    rate_limited_passes: int = 0
    tilt_leaned_points: int = 0
    max_tilt_lean_deg: float = 0.0


def limit_lean(axes: NDArray[np.float64], normals: NDArray[np.float64], max_lean_deg: float
               ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Turn unit axes leaning more than ``max_lean_deg`` from the unit normals back onto that cone.

    ``a' = cos(L) n + sin(L) h`` with ``h`` the unit part of ``a`` perpendicular to ``n``
    (in the plane of ``a`` and ``n``). Returns the axes and which were moved.
    """
    a = np.ascontiguousarray(axes, dtype=float)
    out = np.empty_like(a)
    over = np.empty(len(a), dtype=bool)
    c = np.radians(max_lean_deg)
    _limit_lean_rows(a, np.ascontiguousarray(normals, dtype=float), float(max_lean_deg),
                     float(np.cos(c)), float(np.sin(c)), out, over)
    return out, over


@numba.njit(cache=True)
def _limit_lean_rows(axes, normals, max_lean_deg, cos_lean, sin_lean, out, over):
    """:func:`limit_lean` row by row."""
    for i in range(axes.shape[0]):
        dot = axes[i, 0] * normals[i, 0] + axes[i, 1] * normals[i, 1] + axes[i, 2] * normals[i, 2]
        # (unit vectors: the cosine decides unless it is within round-off of the limit's)
        if abs(dot - cos_lean) > LIMIT_SLACK:
            over[i] = dot < cos_lean
        else:
            over[i] = angle_deg_at(axes, normals, i, i) > max_lean_deg
        if not over[i]:
            for k in range(3):  # (a slice copy would compile numba's shape-error text: ~2 s)
                out[i, k] = axes[i, k]
            continue
        size2 = 0.0
        for k in range(3):
            perp = axes[i, k] - dot * normals[i, k]
            out[i, k] = perp
            size2 += perp * perp
        size = math.sqrt(size2)
        if size <= 0.0:
            size = 1.0
        for k in range(3):
            out[i, k] = cos_lean * normals[i, k] + sin_lean * (out[i, k] / size)


def lean_interpolated(axes_a: NDArray[np.float64], normals_a: NDArray[np.float64],
                      feeds_a: NDArray[np.float64], axes_b: NDArray[np.float64],
                      normals_b: NDArray[np.float64], feeds_b: NDArray[np.float64],
                      w: ArrayLike, normals: NDArray[np.float64], feeds: NDArray[np.float64]
                      ) -> NDArray[np.float64]:
    """Axes a fraction ``w`` of the way from ``a`` to ``b`` in lean and in its direction.

    For a flat face's lead. Each axis is read in its own contact's frame as a lean
    ``theta`` from the normal ``n`` and a direction ``phi`` about it, measured from the
    feed direction ``f`` (made tangent) towards ``n x f``; between the ends

    ``theta = (1 - w) theta_a + w theta_b``, ``phi = phi_a + w wrap(phi_b - phi_a)``,
    ``a = cos(theta) n + sin(theta) (cos(phi) f + sin(phi) n x f)``

    at the new contact's frame. So the axis goes round the normal on the lean cone, not
    through it, and leans between its ends' leans (no floor at the lead: on the DCA
    rotor's 5-axis flat:6 job, past the leading edge, ends leaning 5 and 6 degrees had a
    new point raised to 10, 4 degrees off both and its tip 1.5 mm out of the move).

    Where the normal turns faster than the axes (round a leading edge, the lean's
    direction swinging from ahead to beside or behind) a slerp between two leaning axes
    leans less, down to none, and the contact then jumps across the face (the tip by up to
    its diameter in one move); here the face keeps its lean and the contact stays on its
    rim, moving round it as far as the lean's direction turns. Ends leaning less than 0.5
    degree have no direction to speak of: their lean vectors ``theta (cos(phi), sin(phi))``
    are interpolated instead.
    """
    w = np.asarray(w, dtype=float)
    theta_a, phi_a = _lean_polar(axes_a, normals_a, feeds_a)
    theta_b, phi_b = _lean_polar(axes_b, normals_b, feeds_b)
    turn = np.remainder(phi_b - phi_a + np.pi, 2.0 * np.pi) - np.pi
    theta = (1.0 - w) * theta_a + w * theta_b
    phi = phi_a + w * turn
    upright = np.minimum(theta_a, theta_b) < np.radians(0.5)
    if upright.any():
        x = (1.0 - w) * theta_a * np.cos(phi_a) + w * theta_b * np.cos(phi_b)
        y = (1.0 - w) * theta_a * np.sin(phi_a) + w * theta_b * np.sin(phi_b)
        theta = np.where(upright, np.hypot(x, y), theta)
        phi = np.where(upright, np.arctan2(y, x), phi)
    f, b = _tangent_basis(normals, feeds)
    return unit(np.cos(theta)[:, None] * normals + np.sin(theta)[:, None]
                * (np.cos(phi)[:, None] * f + np.sin(phi)[:, None] * b))


def _tangent_basis(normals: NDArray[np.float64], feeds: NDArray[np.float64]
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``f`` made tangent (unit) and ``n x f``: the frame a lean's direction is read in."""
    f = unit(feeds - np.einsum("ij,ij->i", feeds, normals)[:, None] * normals)
    return f, np.cross(normals, f)


def _lean_polar(axes: NDArray[np.float64], normals: NDArray[np.float64],
                feeds: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Each axis's lean from the normal and its direction about it, rad."""
    f, b = _tangent_basis(normals, feeds)
    theta = np.radians(angle_deg(axes, normals))
    phi = np.arctan2(np.einsum("ij,ij->i", axes, b), np.einsum("ij,ij->i", axes, f))
    return theta, phi


def smooth_axes(nominal: NDArray[np.float64], normals: NDArray[np.float64],
                feed_dirs: NDArray[np.float64], arclen_mm: NDArray[np.float64],
                pass_id: NDArray[np.int64], *, smoothing_mm: float,
                max_rate_deg_per_mm: float | None, max_lean_deg: float,
                keep_lead: bool = False) -> AxisSmoothing:
    """Smooth nominal axes along each pass and limit their turn rate (module docstring).

    Parameters
    ----------
    nominal : ndarray, shape (n, 3)
        Unit nominal axes, in pass order (passes contiguous, ascending ``pass_id``).
    normals, feed_dirs : ndarray, shape (n, 3)
        Unit surface normals at the contacts and unit feed directions.
    arclen_mm : ndarray, shape (n,)
        Arc length along each pass (restarting anywhere; only differences within a pass
        are used), mm: the path the rate is measured on.
    pass_id : ndarray, shape (n,)
        Pass of each point (contiguous runs).
    smoothing_mm : float
        Box half-width, mm (0: no smoothing).
    max_rate_deg_per_mm : float or None
        Turn-rate limit, deg/mm; ``None`` for none.
    max_lean_deg : float
        Largest angle allowed between an axis and the normal (see :func:`limit_lean`).
    keep_lead : bool
        The rate limit may lean the axis further ahead than the nominal one, not less
        (flat and bull-nose cutters; :func:`rate_limited_axes`).
    """
    n = len(nominal)
    x, starts, ends, which = _pass_coordinate(arclen_mm, pass_id)
    n_passes = len(starts)
    same = pass_id[1:] == pass_id[:-1]
    axes = nominal
    limited = np.zeros(n, dtype=bool)
    if smoothing_mm > 0.0:
        lo_x, hi_x = x[starts][which], x[ends][which]
        w_pt = np.full(n, float(smoothing_mm))
        c_pt = np.ones(n, dtype=bool)
        window = box_window(x, lo_x, hi_x, w_pt, c_pt)
        twice = window_average(window_average(nominal, x, window), x, window)
        # a window spanning opposite normals can average to nothing: keep the nominal
        _unit_or_nominal(twice, nominal, WEAK_AVERAGE)
        axes, limited = limit_lean(twice, normals, max_lean_deg)
    rates = segment_turn_rates(axes, x, same)
    n_limited = 0
    if max_rate_deg_per_mm is not None and (rates > max_rate_deg_per_mm).any():
        bad_pass = np.zeros(n_passes, dtype=bool)
        bad_pass[which[:-1][rates > max_rate_deg_per_mm]] = True
        rows: NDArray[np.int64] | slice = np.flatnonzero(bad_pass[which])
        sub_starts = np.flatnonzero(np.r_[True, which[rows][1:] != which[rows][:-1]])
        if bad_pass.all():
            rows = slice(None)  # (views, not copies: round a blade every pass is limited)
        axes = axes.copy()
        axes[rows] = rate_limited_axes(axes[rows], normals[rows], feed_dirs[rows], x[rows],
                                       sub_starts, max_rate_deg_per_mm=max_rate_deg_per_mm,
                                       max_lean_deg=max_lean_deg,
                                       nominal=nominal[rows] if keep_lead else None)
        limited[rows] = False
        rates = segment_turn_rates(axes, x, same)
        n_limited = int(bad_pass.sum())
    worst = int(np.argmax(rates)) if rates.size else -1
    return AxisSmoothing(axes=axes, max_rate_deg_per_mm=float(rates.max()) if rates.size
                         else 0.0, worst_point=worst, limited_points=int(limited.sum()),
                         rate_limited_passes=n_limited)


def keep_out_of_cone(axes: NDArray[np.float64], min_cone_deg: float,
                     fallback: NDArray[np.float64]) -> tuple[NDArray[np.float64], int]:
    """Push axes closer than ``min_cone_deg`` to +Z onto the cone, along the great circle.

    ``a' = cos(c) Z + sin(c) h`` with ``h`` the unit horizontal part of ``a`` (or of
    ``fallback`` where ``a`` is vertical). Returns the axes and how many were moved.
    """
    theta = angle_deg(axes, Z_AXIS)
    inside = theta < min_cone_deg
    if not inside.any():
        return axes, 0
    horiz = axes.copy()
    horiz[:, 2] = 0.0
    size = np.linalg.norm(horiz, axis=1)
    fb = np.asarray(fallback, dtype=float).copy()
    fb[..., 2] = 0.0
    fb_size = np.linalg.norm(fb, axis=-1)
    fb = np.where(fb_size[..., None] > PARALLEL_SIN,
                  fb / np.where(fb_size > PARALLEL_SIN, fb_size, 1.0)[..., None],
                  np.array([1.0, 0.0, 0.0]))
    h = np.where(size[:, None] > PARALLEL_SIN,
                 horiz / np.where(size > PARALLEL_SIN, size, 1.0)[:, None], fb)
    c = np.radians(min_cone_deg)
    pushed = np.cos(c) * Z_AXIS + np.sin(c) * h
    return np.where(inside[:, None], pushed, axes), int(inside.sum())


#: The tilt lean ramps in and out at most this share of the axis turn-rate limit.
LEAN_RATE_SHARE = 0.25


@dataclass(frozen=True)
class TiltLean:
    """Result of :func:`lean_within_tilt`.

    Attributes
    ----------
    axes : ndarray, shape (n, 3)
        The axes, leaned where needed.
    lean_deg : ndarray, shape (n,)
        Angle each axis was turned by, deg (0 where it was not).
    impossible : ndarray of bool, shape (n,)
        No axis within ``max_lean_deg`` of the normal is within ``max_tilt_deg`` of +Z:
        the axis there is the best one (the normal leaned ``max_lean_deg`` toward +Z).
    """

    axes: NDArray[np.float64]
    lean_deg: NDArray[np.float64]
    impossible: NDArray[np.bool_]


def _toward_z(v: NDArray[np.float64], lean_deg: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit axes turned ``lean_deg`` toward +Z along their great circle through +Z.

    ``v = cos(th) Z + sin(th) h`` (``h`` the unit horizontal part) becomes
    ``cos(th - L) Z + sin(th - L) h``: the azimuth is kept.
    """
    theta = np.radians(angle_deg(v, Z_AXIS))
    horiz = v.copy()
    horiz[:, 2] = 0.0
    size = np.linalg.norm(horiz, axis=1)
    h = horiz / np.where(size > ROUND_OFF, size, 1.0)[:, None]  # (else vertical: kept)
    th = theta - np.radians(lean_deg)
    out = np.cos(th)[:, None] * Z_AXIS + np.sin(th)[:, None] * h
    return np.where((size > ROUND_OFF)[:, None], out, v)


@numba.njit(cache=True)
def _running_max(values, arclen, pass_id, half_width, out):
    """``out[i]``: largest ``values[j]`` of the same pass with ``|arclen[j] - arclen[i]| <= w``."""
    n = values.size
    for i in range(n):
        best = values[i]
        j = i - 1
        while j >= 0 and pass_id[j] == pass_id[i] and arclen[i] - arclen[j] <= half_width:
            best = max(best, values[j])
            j -= 1
        j = i + 1
        while j < n and pass_id[j] == pass_id[i] and arclen[j] - arclen[i] <= half_width:
            best = max(best, values[j])
            j += 1
        out[i] = best


def _leaned(axes: NDArray[np.float64], lean_deg: NDArray[np.float64],
            normals: NDArray[np.float64], max_lean_deg: float) -> NDArray[np.float64]:
    """Axes leaned ``lean_deg`` toward +Z, kept within ``max_lean_deg`` of the normals.

    Each axis goes to the angle ``T = th - lean`` from +Z (:func:`_toward_z`). Where that
    leans it more than ``L = max_lean_deg`` from the normal, it stays on the circle
    ``a(phi) = (sin T cos phi, sin T sin phi, cos T)`` and its azimuth is clamped to those
    within ``L``: ``a . n >= cos L`` is ``cos(phi - phi_n) >= k`` with
    ``k = (cos L - cos T cos th_n) / (sin T sin th_n)``, so ``phi`` goes into
    ``phi_n +/- acos(k)``. Where the circle does not come within ``L`` of the normal
    (``k > 1``), the axis is the normal leaned ``L`` toward +Z, the nearest to +Z within
    ``L``. Each case meets the next where they touch: the axes stay continuous along a
    pass.
    """
    out = _toward_z(axes, lean_deg)
    cos_lean = np.cos(np.radians(max_lean_deg))
    over = np.einsum("ij,ij->i", out, normals) < cos_lean - ROUND_OFF
    if not over.any():
        return out
    a, n = out[over], normals[over]
    tilt = np.radians(angle_deg(a, Z_AXIS))
    th_n = np.radians(angle_deg(n, Z_AXIS))
    phi_n = np.arctan2(n[:, 1], n[:, 0])
    phi = np.arctan2(a[:, 1], a[:, 0])
    denominator = np.sin(tilt) * np.sin(th_n)
    k = (cos_lean - np.cos(tilt) * np.cos(th_n)) / np.where(
        np.abs(denominator) > ROUND_OFF, denominator, ROUND_OFF)
    half = np.arccos(np.clip(k, -1.0, 1.0))
    phi = phi_n + np.clip(np.mod(phi - phi_n + np.pi, 2.0 * np.pi) - np.pi, -half, half)
    on_circle = np.column_stack([np.sin(tilt) * np.cos(phi), np.sin(tilt) * np.sin(phi),
                                 np.cos(tilt)])
    nearest = _toward_z(n, np.full(len(n), float(max_lean_deg)))
    out[over] = np.where((k > 1.0)[:, None], nearest, on_circle)
    return out


#: Rounds of :func:`lean_within_tilt` leaning the ends of moves whose middle axis is over.
MID_ROUNDS = 4


def _spread(need: NDArray[np.float64], arclen_mm: NDArray[np.float64],
            pass_id: NDArray[np.int64], smoothing_mm: float,
            max_rate_deg_per_mm: float | None) -> NDArray[np.float64]:
    """Leans at least ``need`` that change slowly along each pass (:func:`lean_within_tilt`)."""
    n = len(need)
    if smoothing_mm <= 0.0 or n < 2:
        return need
    rate = max_rate_deg_per_mm if max_rate_deg_per_mm else 10.0
    w = max(smoothing_mm, float(need.max()) / (2.0 * LEAN_RATE_SHARE * rate))
    arclen = np.ascontiguousarray(arclen_mm, dtype=float)
    widest = np.empty(n)
    _running_max(need, arclen, pass_id, w, widest)
    x, starts, ends, which = _pass_coordinate(arclen, pass_id)
    window = box_window(x, x[starts][which], x[ends][which], np.full(n, w),
                         np.zeros(n, dtype=bool))
    return np.maximum(window_average(widest[:, None], x, window)[:, 0], need)


def lean_within_tilt(axes: NDArray[np.float64], normals: NDArray[np.float64],
                     arclen_mm: NDArray[np.float64], pass_id: NDArray[np.int64], *,
                     max_tilt_deg: float, max_lean_deg: float, smoothing_mm: float,
                     max_rate_deg_per_mm: float | None, moves: bool = True) -> TiltLean:
    """Axes more than ``max_tilt_deg`` from +Z leaned back toward +Z, smoothly along each pass.

    The tilt joint of a 5-axis machine turns the tool axis away from the workpiece +Z by
    the angle ``th`` of the axis from +Z (on either branch, :mod:`machines.kinematics`), so
    ``th <= max_tilt_deg`` is the whole joint limit. Each axis needs a lean
    ``n_i = max(th_i - max_tilt_deg, 0)`` toward +Z along its great circle through +Z (the
    azimuth, hence C, unchanged). The leans are spread along the pass: the largest need
    within ``w`` of each point (same pass, by ``arclen_mm``), then its mean over the same
    window (a box filter), which is at least the need everywhere (every point of a
    window within ``w`` of ``x`` sees ``x``'s need) and changes by at most
    ``max(n) / 2w`` per mm; ``w`` is ``smoothing_mm`` or more, so that the lean turns
    the axis at most :data:`LEAN_RATE_SHARE` of ``max_rate_deg_per_mm``. A leaned axis
    further than ``max_lean_deg`` from the normal is turned back onto that cone
    (:func:`limit_lean`); where that puts it over ``max_tilt_deg`` again, the axis is the
    normal leaned toward +Z by ``min(th_n - max_tilt_deg, max_lean_deg)`` (``th_n`` the
    normal's angle from +Z): within both limits where any axis is, else the best
    (``impossible``, its tilt ``th_n - max_lean_deg``). Between two axes at
    ``max_tilt_deg`` (beyond 90 deg) the great circle bows further from +Z (by about
    ``|cot th| d^2 / 8`` for axes ``d`` apart): where the normalized mean of a move's ends
    is over, the ends' needs grow by the excess and the leans are found again
    (:data:`MID_ROUNDS`).

    Parameters
    ----------
    axes, normals : ndarray, shape (n, 3)
        Unit tool axes and surface normals, passes contiguous.
    arclen_mm : ndarray, shape (n,)
        Arc length along each pass (differences within a pass are used), mm.
    pass_id : ndarray of int, shape (n,)
        Pass of each point.
    max_tilt_deg : float
        Largest angle of an axis from +Z, deg.
    max_lean_deg : float
        Largest angle of an axis from the normal, deg.
    smoothing_mm : float
        Least half-width of the lean's window, mm (0: each point leans by its own need).
    max_rate_deg_per_mm : float or None
        The axis turn-rate limit the lean's ramps keep a share of.
    moves : bool
        Consecutive rows of a pass are consecutive points, joined by moves whose middle
        axes are checked too (False for points scattered along their passes).
    """
    axes = np.ascontiguousarray(axes, dtype=float)
    n = len(axes)
    theta = angle_deg(axes, Z_AXIS)
    need = np.maximum(theta - max_tilt_deg, 0.0)
    if not (need > 0.0).any():
        return TiltLean(axes, np.zeros(n), np.zeros(n, dtype=bool))
    pid = np.ascontiguousarray(pass_id, dtype=np.int64)
    same = (pid[1:] == pid[:-1]) & moves
    for _ in range(MID_ROUNDS):
        lean = np.minimum(_spread(need, arclen_mm, pid, smoothing_mm, max_rate_deg_per_mm),
                          theta)
        out = _leaned(axes, lean, normals, max_lean_deg)
        # a move's axes in between (the normalized mean of its ends: the post's split
        # points) lie off the circle th = max_tilt_deg, further from +Z beyond 90 deg:
        # its ends lean further by the excess
        mid = unit(out[1:] + out[:-1])
        excess = np.where(same, angle_deg(mid, Z_AXIS) - max_tilt_deg, 0.0)
        if not (excess > ANGLE_SLACK_DEG).any():
            break
        grow = np.maximum(np.r_[excess, 0.0], np.r_[0.0, excess])
        need = need + 1.5 * np.maximum(grow, 0.0)
    impossible = angle_deg(normals, Z_AXIS) - max_lean_deg > max_tilt_deg + ANGLE_SLACK_DEG
    moved = angle_deg(out, axes)
    return TiltLean(out, np.where(moved > ANGLE_SLACK_DEG, moved, 0.0), impossible)
