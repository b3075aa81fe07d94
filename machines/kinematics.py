"""Forward and inverse kinematics, vectorized over paths.

Conventions (every angle in deg, every length in mm):

* Frames as in :mod:`machines.machine`: the machine frame, and the workpiece frame carried
  by the rotary table, parallel to the machine frame at zero rotary angles with its origin
  at ``machine.work_origin``. Tool-tip positions and tool axes are given in the workpiece
  frame; the tool axis is the unit vector from the tip toward the spindle (+Z for a
  vertical spindle).
* Rotations are right-handed about the positive machine axis of the moving part: a
  positive table angle turns the *table* right-handed about +X (A), +Y (B) or +Z (C), as
  LinuxCNC's ``xyzac-trt-kins`` does (the tests check its forward formula; this is the
  opposite of the ISO tool-relative direction); a positive head angle turns the
  *spindle* right-handed about +Y (B) or +X (A).
* With ``R_k(q)`` the right-handed rotation by ``q`` about axis ``k``, ``t`` the tilt angle,
  ``c`` the C angle, ``P`` = ``rotary_centre``, ``P_C = P + c_offset``, ``O`` =
  ``work_origin``, ``L`` = ``tool_length``, ``Lp`` = ``head_pivot_length``, ``G`` the
  linear joints and ``q``, ``w`` the tip and tool axis in the workpiece frame:

  - table-table: ``tip_M = R_t(t) (R_z(c) (O + q - P_C) + P_C - P) + P``,
    ``G = tip_M + L Z``, ``w = R_z(-c) R_t(-t) Z``;
  - head-table: ``tip_M = R_z(c) (O + q - P) + P``, ``u = R_h(t) Z``,
    ``G = tip_M + (Lp + L) u - Lp Z``, ``w = R_z(-c) u``;
  - 3-axis: ``G = O + q + L Z``, ``w = Z``.

  Both 5-axis families give ``w = R_z(-c) (sin t d + cos t Z)`` with a fixed horizontal unit
  vector ``d``, so the tilt magnitude is the angle of ``w`` from +Z and C follows from the
  azimuth of ``w``. Every ``w`` off +Z has two solutions, ``(t, c)`` and ``(-t, c + 180)``.

Branch and unwrap rules of :func:`inverse` (vectorized; no per-point Python loop):

1. A point whose tilt is inside the singular cone (angle of ``w`` from +Z below
   `cone_deg`), where C is undefined, does not follow the azimuth of ``w``: C is held at
   the value of the nearest point outside the cone at the start and end of a path (or at
   `start`'s), and between cone entry and exit it is carried linearly, by point index,
   from the entry value to the exit value (these are equal, so C is simply held, when the
   path passes straight through the vertical; otherwise the turn C must make, at most
   90 deg, or 180 deg where rule 2 keeps the branch, is spread over the cone instead of
   jumping at its edge). The tilt is then the signed
   angle that best fits ``w`` in the plane C allows, so the tool axis there is off by at
   most `cone_deg`. The tip position is always exact.
2. Between consecutive points outside the cone, the branch switches when the other
   branch's C is closer (the C step on the current branch would exceed 90 deg), i.e.
   where the path crosses the singular cone and the switch costs no C motion, unless the
   switched branch would leave the tilt axis's travel where the current one would not
   (e.g. a trunnion with A in [-120, 30] keeps A negative and turns C by 180 deg through
   the cone instead). This is a sequential pass over such crossings, not over points.
3. The first branch is the one closest to `start` when given; otherwise the one whose tilt
   values leave the tilt axis's travel at fewer points up to the first crossing, ties
   going to ``machine.preferred_tilt_sign``.
4. C is unwrapped (no 359 -> 0 jumps). Without `start`, the path is shifted by whole turns to
   begin in [-180, 180] deg, or, on a LIMITED C axis, to fit its travel when a shift can.

Examples
--------
>>> import numpy as np
>>> from machines.machine import load_machine
>>> m = load_machine("trunnion-ac")
>>> tips = np.array([[10.0, 0.0, 50.0]])
>>> axes = np.array([[0.0, np.sin(np.radians(30)), np.cos(np.radians(30))]])
>>> j = inverse(m, tips, axes)
>>> j[0, 3:].round(6).tolist()  # A, C: the negative branch (preferred_tilt = negative)
[-30.0, 180.0]
>>> tip, axis = forward(m, j)
>>> bool(np.allclose(tip, tips) and np.allclose(axis, axes))
True
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from machines.axes import Axis
from machines.errors import KinematicsError, UnreachableOrientationError
from machines.machine import KinematicType, Machine

__all__ = [
    "AXIS_NORM_TOL",
    "SINGULAR_CONE_DEG",
    "XYZ_AXIS_TOL_DEG",
    "InverseSolution",
    "controller_values",
    "forward",
    "inverse",
    "linear_jacobian",
    "solve_inverse",
    "tilt_reach_deg",
    "tool_point_gradient",
]

SINGULAR_CONE_DEG: Final[float] = 0.1
"""Default half-angle of the singular cone, deg. Inside it C does not follow the azimuth of
the tool axis, and the axis may be off by up to this angle: 0.1 deg (1.7 mrad) moves the
centre of a 6 mm ball (radius 3 mm) by at most 0.0052 mm, about the finest scallop height
the planner is asked for, while absorbing round-off and paths that graze the vertical."""

XYZ_AXIS_TOL_DEG: Final[float] = 1e-3
"""Largest angle from +Z, deg, accepted as "vertical" on a 3-axis machine (17 urad: round-off
of computed axes, far below any effect on the cut)."""

AXIS_NORM_TOL: Final[float] = 1e-6
"""Largest accepted deviation of a tool-axis vector's norm from 1 (relative). Vectors within it
are renormalized; anything further is a caller bug and raises."""

_Z = np.array([0.0, 0.0, 1.0])


@dataclass(frozen=True, slots=True)
class InverseSolution:
    """Result of :func:`solve_inverse`.

    Attributes
    ----------
    joints : numpy.ndarray, shape (n, n_axes)
        Joint values in the machine's axis order: mm for linear axes, deg (unwrapped) for
        rotary axes.
    in_cone : numpy.ndarray of bool, shape (n,)
        True where the tool axis was inside the singular cone, so C did not follow its
        azimuth (always False on a 3-axis machine).
    axis_error_deg : numpy.ndarray, shape (n,)
        Angle between the requested and the achieved tool axis, deg (0 up to round-off
        outside the cone, at most the cone angle inside it).
    """

    joints: NDArray[np.float64]
    in_cone: NDArray[np.bool_]
    axis_error_deg: NDArray[np.float64]


# --------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------


def _rot(v: NDArray[np.float64], k: int, ang_deg: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotate row vectors ``v`` (n, 3) right-handed about basis axis ``k`` by ``ang_deg``."""
    return _rot_cs(v, k, *_cos_sin(ang_deg))


