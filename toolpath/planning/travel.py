"""Where the part must sit for a path to stay inside a machine's travel.

A rigid shift ``d`` (mm, workpiece frame) of the part moves every tool tip by ``d`` and
keeps every tool axis, so the rotary joints do not change and the linear joints of point
``i`` move by ``J_i d``: for each machine family (:mod:`machines.kinematics`) the linear
joints are ``G_i = R_i q_i + g_i`` with ``R_i`` the rotation the rotary joints of point
``i`` apply to the workpiece (``R_t(t) R_z(c)`` for a trunnion, ``R_z(c)`` for a rotary
table under a swivel head, the identity on a 3-axis machine). ``J_i`` is read from the
inverse kinematics of the tips shifted by the unit vectors (exact: ``G`` is affine in
``q`` at fixed angles).

:func:`fit_travel` finds the shift by a linear program in ``(d, e)``::

    minimise  BIG e + |d|_1
    subject to lo_k + m - e <= G_ik + J_ik d <= hi_k - m + e   (every point i, linear axis k)
               d_z >= 0 when the part may only be raised (it stands on the table or a riser)
               e >= 0

``m`` is a margin for the G-code's rounding. ``e = 0`` at the optimum means the path fits
and ``d`` is the smallest shift that makes it fit (0 when it already does); otherwise ``e``
is the least overrun any shift leaves, and the axes still overrun at that shift are the
binding limits. The points are many (every cutter location and link), the constraints that
bind few: the program is solved on the points with the least slack and points that the
solution breaks are added until none is (constraint generation, exact).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Final

import numpy as np
import scipy.optimize
from numpy.typing import ArrayLike, NDArray

from machines import Machine
from machines.kinematics import InverseSolution, linear_jacobian, solve_inverse
from machines.limits import TRAVEL_TOLERANCE, Violation, check_travel

from ..errors import InvalidParameterError
from ..tolerances import LENGTH_SLACK_MM, NO_MEAN_AXIS

__all__ = ["TRAVEL_MARGIN_MM", "AxisRange", "TravelFit", "fit_travel", "with_split_middles"]

TRAVEL_MARGIN_MM: Final[float] = 0.01
"""Room kept inside each linear limit when the part is moved, mm: ten steps of the
G-code's 0.001 mm grid, so rounding the written joints cannot push one over."""

#: Weight of the overrun against the length of the shift (mm per mm).
_OVERRUN_WEIGHT = 1.0e4
#: Constraints per axis and side in the first round, and added per round.
_ROUND_ROWS = 256
_MAX_ROUNDS = 30
#: A horizontal shift below this (mm) prints as 0.000 at the report's 3 decimals: the
#: part is said to be raised or lowered only.
_PRINTS_ZERO_MM = 5e-4


@dataclass(frozen=True)
class AxisRange:
    """What one linear axis needs along the path (at the shift found) and what it has, mm."""

    letter: str
    needed_mm: tuple[float, float]
    travel_mm: tuple[float, float]

    @property
    def fits(self) -> bool:
        """The needed range lies within the travel (up to the limits' tolerance)."""
        return (self.needed_mm[0] >= self.travel_mm[0] - TRAVEL_TOLERANCE
                and self.needed_mm[1] <= self.travel_mm[1] + TRAVEL_TOLERANCE)

    def describe(self) -> str:
        """``axis 'Z' needs -830.2..-512.0 mm (318.2 mm), travel -800..0 mm (800 mm)``."""
        lo, hi = self.needed_mm
        tlo, thi = self.travel_mm
        return (f"axis {self.letter!r} needs {lo:.3f}..{hi:.3f} mm ({hi - lo:.3f} mm), "
                f"travel {tlo:g}..{thi:g} mm ({thi - tlo:g} mm)")


