"""How a machine's joint values map to G-code axis words, and back.

A :class:`~machines.Machine` gives joint values in its own column order (``"XYZAC"``, ...):
linear joints in machine coordinates (mm), rotary joints in unwrapped degrees. G-code
carries program coordinates X Y Z A B C in the active work system. The convention the post,
the checker and the summary share (and the controller must be set up for):

* the work offset (G54) of the linear axes is ``machine.work_origin`` and of the rotary
  axes 0, so ``program = joint - work_origin`` for X, Y, Z;
* rotary words are the controller values of :func:`machines.controller_values`
  (``[0, 360)`` on a modulo-360 axis, unwrapped otherwise), never scaled by units.

Segments of :func:`gcode.interpreter.interpret` are in machine coordinates (program plus
work offset), X Y Z A B C; :func:`joint_columns` picks the machine's columns out of them.

Examples
--------
>>> import numpy as np
>>> from machines import load_machine
>>> m = load_machine("grbl-router")
>>> program_values(m, np.array([[-400.0, -300.0, -105.0]])).tolist()
[[0.0, 0.0, 5.0, nan, nan, nan]]
>>> work_offsets(m)[1]
(-400.0, -300.0, -110.0, 0.0, 0.0, 0.0)
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from gcode.program import AXES
from machines import Machine, controller_values

__all__ = [
    "joint_columns",
    "machine_axis_names",
    "program_values",
    "work_offset_vector",
    "work_offsets",
]


def machine_axis_names(machine: Machine) -> tuple[str, ...]:
    """IR field names of the machine's axes in its column order (``("x", "y", "z", "a", "c")``).

    Parameters
    ----------
    machine : Machine
        The machine.

    Returns
    -------
    tuple of str
        Lower-case axis letters, one per joint column.
    """
    return tuple(letter.lower() for letter in machine.letters)


def work_offset_vector(machine: Machine) -> npt.NDArray[np.float64]:
    """The work offset the programs assume, X Y Z A B C (mm, degrees).

    Parameters
    ----------
    machine : Machine
        The machine.

    Returns
    -------
    ndarray, shape (6,)
        ``machine.work_origin`` for X Y Z and 0 for A B C.
    """
    out = np.zeros(6)
    out[:3] = machine.work_origin
    return out


def work_offsets(machine: Machine) -> dict[int, tuple[float, ...]]:
    """Work offsets G54-G59 (all equal to :func:`work_offset_vector`), for the interpreter.

    Parameters
    ----------
    machine : Machine
        The machine.

    Returns
    -------
    dict of int to tuple of float
        Work system index 1-6 -> X Y Z A B C offset (mm, degrees).
    """
    vec = tuple(work_offset_vector(machine).tolist())
    return dict.fromkeys(range(1, 7), vec)


def program_values(machine: Machine, joints: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Program coordinates X Y Z A B C of joint values; NaN for axes the machine lacks.

    Parameters
    ----------
    machine : Machine
        The machine.
    joints : array_like, shape (n, n_axes)
        Joint values in the machine's column order (mm, unwrapped degrees).

    Returns
    -------
    ndarray, shape (n, 6)
        Linear axes minus the work offset (mm); rotary axes as the controller takes them
        (degrees).
    """
    j = np.atleast_2d(np.asarray(joints, dtype=np.float64))
    ctrl = controller_values(machine, j)
    out = np.full((j.shape[0], 6), np.nan)
    offset = work_offset_vector(machine)
    for col, name in enumerate(machine_axis_names(machine)):
        k = AXES.index(name)
        out[:, k] = ctrl[:, col] - offset[k]
    return out


def joint_columns(machine: Machine, positions: npt.ArrayLike) -> npt.NDArray[np.float64]:
    """Machine positions X Y Z A B C (as the interpreter gives them) in joint column order.

    Parameters
    ----------
    machine : Machine
        The machine.
    positions : array_like, shape (n, 6)
        Machine coordinates X Y Z A B C (mm, degrees), work offset included.

    Returns
    -------
    ndarray, shape (n, n_axes)
        The machine's columns, in its order.
    """
    p = np.atleast_2d(np.asarray(positions, dtype=np.float64))
    return p[:, [AXES.index(name) for name in machine_axis_names(machine)]]
