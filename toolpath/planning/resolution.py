"""How far the G-code's number grid can move the cutter: the planner's reserve for it.

The post writes every joint rounded to the dialect's grid (0.001 mm and 0.001 deg by
default), so the machine's cutter stands up to half a step off the planned one in every
joint. For the linear axes that is at most ``sqrt(3) / 2`` of the coordinate step. A rotary
joint off by ``delta`` turns the tip about its axis, by ``delta`` (rad) times the tip's
distance from that axis: on a table-table machine with the part 100 mm from the C axis,
half of 0.001 deg moves it by 0.00087 mm, as much as the three linear axes together.
Rotary displacements are found through the machine's forward kinematics at sample poses
(each rotary joint moved by half a step, both ways) and added for the worst case.

The planner plans for the request minus this reserve (at most :data:`MAX_RESERVE_SHARE`
of it), so that the program as written keeps the request.
"""

from __future__ import annotations

import math
from typing import Final

import numpy as np
from numpy.typing import NDArray

from machines import Machine
from machines.axes import AxisKind
from machines.kinematics import forward, solve_inverse

from .defaults import GOUGE_TOL_MM

__all__ = ["GOUGE_TOL_MM", "MAX_RESERVE_SHARE", "rounding_reserve_mm"]

#: The reserve never takes more than this share of a tolerance; where the grid would need
#: more, the request is finer than the machine's resolution can honour (reported).
MAX_RESERVE_SHARE: Final[float] = 0.25


def rounding_reserve_mm(tips_mm: NDArray[np.float64], axes: NDArray[np.float64],
                        machine: Machine | None, *, coordinate_step_mm: float,
                        angle_step_deg: float) -> float:
    """Largest tip displacement the written grid can cause at these poses, mm.

    Parameters
    ----------
    tips_mm, axes : ndarray, shape (n, 3)
        Sample cutter poses in the workpiece frame (tip, unit axis).
    machine : Machine or None
        With a 5-axis machine, its rotary joints' share is added (none without one:
        a toolpath posted to an unknown machine is judged on its linear grid only).
    coordinate_step_mm, angle_step_deg : float
        The grid of linear (mm) and rotary (deg) words.
    """
    linear = 0.5 * math.sqrt(3.0) * coordinate_step_mm
    if machine is None or not machine.kinematics.is_five_axis or not len(tips_mm):
        return linear
    joints = solve_inverse(machine, tips_mm, axes).joints
    base, _ = forward(machine, joints)
    rotary = 0.0
    for k, axis in enumerate(machine.axes):
        if axis.kind is AxisKind.LINEAR:
            continue
        worst = 0.0
        for sign in (-1.0, 1.0):
            moved = joints.copy()
            moved[:, k] += sign * 0.5 * angle_step_deg
            tips, _ = forward(machine, moved)
            worst = max(worst, float(np.linalg.norm(tips - base, axis=1).max()))
        rotary += worst
    return linear + rotary
