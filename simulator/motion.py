"""Motion physics: block kinematics, grbl junction speeds and trapezoidal profiles.

Every motion block is a straight segment in joint space (X Y Z in mm, A B C in degrees,
treated alike as grbl treats its axes). Its *nominal speed* (mm/s along the joint-space
segment) comes from the programmed feed and is capped by each axis' maximum rate; its
*acceleration* (mm/s^2) is the largest that keeps every axis within its maximum
acceleration (grbl ``limit_value_by_axis_maximum``). The speed allowed through the
junction with the previous block follows grbl 1.1's junction-deviation rule
(``planner.c``). Inside a block the speed follows a trapezoid: accelerate, cruise,
decelerate, with the planned entry and exit speeds.

Feed semantics (units inside: mm, deg, s): G94 ``F`` (mm/min) is the speed of the XYZ
part of the move, or of the rotary part for rotary-only moves (LinuxCNC's rule); G93
``F`` (1/min) makes the move last ``60 / F`` s. Rapids run at the axes' maximum rates.

Scalar functions serve the streaming controller (one block at a time, no numpy
overhead); the ``*_array`` twins serve the whole-program path and give the same numbers.

Examples
--------
>>> trapezoid_time_s(10.0, 0.0, 0.0, 100.0, 1000.0)  # 10 mm, 100 mm/s, 1000 mm/s^2
0.2
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from machines import Machine

__all__ = [
    "DEFAULT_JUNCTION_DEVIATION_MM",
    "LARGE_SPEED_SQ",
    "AxisLimits",
    "BlockKinematics",
    "advance_in_block",
    "block_kinematics",
    "block_kinematics_array",
    "junction_speed_sq",
    "junction_speed_sq_array",
    "trapezoid_time_s",
    "trapezoid_time_s_array",
]

#: grbl ``$11`` default, mm.
DEFAULT_JUNCTION_DEVIATION_MM = 0.010
#: grbl ``SOME_LARGE_VALUE``: no limit on a straight junction, (mm/s)^2.
LARGE_SPEED_SQ = 1.0e38
#: Cosines beyond these are a reversal / a straight line (grbl uses 0.999999).
_COS_LIMIT = 0.999999
_AXES = "XYZABC"

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class AxisLimits:
    """Per-slot limits for the six joint slots X Y Z A B C.

    Attributes
    ----------
    rate_per_s : tuple of 6 float
        Maximum rate, mm/s or deg/s (``inf`` for a slot the machine lacks).
    accel_per_s2 : tuple of 6 float
        Maximum acceleration, mm/s^2 or deg/s^2 (``inf`` for a missing slot).
    present : tuple of 6 bool
        Which slots the machine has.
    """

    rate_per_s: tuple[float, ...]
    accel_per_s2: tuple[float, ...]
    present: tuple[bool, ...]

    @classmethod
    def from_machine(cls, machine: Machine) -> AxisLimits:
        """Take rates (mm/min -> mm/s) and accelerations from a machine definition."""
        rate = [math.inf] * 6
        accel = [math.inf] * 6
        present = [False] * 6
        for ax in machine.axes:
            i = _AXES.index(ax.letter)
            rate[i] = ax.max_rate / 60.0
            accel[i] = ax.max_accel
            present[i] = True
        return cls(tuple(rate), tuple(accel), tuple(present))


@dataclass(frozen=True, slots=True)
class BlockKinematics:
    """What the planner needs of one straight block.

    Attributes
    ----------
    length : float
        Joint-space length, mm (degrees count as mm).
    unit : tuple of 6 float
        Unit direction in joint space (zeros for a zero-length block).
    nominal_speed : float
        Target cruise speed, mm/s along the segment.
    accel : float
        Acceleration limit along the segment, mm/s^2.
    feed_ratio : float
        Reported feed per unit of joint-space speed: XYZ length / joint length, or 1 for
        rotary-only moves.
    """

    length: float
    unit: tuple[float, ...]
    nominal_speed: float
    accel: float
    feed_ratio: float


def _limit_by_axes(limits: tuple[float, ...], unit: tuple[float, ...]) -> float:
    out = math.inf
    for lim, u in zip(limits, unit, strict=True):
        if u != 0.0:
            out = min(out, abs(lim / u))
    return out


def block_kinematics(
    delta: tuple[float, ...],
    feed: float,
    *,
    rapid: bool,
    inverse_time: bool,
    limits: AxisLimits,
) -> BlockKinematics:
    """Length, direction, nominal speed and acceleration of one block.

    Parameters
    ----------
    delta : tuple of 6 float
        End minus start, X Y Z (mm) A B C (deg).
    feed : float
        mm/min (G94) or 1/min (G93); ignored for rapids.
    rapid : bool
        G0: run at the axes' maximum rates.
    inverse_time : bool
        ``feed`` is inverse time (G93).
    limits : AxisLimits
        The machine's rates and accelerations.

    Returns
    -------
    BlockKinematics
        Zero length gives zero speed and acceleration.
    """
    sq_xyz = delta[0] * delta[0] + delta[1] * delta[1] + delta[2] * delta[2]
    sq_rot = delta[3] * delta[3] + delta[4] * delta[4] + delta[5] * delta[5]
    length = math.sqrt(sq_xyz + sq_rot)
    if length == 0.0:
        return BlockKinematics(0.0, (0.0,) * 6, 0.0, 0.0, 1.0)
    unit = tuple(d / length for d in delta)
    rate_cap = _limit_by_axes(limits.rate_per_s, unit)
    xyz = math.sqrt(sq_xyz)
    if rapid:
        speed = rate_cap
    elif inverse_time:
        speed = min(length * feed / 60.0, rate_cap)
    else:
        ref = xyz if xyz > 0.0 else math.sqrt(sq_rot)
        speed = min(feed / 60.0 * length / ref, rate_cap)
    ratio = xyz / length if xyz > 0.0 else 1.0
    return BlockKinematics(length, unit, speed, _limit_by_axes(limits.accel_per_s2, unit), ratio)


def block_kinematics_array(
    start: FloatArray,
    end: FloatArray,
    feed: FloatArray,
    rapid: npt.NDArray[np.bool_],
    inverse_time: npt.NDArray[np.bool_],
    limits: AxisLimits,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Vectorized :func:`block_kinematics` over rows of segments.

    Returns
    -------
    length, unit, nominal_speed, accel, feed_ratio : ndarray
        Shapes (n,), (n, 6), (n,), (n,), (n,); same units as the scalar version.
    """
    delta = end - start
    sq = delta * delta
    sq_xyz = sq[:, 0] + sq[:, 1] + sq[:, 2]
    sq_rot = sq[:, 3] + sq[:, 4] + sq[:, 5]
    length = np.sqrt(sq_xyz + sq_rot)
    moving = length > 0.0
    safe = np.where(moving, length, 1.0)
    unit = delta / safe[:, None]
    absu = np.abs(unit)
    rate_cap = np.full(length.shape, np.inf)
    accel = np.full(length.shape, np.inf)
    with np.errstate(divide="ignore"):
        for i in range(6):
            col = absu[:, i]
            if not col.any():
                continue
            np.minimum(rate_cap, limits.rate_per_s[i] / col, out=rate_cap)
            np.minimum(accel, limits.accel_per_s2[i] / col, out=accel)
    xyz = np.sqrt(sq_xyz)
    ref = np.where(xyz > 0.0, xyz, np.sqrt(sq_rot))
    with np.errstate(divide="ignore", invalid="ignore"):
        g94 = feed / 60.0 * length / np.where(ref > 0.0, ref, 1.0)
    speed = np.where(inverse_time, length * feed / 60.0, g94)
    speed = np.where(rapid, rate_cap, np.minimum(speed, rate_cap))
    speed = np.where(moving, speed, 0.0)
    accel = np.where(moving, accel, 0.0)
    ratio = np.where(xyz > 0.0, xyz / safe, 1.0)
    return length, unit, speed, accel, ratio


