"""Toolpath planning: streamline finishing and z-level roughing of blade surfaces.

Index
-----
plan_finishing
    Passes along ``s = const`` spaced by the scallop height, points by the chord tolerance,
    3-axis or 5-axis lead/tilt axes, gouge checks, linking -> ``(Toolpath, PlanningReport)``.
plan_roughing
    Contour-parallel z-level roughing of a blade from a stock outline (shapely), 3-axis.
Cutter, parse_cutter
    Ball, flat and bull-nose end mills (``"ball:6"``: the number is the diameter, mm).
FinishingOptions
    Every option with its documented default.
PlanningReport
    Scallop and chord error measured on the result, clearance, unreachable regions.
PlaneSurface, SpherePatch, CylinderPatch, PocketSurface, EllipticBladeSurface
    Analytic surfaces for tests and demos (:func:`analytic_surface_from_dict`).
GougeError, PlanningError, PlanTravelLimitError, UnreachableRegionError
    The planner's errors (``ToolpathError`` subclasses; the travel error is a
    ``MachineError``).

Modules: ``cutters``, ``analytic``, ``local`` (pass frame, projection), ``scallop``
(stepover), ``sampling`` (chord), ``tool_axis``, ``passes``, ``gouge``, ``avoid``,
``linking``, ``measure``, ``report``, ``options``, ``finishing``, ``roughing``.
"""

from __future__ import annotations

from ..lazy import lazy_exports
from .errors import GougeError, PlanningError, PlanTravelLimitError, UnreachableRegionError

#: Exported names -> defining module, imported on first use, so a command that reads one
#: option or constant does not compile or load the planner's kernels.
_EXPORTS = {
    "AnalyticSurface": ".analytic",
    "CylinderPatch": ".analytic",
    "EllipticBladeSurface": ".analytic",
    "PlaneSurface": ".analytic",
    "PocketSurface": ".analytic",
    "SpherePatch": ".analytic",
    "analytic_surface_from_dict": ".analytic",
    "Cutter": ".cutters",
    "CutterKind": ".cutters",
    "parse_cutter": ".cutters",
    "plan_finishing": ".finishing",
    "AxisMode": ".options",
    "FinishingOptions": ".options",
    "Linking": ".options",
    "OnGouge": ".options",
    "OnLimit": ".options",
    "PlanningReport": ".report",
    "UnreachableRegion": ".report",
    "UnreachableSpan": ".report",
    "RoughingReport": ".roughing",
    "plan_roughing": ".roughing",
}

__all__ = [
    "AnalyticSurface",
    "AxisMode",
    "Cutter",
    "CutterKind",
    "CylinderPatch",
    "EllipticBladeSurface",
    "FinishingOptions",
    "GougeError",
    "Linking",
    "OnGouge",
    "OnLimit",
    "PlanTravelLimitError",
    "PlaneSurface",
    "PlanningError",
    "PlanningReport",
    "PocketSurface",
    "RoughingReport",
    "SpherePatch",
    "UnreachableRegion",
    "UnreachableRegionError",
    "UnreachableSpan",
    "analytic_surface_from_dict",
    "parse_cutter",
    "plan_finishing",
    "plan_roughing",
]


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
