"""Machine definitions and kinematics (leaf package: imports nothing of ours).

Units everywhere: mm, mm/min, mm/s^2 for linear axes; deg, deg/min, deg/s^2 for rotary
axes (never scaled by 25.4); seconds for time.

Index
-----
units
    :data:`MM_PER_INCH`, :class:`Unit`, :func:`convert_length`, :func:`convert_feed`,
    :func:`convert_joints` (linear columns only).
axes
    :class:`Axis` (letter, kind, travel, max rate and acceleration, :class:`Wrap`),
    :class:`AxisKind`.
machine
    :class:`Machine`, :class:`KinematicType`, :func:`load_machine` (by name or path),
    :func:`list_machines`, :func:`machine_from_mapping`. Shipped definitions:
    ``grbl-router`` (3-axis, grbl), ``trunnion-ac`` (table-table A/C, linuxcnc),
    ``head-table-bc`` (B head, C table, linuxcnc).
kinematics
    :func:`inverse` / :func:`solve_inverse` (tip + tool axis in the workpiece frame ->
    joints, with branch choice, C unwrap and the singular cone), :func:`forward`,
    :func:`controller_values`, :data:`SINGULAR_CONE_DEG`.
limits
    :func:`check_travel`, :func:`check_rates`, :func:`min_segment_times` returning
    :class:`Violation` records; :func:`raise_for_violations`.
errors
    :class:`MachineError` and its subclasses.

Examples
--------
>>> import numpy as np
>>> import machines
>>> m = machines.load_machine("head-table-bc")
>>> j = machines.inverse(m, np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]))
>>> machines.check_travel(m, j)
[]
"""

from machines.axes import Axis, AxisKind, Wrap
from machines.errors import (
    KinematicsError,
    LimitError,
    MachineDefinitionError,
    MachineError,
    RateLimitError,
    TravelLimitError,
    UnknownAxisError,
    UnknownMachineError,
    UnreachableOrientationError,
)
from machines.kinematics import (
    SINGULAR_CONE_DEG,
    XYZ_AXIS_TOL_DEG,
    InverseSolution,
    controller_values,
    forward,
    inverse,
    solve_inverse,
)
from machines.limits import (
    Quantity,
    Side,
    Violation,
    check_rates,
    check_travel,
    min_segment_times,
    raise_for_violations,
)
from machines.machine import (
    KinematicType,
    Machine,
    list_machines,
    load_machine,
    machine_from_mapping,
)
from machines.units import (
    MM_PER_INCH,
    Unit,
    convert_feed,
    convert_joints,
    convert_length,
    from_mm,
    to_mm,
)

__all__ = [
    "MM_PER_INCH",
    "SINGULAR_CONE_DEG",
    "XYZ_AXIS_TOL_DEG",
    "Axis",
    "AxisKind",
    "InverseSolution",
    "KinematicType",
    "KinematicsError",
    "LimitError",
    "Machine",
    "MachineDefinitionError",
    "MachineError",
    "Quantity",
    "RateLimitError",
    "Side",
    "TravelLimitError",
    "UnknownAxisError",
    "UnknownMachineError",
    "UnreachableOrientationError",
    "Unit",
    "Violation",
    "Wrap",
    "check_rates",
    "check_travel",
    "controller_values",
    "convert_feed",
    "convert_joints",
    "convert_length",
    "forward",
    "from_mm",
    "inverse",
    "list_machines",
    "load_machine",
    "machine_from_mapping",
    "min_segment_times",
    "raise_for_violations",
    "solve_inverse",
    "to_mm",
]