@dataclass(frozen=True)
class TravelFit:
    """Result of :func:`fit_travel`.

    Attributes
    ----------
    offset_mm : ndarray, shape (3,)
        The shift of the part (workpiece frame) found: the smallest that fits, or the one
        leaving the least overrun.
    fits : bool
        Every linear joint within travel after the shift, and every rotary one before it
        (a shift cannot change those).
    ranges : tuple of AxisRange
        Per limited linear axis, the joints' range after the shift against the travel.
    violations : tuple of Violation
        Travel violations left after the shift (rotary ones included); a middle of a move
        counts as the point the move arrives at.
    uniform : bool
        Every point's linear joints move by the same vector (a 3-axis machine, or a shift
        along the C axis of a rotary table under a swivel head): moves between the points
        keep their shape under the machine's joint interpolation.
    """

    offset_mm: NDArray[np.float64]
    fits: bool
    ranges: tuple[AxisRange, ...]
    violations: tuple[Violation, ...]
    uniform: bool = True

    @property
    def binding(self) -> tuple[AxisRange, ...]:
        """The linear axes still out of travel after the shift."""
        return tuple(r for r in self.ranges if not r.fits)

    def describe_offset(self) -> str:
        """``raised 25.000 mm`` / ``moved by (1.000, 0.000, 25.000) mm``."""
        d = self.offset_mm
        if abs(d[0]) < _PRINTS_ZERO_MM and abs(d[1]) < _PRINTS_ZERO_MM:
            return f"raised {d[2]:.3f} mm" if d[2] >= 0.0 else f"lowered {-d[2]:.3f} mm"
        return f"moved by ({d[0]:.3f}, {d[1]:.3f}, {d[2]:.3f}) mm"