def _cos_sin(ang_deg: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``cos`` and ``sin`` of angles in deg (computed once where a rotation is used twice)."""
    a = np.radians(ang_deg)
    return np.cos(a), np.sin(a)


def _rot_cs(v: NDArray[np.float64], k: int, c: NDArray[np.float64], s: NDArray[np.float64]
            ) -> NDArray[np.float64]:
    """:func:`_rot` by the angles whose cosines ``c`` and sines ``s`` are given."""
    x, y, z = v[:, 0], v[:, 1], v[:, 2]
    out = np.empty((len(c), 3))
    i, j = ((1, 2), (2, 0), (0, 1))[k]  # the plane turned: e_i toward e_j
    a, b = v[:, i], v[:, j]
    out[:, k] = (x, y, z)[k]
    np.multiply(c, a, out=out[:, i])
    out[:, i] -= s * b
    np.multiply(s, a, out=out[:, j])
    out[:, j] += c * b
    return out


def _wrap180(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angles wrapped into [-180, 180) deg."""
    return np.mod(a + 180.0, 360.0) - 180.0


def _as_rows(a: ArrayLike, name: str, width: int) -> tuple[NDArray[np.float64], bool]:
    arr = np.asarray(a, dtype=float)
    single = arr.ndim == 1
    if single:
        arr = arr[None, :]
    if arr.ndim != 2 or arr.shape[1] != width:
        raise KinematicsError(
            f"{name} must have shape (n, {width}) or ({width},), got {np.shape(a)!r}"
        )
    if not np.isfinite(arr).all():  # (one pass over the values; rows only to name one)
        i = int(np.flatnonzero(~np.isfinite(arr).all(axis=1))[0])
        raise KinematicsError(f"{name}[{i}] is not finite: {arr[i].tolist()!r}")
    return arr, single


def _unit_axes(axes: NDArray[np.float64]) -> NDArray[np.float64]:
    norm = np.linalg.norm(axes, axis=1)
    bad = np.abs(norm - 1.0) > AXIS_NORM_TOL
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise KinematicsError(
            f"tool axis {i} is not a unit vector: {axes[i].tolist()!r} has norm "
            f"{float(norm[i])!r} (tolerance {AXIS_NORM_TOL!r})"
        )
    return axes / norm[:, None]


def _tilt_index(kin: KinematicType) -> int:
    return 0 if kin.tilt_letter == "A" else 1


def _tilt_sign(kin: KinematicType) -> float:
    """+1 when the tool axis tilts with the angle (head), -1 when against it (table)."""
    return 1.0 if kin.tilting_head else -1.0


def _azimuth_of_d(kin: KinematicType) -> float:
    """Azimuth, deg, of the horizontal direction ``d`` the tool axis leans to at t=+90, c=0."""
    d = _rot(_Z[None, :], _tilt_index(kin), np.array([90.0 * _tilt_sign(kin)]))[0]
    return float(np.degrees(np.arctan2(d[1], d[0])))


def _order(machine: Machine) -> list[int]:
    """Machine column of each canonical column (X, Y, Z[, tilt, C])."""
    return [machine.index(letter) for letter in machine.kinematics.letters]


# --------------------------------------------------------------------------------------
# forward
# --------------------------------------------------------------------------------------


def forward(machine: Machine, joints: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Tool-tip positions and tool axes in the workpiece frame from joint values.

    Parameters
    ----------
    machine : Machine
        The machine.
    joints : array_like, shape (n, n_axes) or (n_axes,)
        Joint values in the machine's axis order: mm for linear axes, deg for rotary axes
        (any number of turns).

    Returns
    -------
    tips : numpy.ndarray, shape (n, 3) or (3,)
        Tool-tip positions in the workpiece frame, mm.
    axes : numpy.ndarray, shape (n, 3) or (3,)
        Unit tool axes (tip toward spindle) in the workpiece frame.

    Raises
    ------
    KinematicsError
        For a wrong shape or non-finite values.
    """
    j, single = _as_rows(joints, "joints", machine.n_axes)
    canon = j[:, _order(machine)]
    g = canon[:, :3]
    n = len(j)
    kin = machine.kinematics
    origin = np.asarray(machine.work_origin)
    z = np.broadcast_to(_Z, (n, 3))
    if kin is KinematicType.XYZ:
        tips = g - machine.tool_length * _Z - origin
        axes = np.array(z)
    else:
        t, c = canon[:, 3], canon[:, 4]
        k = _tilt_index(kin)
        p = np.asarray(machine.rotary_centre)
        turn_c = _cos_sin(-c)  # (each rotation's cos and sin once: used twice)
        if kin.tilting_head:
            u = _rot(z, k, t)
            lp = machine.head_pivot_length
            tip_m = g + lp * _Z - (lp + machine.tool_length) * u
            tips = _rot_cs(tip_m - p, 2, *turn_c) + p - origin
            axes = _rot_cs(u, 2, *turn_c)
        else:
            turn_t = _cos_sin(-t)
            pc = p + np.asarray(machine.c_offset)
            tip_m = g - machine.tool_length * _Z
            v = _rot_cs(tip_m - p, k, *turn_t) + p - pc
            tips = _rot_cs(v, 2, *turn_c) + pc - origin
            axes = _rot_cs(_rot_cs(z, k, *turn_t), 2, *turn_c)
    if single:
        return tips[0], axes[0]
    return tips, axes


def tool_point_gradient(machine: Machine, joints: ArrayLike, along_mm: float,
                        covectors: ArrayLike) -> NDArray[np.float64]:
    """How ``w . P`` changes with each joint, for a point ``P`` carried by the tool.

    ``P = tip + along_mm * axis`` (workpiece frame, :func:`forward`; a ball's centre with
    ``along_mm`` its radius) and ``w`` one covector per row (a unit normal: then the
    rate of ``P``'s distance to a surface at its foot). Returns ``d(w . P)/dq`` per row
    (n, n_axes), machine axis order, per mm of a linear joint and per deg of a rotary
    one: the joints moving at rates ``dq`` move ``w . P`` at ``gradient . dq`` (under
    joint interpolation, ``dq = q_b - q_a`` per unit ``u`` along the move).

    The derivative of the formulas of the module's text: a rotation ``R_k(a)`` turning
    at ``a'`` (rad) moves ``R_k(a) x`` at ``a' e_k x R_k(a) x``. With ``e_t`` the tilt
    joint's axis, ``e'_t = R_z(-c) e_t`` (horizontal), ``P_0`` = ``rotary_centre`` and
    ``P_C = P_0 + c_offset`` (per deg: times ``pi / 180``):

    - table-table: ``dP/dG = R_z(-c) R_t(-t)``, so ``w . dP/dG = R_t(t) R_z(c) w``;
      ``dP/dt = -e'_t x (P - P_C + O - R_z(-c)(P_0 - P_C))``;
      ``dP/dc = -Z x (P - P_C + O)``;
    - head-table: ``w . dP/dG = R_z(c) w``; ``dP/dt = (along - Lp - L) e'_t x axis``;
      ``dP/dc = -Z x (P - P_0 + O)``;
    - 3-axis: ``w . dP/dG = w``.

    Parameters
    ----------
    machine : Machine
        The machine.
    joints : array_like, shape (n, n_axes)
        Joint values in the machine's axis order.
    along_mm : float
        How far up the tool axis from the tip ``P`` lies, mm.
    covectors : array_like, shape (n, 3)
        ``w`` per row, workpiece frame.

    Returns
    -------
    numpy.ndarray, shape (n, n_axes)
        ``d(w . P)/dq``: mm per mm of a linear joint, mm per deg of a rotary one (for a
        unit ``w``).

    Raises
    ------
    KinematicsError
        For a wrong shape or non-finite values.
    """
    j, _ = _as_rows(joints, "joints", machine.n_axes)
    w, _ = _as_rows(covectors, "covectors", 3)
    if len(w) != len(j):
        raise KinematicsError(f"covectors has {len(w)} rows, joints {len(j)}")
    order = _order(machine)
    out = np.zeros((len(j), machine.n_axes))
    kin = machine.kinematics
    if kin is KinematicType.XYZ:
        out[:, order] = w
        return out
    tips, axes = forward(machine, j)
    canon = j[:, order]
    cos_c, sin_c = _cos_sin(canon[:, 4])
    rad = np.pi / 180.0
    origin = np.asarray(machine.work_origin)
    centre = np.asarray(machine.rotary_centre)
    point = tips + along_mm * axes
    # e'_t = R_z(-c) e_t, horizontal: (cos c, -sin c, 0) for A, (sin c, cos c, 0) for B
    k = _tilt_index(kin)
    tilt = (cos_c, -sin_c) if k == 0 else (sin_c, cos_c)
    if kin.tilting_head:
        lin = _rot_cs(w, 2, cos_c, sin_c)
        lever = along_mm - machine.head_pivot_length - machine.tool_length
        arm = point - centre + origin
        d_tilt = lever * _horizontal_triple(tilt, axes, w)
    else:
        lin = _rot_cs(_rot_cs(w, 2, cos_c, sin_c), k, *_cos_sin(canon[:, 3]))
        offset = np.asarray(machine.c_offset, dtype=float)
        arm = point - centre - offset + origin
        lever = arm
        if offset.any():  # arm - R_z(-c) (P - P_C), with P - P_C = -c_offset
            lever = arm + _rot_cs(np.broadcast_to(offset, (len(j), 3)), 2, cos_c, -sin_c)
        d_tilt = -_horizontal_triple(tilt, lever, w)
    out[:, order[:3]] = lin
    out[:, order[3]] = rad * d_tilt
    # dP/dc = -Z x arm = (arm_y, -arm_x, 0)
    out[:, order[4]] = rad * (arm[:, 1] * w[:, 0] - arm[:, 0] * w[:, 1])
    return out


def _horizontal_triple(a: tuple[NDArray[np.float64], NDArray[np.float64]],
                       v: NDArray[np.float64], w: NDArray[np.float64]) -> NDArray[np.float64]:
    """``(a x v) . w = a . (v x w)`` per row, ``a = (a_x, a_y, 0)`` horizontal."""
    return (a[0] * (v[:, 1] * w[:, 2] - v[:, 2] * w[:, 1])
            + a[1] * (v[:, 2] * w[:, 0] - v[:, 0] * w[:, 2]))


# --------------------------------------------------------------------------------------
# inverse
# --------------------------------------------------------------------------------------


def tilt_reach_deg(machine: Machine) -> float:
    """Largest angle of the tool axis from the workpiece +Z the tilt joint can make, deg.

    The tilt joint sets that angle ``th`` on one branch (``t = th``) or the other
    (``t = -th``, C turned half a turn): the reach is ``max(t_max, -t_min)`` of its travel
    (180 for an unlimited tilt axis, 0 on a 3-axis machine).

    Examples
    --------
    >>> from machines.machine import load_machine
    >>> tilt_reach_deg(load_machine("trunnion-ac")), tilt_reach_deg(load_machine("head-table-bc"))
    (120.0, 110.0)
    """
    letter = machine.kinematics.tilt_letter
    if letter is None:
        return 0.0
    axis = machine.axis(letter)
    if not axis.is_limited:
        return 180.0
    return float(min(max(axis.max, -axis.min), 180.0))


def _fit_turns(c: NDArray[np.float64], axis: Axis) -> NDArray[np.float64]:
    """Shift an unwrapped C path by whole turns: start in [-180, 180], or fit LIMITED travel."""
    c = c - 360.0 * np.round(c[0] / 360.0)
    if not axis.is_limited:
        return c
    lo, hi = float(c.min()), float(c.max())
    centre = np.round(((axis.min + axis.max) - (lo + hi)) / 720.0)
    ks = np.unique(np.concatenate([np.arange(centre - 2, centre + 3), [0.0]]))
    excess = np.maximum(0.0, axis.min - (lo + 360.0 * ks)) + np.maximum(
        0.0, (hi + 360.0 * ks) - axis.max
    )
    best = ks[np.lexsort((np.abs(c[0] + 360.0 * ks), excess))[0]]
    return c + 360.0 * best


def _angles(
    machine: Machine,
    w: NDArray[np.float64],
    start: NDArray[np.float64] | None,
    cone_deg: float,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """C and the in-cone mask for unit tool axes ``w`` along a path (rules 1-4)."""
    kin = machine.kinematics
    n = len(w)
    phi_d = _azimuth_of_d(kin)
    tilt_axis = machine.axis(kin.tilt_letter or "")
    c_axis = machine.axis("C")
    mag = np.degrees(np.arctan2(np.hypot(w[:, 0], w[:, 1]), w[:, 2]))
    c_plus = phi_d - np.degrees(np.arctan2(w[:, 1], w[:, 0]))
    in_cone = mag < cone_deg
    out = np.flatnonzero(~in_cone)
    c = np.empty(n)
    c_start = None if start is None else float(start[machine.index("C")])
    t_start = None if start is None else float(start[machine.index(kin.tilt_letter or "")])
    if out.size:
        cp = c_plus[out]
        # rule 2: the branch may switch only where the other branch's C is the closer one;
        # this splits the path into runs, each on one branch
        flips = np.abs(_wrap180(np.diff(cp))) > 90.0
        run = np.concatenate([[0], np.cumsum(flips)])
        n_runs = int(run[-1]) + 1
        m_out = mag[out]
        # points of each run that leave the tilt travel on the + and on the - branch
        miss = {
            1.0: np.bincount(run, ~tilt_axis.within(m_out), minlength=n_runs).tolist(),
            -1.0: np.bincount(run, ~tilt_axis.within(-m_out), minlength=n_runs).tolist(),
        }
        if c_start is not None and t_start is not None:
            t0 = m_out[0]
            dist_plus = abs(_wrap180(np.array(cp[0] - c_start))) + abs(t0 - t_start)
            dist_minus = abs(_wrap180(np.array(cp[0] + 180.0 - c_start))) + abs(-t0 - t_start)
            s0 = 1.0 if dist_plus <= dist_minus else -1.0
        elif miss[1.0][0] == miss[-1.0][0]:
            s0 = float(machine.preferred_tilt_sign)
        else:
            s0 = 1.0 if miss[1.0][0] < miss[-1.0][0] else -1.0
        # rule 3: cheap sequential pass over the runs (not the points): take the closer
        # branch unless it leaves the tilt travel where the current one does not
        signs = [s0]
        for r in range(1, n_runs):
            keep = signs[-1]
            signs.append(keep if miss[-keep][r] > miss[keep][r] else -keep)
        sign = np.asarray(signs)[run]
        c_out = np.unwrap(cp + np.where(sign < 0.0, 180.0, 0.0), period=360.0)
        if c_start is not None:
            c_out = c_out + 360.0 * np.round((c_start - c_out[0]) / 360.0)
        else:
            c_out = _fit_turns(c_out, c_axis)
        c[out] = c_out
        # rule 1: inside the cone C is held at the edges of the path and carried linearly
        # (by point index) from its entry to its exit value between them
        if in_cone.any():
            inside = np.flatnonzero(in_cone)
            if c_start is None:
                c[inside] = np.interp(inside, out, c_out)
            else:
                c[inside] = np.interp(inside, np.r_[-1, out], np.r_[c_start, c_out])
    else:
        c[:] = 0.0 if c_start is None else c_start
    return c, in_cone


def _tilts(kin: KinematicType, w: NDArray[np.float64], c: NDArray[np.float64]
           ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Signed tilt and axis error (deg) of unit axes ``w`` in the planes their C allows.

    Exact outside the cone, the best fit inside it: the achieved axis is ``w`` projected on
    the plane of ``h`` (the lean direction at that C) and Z; the error is its angle. Row by
    row (a row's values depend on its own ``w`` and ``c`` only).
    """
    psi = np.radians(_azimuth_of_d(kin) - c)
    h0, h1 = np.cos(psi), np.sin(psi)
    t = np.degrees(np.arctan2(w[:, 0] * h0 + w[:, 1] * h1, w[:, 2]))
    err = np.degrees(np.arcsin(np.minimum(np.abs(w[:, 0] * h1 - w[:, 1] * h0), 1.0)))
    return t, err


def _linear_joints(machine: Machine, q: NDArray[np.float64], t: NDArray[np.float64],
                   c: NDArray[np.float64]) -> NDArray[np.float64]:
    """Linear joints ``G`` (n, 3) of tips ``q`` at tilt ``t`` and C ``c`` (row by row)."""
    kin = machine.kinematics
    origin = np.asarray(machine.work_origin)
    k = _tilt_index(kin)
    p = np.asarray(machine.rotary_centre)
    if kin.tilting_head:
        tip_m = _rot(origin + q - p, 2, c) + p
        u = _rot(np.broadcast_to(_Z, (len(q), 3)), k, t)
        lp = machine.head_pivot_length
        return tip_m + (lp + machine.tool_length) * u - lp * _Z
    pc = p + np.asarray(machine.c_offset)
    tip_m = _rot(_rot(origin + q - pc, 2, c) + pc - p, k, t) + p
    return tip_m + machine.tool_length * _Z


def solve_inverse(
    machine: Machine,
    tips: ArrayLike,
    axes: ArrayLike,
    *,
    start: ArrayLike | None = None,
    cone_deg: float = SINGULAR_CONE_DEG,
    axis_tol_deg: float = XYZ_AXIS_TOL_DEG,
    previous: tuple[InverseSolution, NDArray[np.int64]] | None = None,
) -> InverseSolution:
    """Joint values along a path, with the cone and achieved-axis report.

    Parameters
    ----------
    machine : Machine
        The machine.
    tips : array_like, shape (n, 3)
        Tool-tip positions in the workpiece frame, mm, in path order.
    axes : array_like, shape (n, 3)
        Unit tool axes (tip toward spindle) in the workpiece frame.
    start : array_like, shape (n_axes,), optional
        Joint values the path continues from (machine axis order, mm and deg): the branch
        and the C turn closest to it are chosen, and C is held at its value if the path
        starts inside the singular cone.
    cone_deg : float, optional
        Half-angle of the singular cone, deg (default :data:`SINGULAR_CONE_DEG`).
    axis_tol_deg : float, optional
        3-axis machines only: largest accepted angle of a tool axis from +Z, deg
        (default :data:`XYZ_AXIS_TOL_DEG`).
    previous : (InverseSolution, ndarray of int64), optional
        5-axis: the solution of a path these points came from (a path with points
        inserted), and per row of ``tips`` its row there (``-1``: a new point), whose tip
        and axis must be this row's. C, the branch and the cone are decided along the
        whole path as always; a row whose C and cone come out as before keeps its tilt,
        linear joints and axis error (they follow from the row's own point, C and cone
        alone), so only new rows and rows whose C moved are computed. The result is the
        one without ``previous``, value for value.

    Returns
    -------
    InverseSolution
        Joints (n, n_axes) in the machine's axis order, the in-cone mask and the axis error.

    Raises
    ------
    KinematicsError
        For wrong shapes, non-finite values or non-unit axes.
    UnreachableOrientationError
        On a 3-axis machine, for tool axes further than `axis_tol_deg` from +Z; the
        message names the first such point, and ``indices`` lists all of them.

    Notes
    -----
    Travel limits are not applied here: check the result with
    :func:`machines.limits.check_travel`, which reports and never clips.
    """
    q, _ = _as_rows(tips, "tips", 3)
    w, _ = _as_rows(axes, "axes", 3)
    if len(q) != len(w):
        raise KinematicsError(f"tips has {len(q)} rows but axes has {len(w)}")
    w = _unit_axes(w)
    if not (np.isfinite(cone_deg) and 0.0 <= cone_deg < 90.0):
        raise KinematicsError(f"cone_deg must be in [0, 90) deg, got {cone_deg!r}")
    st = None
    if start is not None:
        st, _ = _as_rows(start, "start", machine.n_axes)
        st = st[0]
    kin = machine.kinematics
    origin = np.asarray(machine.work_origin)
    n = len(q)
    canon = np.empty((n, len(kin.letters)))
    if kin is KinematicType.XYZ:
        off = np.degrees(np.arctan2(np.hypot(w[:, 0], w[:, 1]), w[:, 2]))
        bad = np.flatnonzero(off > axis_tol_deg)
        if bad.size:
            i = int(bad[0])
            raise UnreachableOrientationError(
                f"3-axis machine {machine.name!r} holds the tool axis at +Z only: point {i} "
                f"has tool axis {w[i].round(6).tolist()!r}, {float(off[i]):.4g} deg from +Z "
                f"({bad.size} such point{'s' if bad.size != 1 else ''}; "
                f"tolerance {axis_tol_deg!r} deg)",
                indices=bad.tolist(),
            )
        canon[:, :3] = origin + q + machine.tool_length * _Z
        in_cone = np.zeros(n, dtype=bool)
        err = off
    else:
        c, in_cone = _angles(machine, w, st, cone_deg)
        order = _order(machine)
        # rows solved before with the same point, the same C and cone: the same numbers in,
        # the same out (every later step is row by row)
        if previous is None:
            t, err = _tilts(kin, w, c)
            canon[:, 3] = t
            canon[:, :3] = _linear_joints(machine, q, t, c)
        else:
            old_sol, was = previous
            if np.shape(was) != (n,) or (was >= len(old_sol.joints)).any():
                raise KinematicsError(
                    f"previous rows must be {n} row numbers below {len(old_sol.joints)} "
                    f"(or -1), got shape {np.shape(was)!r}")
            row = np.maximum(was, 0)
            canon[:, :4] = old_sol.joints[:, order[:4]][row]
            err = old_sol.axis_error_deg[row]
            fresh = np.flatnonzero((was < 0) | (old_sol.joints[row, order[4]] != c)
                                   | (old_sol.in_cone[row] != in_cone))
            t, err[fresh] = _tilts(kin, w[fresh], c[fresh])
            canon[fresh, 3] = t
            canon[fresh, :3] = _linear_joints(machine, q[fresh], t, c[fresh])
        canon[:, 4] = c
    joints = np.empty_like(canon)
    joints[:, _order(machine)] = canon
    return InverseSolution(joints=joints, in_cone=in_cone, axis_error_deg=err)


def linear_jacobian(machine: Machine, joints: ArrayLike) -> NDArray[np.float64]:
    """How the linear joints move with the tool tip at fixed rotary joints, ``dG/dq``.

    The inverse maps of the module's text are affine in the tip ``q`` for given rotary
    angles (which follow from the tool axis alone): ``G = M q + const`` with
    ``M = R_t(t) R_z(c)`` on a table-table machine, ``R_z(c)`` on a head-table one and the
    identity on a 3-axis one. Moving the part by ``d`` (workpiece frame) moves the linear
    joints of every pose by ``M d`` exactly.

    Parameters
    ----------
    machine : Machine
        The machine.
    joints : array_like, shape (n, n_axes)
        Joint values in the machine's axis order (only the rotary ones are read).

    Returns
    -------
    numpy.ndarray, shape (n, 3, 3)
        ``M`` per pose: rows X, Y, Z of the linear joints, columns x, y, z of the tip.
    """
    j, _ = _as_rows(joints, "joints", machine.n_axes)
    kin = machine.kinematics
    n = len(j)
    jac = np.empty((n, 3, 3))
    if kin is KinematicType.XYZ:
        jac[:] = np.eye(3)
        return jac
    canon = j[:, _order(machine)]
    turn_c = _cos_sin(canon[:, 4])
    turn_t = None if kin.tilting_head else _cos_sin(canon[:, 3])
    for k in range(3):
        column = _rot_cs(np.broadcast_to(np.eye(3)[k], (n, 3)), 2, *turn_c)
        jac[:, :, k] = column if turn_t is None else _rot_cs(column, _tilt_index(kin),
                                                              *turn_t)
    return jac


def inverse(
    machine: Machine,
    tips: ArrayLike,
    axes: ArrayLike,
    *,
    start: ArrayLike | None = None,
    cone_deg: float = SINGULAR_CONE_DEG,
    axis_tol_deg: float = XYZ_AXIS_TOL_DEG,
) -> NDArray[np.float64]:
    """Joint values along a path of tool-tip positions and tool axes.

    Parameters
    ----------
    machine : Machine
        The machine.
    tips : array_like, shape (n, 3) or (3,)
        Tool-tip positions in the workpiece frame, mm, in path order.
    axes : array_like, shape (n, 3) or (3,)
        Unit tool axes (tip toward spindle) in the workpiece frame.
    start : array_like, shape (n_axes,), optional
        Joint values the path continues from (see :func:`solve_inverse`).
    cone_deg : float, optional
        Half-angle of the singular cone, deg (default :data:`SINGULAR_CONE_DEG`).
    axis_tol_deg : float, optional
        3-axis machines: largest accepted angle from +Z, deg.

    Returns
    -------
    numpy.ndarray, shape (n, n_axes) or (n_axes,)
        Joint values in the machine's axis order: mm for linear axes, unwrapped deg for
        rotary axes. Not clipped to travel.

    Raises
    ------
    KinematicsError
        For wrong shapes, non-finite values or non-unit axes.
    UnreachableOrientationError
        For a tilted tool axis on a 3-axis machine.

    See Also
    --------
    solve_inverse : the same with the in-cone mask and achieved-axis error.
    forward : the inverse map.
    """
    single = np.ndim(tips) == 1
    sol = solve_inverse(
        machine, tips, axes, start=start, cone_deg=cone_deg, axis_tol_deg=axis_tol_deg
    )
    return sol.joints[0] if single else sol.joints


def controller_values(machine: Machine, joints: ArrayLike) -> NDArray[np.float64]:
    """Joint values as the controller should be sent them.

    Parameters
    ----------
    machine : Machine
        The machine.
    joints : array_like, shape (n, n_axes) or (n_axes,)
        Joint values from :func:`inverse` (mm, unwrapped deg).

    Returns
    -------
    numpy.ndarray
        A copy in which modulo-360 (``Wrap.SHORTEST``) rotary columns are mapped to
        [0, 360) deg; every other column is unchanged.
    """
    j = np.array(joints, dtype=float)
    if j.ndim not in (1, 2) or j.shape[-1] != machine.n_axes:
        raise KinematicsError(
            f"joints must have shape (n, {machine.n_axes}) or ({machine.n_axes},), got {j.shape!r}"
        )
    for i, ax in enumerate(machine.axes):
        j[..., i] = ax.controller_value(j[..., i])
    return j
