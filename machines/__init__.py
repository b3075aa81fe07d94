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
    :func:`machine_from_mapping`. Shipped definitions:
    ``grbl-router`` (3-axis, grbl), ``trunnion-ac`` (table-table A/C, linuxcnc),
    ``head-table-bc`` (B head, C table, linuxcnc).
catalog
    :func:`list_machines`: the shipped definitions by name (standard library only).
kinematics
    :func:`inverse` / :func:`solve_inverse` (tip + tool axis in the workpiece frame ->
    joints, with branch choice, C unwrap and the singular cone), :func:`forward`,
    :func:`controller_values`, :data:`SINGULAR_CONE_DEG`.
limits
    :func:`check_travel`, :func:`check_rates`, :func:`min_segment_times` returning
    :class:`Violation` records; :func:`raise_for_violations`.
errors
    :class:`MachineError` and its subclasses.

The names above load on first use (PEP 562), so ``import machines.errors`` or a command's
``--help`` does not load numpy.

Examples
--------
>>> import numpy as np
>>> import machines
>>> m = machines.load_machine("head-table-bc")
>>> j = machines.inverse(m, np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]))
>>> machines.check_travel(m, j)
[]
"""

from __future__ import annotations

import importlib
from typing import Any

from machines.catalog import list_machines

#: Exported names -> defining module, imported on first use (PEP 562): a command's
#: ``--help``, or ``import machines.errors``, does not load numpy and the kinematics.
#: (The other packages share :func:`toolpath.lazy.lazy_exports`; this leaf package imports
#: nothing of ours, so it keeps its own two functions below.)
_EXPORTS = {
    "Axis": "machines.axes",
    "AxisKind": "machines.axes",
    "Wrap": "machines.axes",
    "KinematicsError": "machines.errors",
    "LimitError": "machines.errors",
    "MachineDefinitionError": "machines.errors",
    "MachineError": "machines.errors",
    "RateLimitError": "machines.errors",
    "TravelLimitError": "machines.errors",
    "UnknownAxisError": "machines.errors",
    "UnknownMachineError": "machines.errors",
    "UnreachableOrientationError": "machines.errors",
    "SINGULAR_CONE_DEG": "machines.kinematics",
    "XYZ_AXIS_TOL_DEG": "machines.kinematics",
    "InverseSolution": "machines.kinematics",
    "controller_values": "machines.kinematics",
    "forward": "machines.kinematics",
    "inverse": "machines.kinematics",
    "solve_inverse": "machines.kinematics",
    "Quantity": "machines.limits",
    "Side": "machines.limits",
    "Violation": "machines.limits",
    "check_rates": "machines.limits",
    "check_travel": "machines.limits",
    "min_segment_times": "machines.limits",
    "raise_for_violations": "machines.limits",
    "KinematicType": "machines.machine",
    "Machine": "machines.machine",
    "load_machine": "machines.machine",
    "machine_from_mapping": "machines.machine",
    "MM_PER_INCH": "machines.units",
    "Unit": "machines.units",
    "convert_feed": "machines.units",
    "convert_joints": "machines.units",
    "convert_length": "machines.units",
    "from_mm": "machines.units",
    "to_mm": "machines.units",
}


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


#: The package's modules, reachable as attributes as when ``__init__`` imported them all.
_SUBMODULES = frozenset({"axes", "catalog", "errors", "kinematics", "limits", "machine",
                         "units"})


def __getattr__(name: str) -> Any:
    if name in _SUBMODULES:
        return importlib.import_module(f"{__name__}.{name}")
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(_EXPORTS[name]), name)
    globals()[name] = value  # the next read is a plain attribute
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS) | _SUBMODULES)