def _linear_joints(machine: Machine, tips: NDArray[np.float64], axes: NDArray[np.float64],
                   previous: tuple[InverseSolution, NDArray[np.int64]] | None = None
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """All joints and the linear joints ``G`` (n, 3).

    ``previous``: the joints of the path's own points and each row's point there (-1: a
    middle), as :func:`~machines.kinematics.solve_inverse` takes them (the same joints,
    computed for the middles only).
    """
    joints = solve_inverse(machine, tips, axes, previous=previous).joints
    return joints, joints[:, [machine.index(letter) for letter in "XYZ"]]


def with_split_middles(tips: NDArray[np.float64], axes: NDArray[np.float64],
                       split: NDArray[np.bool_] | None
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """The poses with the middle poses of the moves ``split`` added, in path order.

    Returns the tips, the axes and the path point each row stands for (a middle: the point
    its move arrives at). The post splits 5-axis moves for joint interpolation at their
    middle (the tip's chord midpoint, the normalized mean of the ends' axes,
    :mod:`toolpath.joint_refine`): beyond 90 deg from +Z that axis lies further down than
    either end, and a swivel head's pivot lever turns that into Z below both ends.
    """
    n = len(tips)
    if split is None or n < 2:
        return tips, axes, np.arange(n)
    mean = axes[1:] + axes[:-1]
    size = np.linalg.norm(mean, axis=1)
    take = np.flatnonzero(np.asarray(split, dtype=bool) & (size > NO_MEAN_AXIS))
    mid_tips = 0.5 * (tips[take] + tips[take + 1])
    mid_axes = mean[take] / size[take, None]
    # in path order, each middle before the point its move arrives at
    order = np.argsort(np.r_[np.arange(n), take + 0.5], kind="stable")
    owner = np.r_[np.arange(n), take + 1][order]
    return np.vstack([tips, mid_tips])[order], np.vstack([axes, mid_axes])[order], owner


def fit_travel(machine: Machine, tips_mm: ArrayLike, axes: ArrayLike, *,
               raise_only: bool = True, lateral: bool = True,
               margin_mm: float = TRAVEL_MARGIN_MM,
               split_moves: ArrayLike | None = None,
               joints: InverseSolution | None = None) -> TravelFit:
    """The smallest shift of the part that keeps a path inside the linear travel.

    Parameters
    ----------
    machine : Machine
        The machine.
    tips_mm, axes : array_like, shape (n, 3)
        Tool tips (mm) and unit tool axes in the workpiece frame, in path order (every
        point of the path: cuts, links, rapids).
    raise_only : bool
        The part may move up (a riser under its fixture) but not down into the table.
    lateral : bool
        The part may move in X and Y too (else only along Z).
    margin_mm : float
        Room kept inside each limit (:data:`TRAVEL_MARGIN_MM`).
    split_moves : array_like of bool, shape (n - 1,), optional
        Moves the post splits for the machine's joint interpolation (every one but the
        rapids): their middle poses must fit too (:func:`with_split_middles`).
    joints : InverseSolution, optional
        ``solve_inverse(machine, tips_mm, axes)`` solved before (the joints a
        :class:`~toolpath.path.Toolpath` carries, :func:`~toolpath.joint_refine.known_joints`):
        on a 5-axis machine only the middles' joints are computed (the same result).

    Returns
    -------
    TravelFit
    """
    tips = np.asarray(tips_mm, dtype=float)
    w = np.asarray(axes, dtype=float)
    owner = np.arange(len(tips))
    previous = None
    if machine.kinematics.is_five_axis:
        n = len(tips)
        tips, w, owner = with_split_middles(tips, w, None if split_moves is None
                                       else np.asarray(split_moves, dtype=bool))
        if joints is not None:
            if len(joints.joints) != n:
                raise InvalidParameterError(
                    f"joints: {len(joints.joints)} rows solved for a path of {n} points")
            # a path point keeps its row; a middle (just before its owner) is new
            point = np.r_[owner[:-1] != owner[1:], True]
            previous = (joints, np.where(point, owner, -1))
    joints_all, g = _linear_joints(machine, tips, w, previous)
    letters = "XYZ"
    limits = [machine.axis(letter) for letter in letters]
    sides = []  # (k, sign, b) of sign J_k d - e <= b per limited axis k and side
    for k, ax in enumerate(limits):
        if not ax.is_limited:
            continue
        # upper: J d - e <= hi - m - g ; lower: -J d - e <= g - lo - m
        sides.append((k, 1.0, ax.max - margin_mm - g[:, k]))
        sides.append((k, -1.0, g[:, k] - ax.min - margin_mm))
    bounds = [(0.0, None)] * 7
    if not lateral:
        bounds[0] = bounds[1] = bounds[3] = bounds[4] = (0.0, 0.0)
    if raise_only:
        bounds[5] = (0.0, 0.0)  # d_z >= 0
    cost = np.r_[np.ones(6), _OVERRUN_WEIGHT]
    x = np.zeros(7)
    # every cost is positive: where no shift is needed (x = 0 keeps every row, b >= 0)
    # no other x is as cheap, and the rounds of linear programs are skipped
    rounds = 0 if all(bool((b >= 0.0).all()) for _, _, b in sides) else _MAX_ROUNDS
    active = [np.argsort(b)[:_ROUND_ROWS] for _, _, b in sides] if rounds else []
    # ``G`` is affine in the tips at the poses' rotary joints (which the axes alone set),
    # so its Jacobian ``J`` (n, 3, 3) in ``d`` is exact; needed only to move the part
    jac = linear_jacobian(machine, joints_all) if rounds else None
    blocks = [(sign * jac[:, k, :], b) for k, sign, b in sides] if jac is not None else []
    for _ in range(rounds):
        rows_a = [np.column_stack([a[idx], -a[idx], -np.ones(idx.size)])
                  for (a, _), idx in zip(blocks, active, strict=True)]
        rows_b = [b[idx] for (_, b), idx in zip(blocks, active, strict=True)]
        result = scipy.optimize.linprog(cost, A_ub=np.vstack(rows_a), b_ub=np.concatenate(rows_b),
                                        bounds=bounds, method="highs")
        x = result.x if result.status == 0 else np.zeros(7)
        d, e = x[:3] - x[3:6], x[6]
        grown = False
        for j, (a, b) in enumerate(blocks):
            slack = b - a @ d + e
            broken = np.flatnonzero(slack < -LENGTH_SLACK_MM)
            if broken.size:
                new = broken[np.argsort(slack[broken])[:_ROUND_ROWS]]
                merged = np.union1d(active[j], new)
                grown = grown or merged.size > active[j].size
                active[j] = merged
        if not grown:
            break
    d = x[:3] - x[3:6]
    d[np.abs(d) < LENGTH_SLACK_MM] = 0.0
    moved, shifted, uniform = g, joints_all, True
    if jac is not None and d.any():
        step = jac @ d
        moved = g + step
        shifted = joints_all.copy()
        shifted[:, [machine.index(letter) for letter in letters]] = moved
        uniform = float(np.ptp(step, axis=0).max()) < LENGTH_SLACK_MM
    violations = tuple(dataclasses.replace(v, index=int(owner[v.index]))
                       for v in check_travel(machine, shifted))
    ranges = tuple(AxisRange(letter, (float(moved[:, k].min()), float(moved[:, k].max())),
                             (ax.min, ax.max))
                   for k, (letter, ax) in enumerate(zip(letters, limits, strict=True))
                   if ax.is_limited and len(moved))
    return TravelFit(offset_mm=d, fits=not violations, ranges=ranges, violations=violations,
                     uniform=uniform)
