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

Modules
-------
finishing
    ``plan_finishing``: probe, spacing, passes, chords, gouge, linking, machine, measure.
options
    ``FinishingOptions`` (the request) and ``PlannedOptions`` (what the plan works to).
defaults
    The request's defaults (feed, gouge tolerance) and the cutter-spec grammar, numpy-free.
cutters, cutter_kernel
    Ball, flat and bull-nose solids, tips from contacts, shadows; their compiled pieces.
analytic
    Plane, sphere, cylinder, pocket and elliptic blade surfaces for tests and demos.
setup
    A fitted surface rotated and placed onto the machine (``--rotate``, ``--on-table``).
local
    The pass frame and the damped Newton projection onto the surface.
scallop
    Stepover from the cusp height (ball circle, flat and bull true section); pass levels.
sampling
    Points along passes from the chord tolerance; cutter-surface gaps along moves.
open_edges
    A flat or bull-nose disc hanging past an open edge reads the edge, not its plane.
tool_axis
    Fixed and lead/tilt axes, smoothing, lean limits, the singular cone.
rate_limit
    The axis turn rate limited within the lean cone.
one_way
    A spiral's axes turned about +Z one way only.
passes
    Points, axes and tips along passes; chord refinement (``RefinedChords``); 3-axis reach.
gouge, clearance_kernel
    Surface samples; local and global (compiled) clearance of the cutter.
avoid
    Gouge depth measured round the contact; lift and retilt.
checks
    The gouge stage (``GougeStats``), link checks, the machine stage (``MachineStats``).
linking
    Runs, lead arcs, extensions, clearance plane or sphere, rapids and plunges.
travel
    The smallest shift of the part keeping the path inside the machine's travel.
resolution
    What the G-code's rounding can move the cutter by (the rounding reserve).
rotary_rate
    Rotary joint rates along the cut against the axes' limits.
blunt_edge
    An open blade's unfitted edge face, reported as left uncut.
chord_measure
    Chord error measured on the result: the cutter's contacts and gaps along the moves.
measure_joints
    A checked toolpath's joints, solved once for both measurements of a plan.
cut_volume
    The material the feed moves remove (``CutVolume``), cut in pieces, queried along rays.
sweep_kernel
    The cut volume's compiled ray entries (ball capsules, flat and bull-nose solids), a
    ball's centre pieces.
cusp_search
    Cusps ray cast from the chord measurement's seeds (``CuspSearch``, ``SearchSeeds``).
cusp_estimates
    Cusps estimated from the passes' own geometry (ball tubes, flat and bull-nose sections).
cusp_kernel
    Where two passes' ball tubes meet near a seed, how the centre path curves (compiled,
    for the estimate).
torus_profile
    Where two passes of a flat or bull-nose cutter meet across the passes.
torus_kernel
    The flat and bull-nose estimate's compiled parts: a pass's piece nearest a point over
    a window of them, where two sections' sides cross, the pose sections' bound.
uncut_area
    The area no cutter comes near, and distances over the surface to it.
measure
    Scallop measured on the result: estimates, ray casts, uncut area (``SeedCusps``).
roots
    The one Illinois regula falsi with a bisection fallback, row by row.
report
    ``PlanningReport``, unreachable spans and regions.
roughing
    Z-level contour-parallel roughing (shapely).
errors
    The planner's ``ToolpathError`` subclasses.
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
