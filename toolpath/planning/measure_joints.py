"""A toolpath's joints, solved once for the chord and the scallop measurement of one plan."""

from __future__ import annotations

import weakref

import numpy as np
from numpy.typing import NDArray

from machines import Machine
from machines.kinematics import solve_inverse

from ..joint_refine import joints_checked, known_joints, machine_key
from ..path import Toolpath

__all__ = ["checked_joints"]


#: The last toolpath's checked joints (a weak reference to it, the machine key, the
#: joints): the chord and the scallop measurement of one plan solve them once.
_JOINTS_SOLVED: list[tuple[weakref.ref[Toolpath], str, NDArray[np.float64]]] = []


def checked_joints(toolpath: Toolpath, machine: Machine | None
                   ) -> NDArray[np.float64] | None:
    """Joints of every point if ``toolpath`` was checked under ``machine``'s interpolation.

    (``Toolpath.joints_checked_for``: the post then leaves its cutting moves whole).
    None otherwise. Those ``toolpath`` carries (:attr:`Toolpath.solved_joints`, the plan's
    machine stage solved them), else solved here once for the chord and the scallop
    measurement.
    """
    if machine is None or not joints_checked(toolpath, machine):
        return None
    known = known_joints(toolpath, machine)
    if known is not None:
        return known.joints
    key = machine_key(machine)
    for ref, known, joints in _JOINTS_SOLVED:
        if ref() is toolpath and known == key:
            return joints
    joints = solve_inverse(machine, toolpath.positions_mm, toolpath.tool_axes).joints
    _JOINTS_SOLVED[:] = [(weakref.ref(toolpath), key, joints)]
    return joints