def junction_speed_sq(
    prev_unit: tuple[float, ...],
    unit: tuple[float, ...],
    limits: AxisLimits,
    junction_deviation_mm: float,
) -> float:
    """Largest squared speed through the corner between two blocks, (mm/s)^2.

    grbl 1.1 ``plan_buffer_line``: the corner is rounded by a circle that deviates at
    most ``junction_deviation_mm`` from it, run at the acceleration the axes allow along
    the change of direction. A straight continuation is unlimited (:data:`LARGE_SPEED_SQ`),
    a full reversal gives 0.
    """
    cos_theta = -sum(p * u for p, u in zip(prev_unit, unit, strict=True))
    if cos_theta > _COS_LIMIT:
        return 0.0
    if cos_theta < -_COS_LIMIT:
        return LARGE_SPEED_SQ
    ju = [u - p for p, u in zip(prev_unit, unit, strict=True)]
    norm = math.sqrt(sum(v * v for v in ju))
    ju_unit = tuple(v / norm for v in ju)
    accel = _limit_by_axes(limits.accel_per_s2, ju_unit)
    sin_half = math.sqrt(0.5 * (1.0 - cos_theta))
    return max(0.0, accel * junction_deviation_mm * sin_half / (1.0 - sin_half))


def junction_speed_sq_array(
    prev_unit: FloatArray, unit: FloatArray, limits: AxisLimits, junction_deviation_mm: float
) -> FloatArray:
    """Vectorized :func:`junction_speed_sq` over rows, (mm/s)^2."""
    cos_theta = -np.einsum("ij,ij->i", prev_unit, unit)
    ju = unit - prev_unit
    norm = np.sqrt(np.einsum("ij,ij->i", ju, ju))
    inv = 1.0 / np.where(norm > 0.0, norm, 1.0)
    accel = np.full(cos_theta.shape, np.inf)
    with np.errstate(divide="ignore"):
        for i in range(6):
            col = np.abs(ju[:, i])
            if not col.any():
                continue
            np.minimum(accel, limits.accel_per_s2[i] / (col * inv), out=accel)
    sin_half = np.sqrt(np.clip(0.5 * (1.0 - cos_theta), 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        v2 = np.maximum(0.0, accel * junction_deviation_mm * sin_half / (1.0 - sin_half))
    out = np.where(cos_theta < -_COS_LIMIT, LARGE_SPEED_SQ, v2)
    return np.where(cos_theta > _COS_LIMIT, 0.0, out)


def trapezoid_time_s(length: float, v0: float, v1: float, vn: float, accel: float) -> float:
    """Time to run ``length`` mm from speed ``v0`` to ``v1`` capped at ``vn`` (mm/s).

    Parameters
    ----------
    length : float
        mm (0 gives 0 s).
    v0, v1 : float
        Entry and exit speeds, mm/s (feasible: ``|v1^2 - v0^2| <= 2 accel length``).
    vn : float
        Nominal (cruise) speed, mm/s.
    accel : float
        mm/s^2.

    Returns
    -------
    float
        Seconds: accelerate, cruise, decelerate (a triangle when ``vn`` is not reached).
    """
    if length <= 0.0:
        return 0.0
    two_a = 2.0 * accel
    d_acc = (vn * vn - v0 * v0) / two_a
    d_dec = (vn * vn - v1 * v1) / two_a
    if d_acc + d_dec <= length:
        return (vn - v0) / accel + (length - d_acc - d_dec) / vn + (vn - v1) / accel
    vp = math.sqrt(max((two_a * length + v0 * v0 + v1 * v1) / 2.0, v0 * v0, v1 * v1))
    return (vp - v0) / accel + (vp - v1) / accel


def trapezoid_time_s_array(
    length: FloatArray, v0: FloatArray, v1: FloatArray, vn: FloatArray, accel: FloatArray
) -> FloatArray:
    """Vectorized :func:`trapezoid_time_s`, s."""
    moving = length > 0.0
    a = np.where(moving, accel, 1.0)
    vn_ = np.where(moving, vn, 1.0)
    two_a = 2.0 * a
    d_acc = (vn_ * vn_ - v0 * v0) / two_a
    d_dec = (vn_ * vn_ - v1 * v1) / two_a
    cruise = d_acc + d_dec <= length
    t_trap = (vn_ - v0) / a + (length - d_acc - d_dec) / vn_ + (vn_ - v1) / a
    vp = np.sqrt(np.maximum.reduce([(two_a * length + v0 * v0 + v1 * v1) / 2.0, v0 * v0, v1 * v1]))
    t_tri = (vp - v0) / a + (vp - v1) / a
    return np.where(moving, np.where(cruise, t_trap, t_tri), 0.0)


def advance_in_block(
    s: float,
    v: float,
    length: float,
    vn: float,
    vx: float,
    accel: float,
    dt: float,
    hold: bool,
) -> tuple[float, float, float]:
    """Move along one block for at most ``dt`` seconds.

    Parameters
    ----------
    s, v : float
        Distance done in the block (mm) and current speed (mm/s).
    length, vn, vx, accel : float
        Block length (mm), nominal speed and planned exit speed (mm/s), mm/s^2.
    dt : float
        Time available, s.
    hold : bool
        Feed hold: decelerate at ``accel`` whatever the plan.

    Returns
    -------
    (s, v, used) : tuple of float
        New distance and speed, and the time used. ``used < dt`` only when the block
        end was reached (``s == length``) or, in a hold, the axes stopped (``v == 0``).
    """
    r = length - s
    if r <= 0.0:
        return length, v, 0.0
    if hold:
        d_stop = v * v / (2.0 * accel)
        if d_stop < r:
            t_end, v_end, s_end = v / accel, 0.0, s + d_stop
        else:
            v_end = math.sqrt(max(v * v - 2.0 * accel * r, 0.0))
            t_end, s_end = (v - v_end) / accel, length
        if dt >= t_end:
            return s_end, v_end, t_end
        return min(s + v * dt - 0.5 * accel * dt * dt, s_end), v - accel * dt, dt
    two_a = 2.0 * accel
    vx = min(vx, math.sqrt(v * v + two_a * r))
    vp = math.sqrt(max(min(vn * vn, (two_a * r + v * v + vx * vx) / 2.0), v * v, vx * vx))
    t1 = (vp - v) / accel
    d1 = (vp * vp - v * v) / two_a
    d3 = (vp * vp - vx * vx) / two_a
    d2 = max(r - d1 - d3, 0.0)
    t2 = d2 / vp if vp > 0.0 else 0.0
    t3 = (vp - vx) / accel
    if dt >= t1 + t2 + t3:
        return length, vx, t1 + t2 + t3
    if dt < t1:
        return s + v * dt + 0.5 * accel * dt * dt, v + accel * dt, dt
    if dt < t1 + t2:
        return s + d1 + vp * (dt - t1), vp, dt
    t = dt - t1 - t2
    return min(s + d1 + d2 + vp * t - 0.5 * accel * t * t, length), vp - accel * t, dt
