"""Fitting measured points with streamline curves of linear differential systems.

After Li et al., *Curve and surface fitting models based on the diagonalizable differential
systems*, J. Comput. Appl. Math. (2017).

Public index
------------
fit_linear_system
    ``dX/dt = A X`` by the P0, P1-1, P1-2 or P2 model (Section 2) -> ``LinearSystemCurve``.
fit_streamline_curve
    ``dX/dt = T^{-1} D(t) T (X + c)`` with adaptive knots (Algorithm 3) -> ``StreamlineCurve``.
fit_bspline_curve
    The cubic B-spline baseline with the same knot logic and interface -> ``BSplineCurve``.
curve_from_dict
    Rebuild any fitted curve from its ``to_dict()`` form.
fit_streamline_surface
    ``∂X/∂t = T^{-1} D(t, s) T (X + c)`` through blade sections (Algorithm 4)
    -> ``StreamlineSurface``.
fit_bspline_surface
    The bicubic tensor B-spline baseline, same knot logic -> ``BSplineSurface``.
surface_from_dict
    Rebuild a fitted surface from its ``to_dict()`` form.
ParametricSurface
    The surface interface planners read: points, partials, normals, curvatures, streamlines.
read_points, read_sections, as_sections
    Read points (``x,y[,z]``) or blade sections (``section,x,y,z``); validate sections.
Toolpath, MoveKind
    The planner's output: tool tips, tool axes, move kinds and feeds.
plan_finishing
    Streamline finishing (scallop, chord tolerance, 3/5-axis, gouge checks)
    -> ``(Toolpath, PlanningReport)``.
plan_roughing
    Z-level contour-parallel roughing of blade sections -> ``(Toolpath, RoughingReport)``.
ToolpathError
    Base of every error raised for bad input (also a ``ValueError``).
"""

from __future__ import annotations

from typing import Any

from .errors import (
    ClosureWarning,
    ConvergenceWarning,
    DataFileError,
    FitError,
    InvalidParameterError,
    InvalidPointsError,
    ToolpathError,
    UnfairFitWarning,
)
from .kernel_cache import ensure_kernel_cache
from .lazy import lazy_exports

ensure_kernel_cache()  # before any kernel module loads numba

#: Exported names -> defining module, imported on first use: ``import toolpath`` (and so
#: ``toolpath check`` or ``toolpath --help``) does not load scipy, numba or the planner.
_EXPORTS = {
    "BSplineCurve": ".bspline_curve",
    "fit_bspline_curve": ".bspline_curve",
    "BSplineSurface": ".bspline_surface",
    "fit_bspline_surface": ".bspline_surface",
    "LINEAR_MODELS": ".linear_system",
    "LinearSystemCurve": ".linear_system",
    "fit_linear_system": ".linear_system",
    "MoveKind": ".path",
    "Toolpath": ".path",
    "plan_finishing": ".planning",
    "plan_roughing": ".planning",
    "read_points": ".pointio",
    "read_sections": ".pointio",
    "Sections": ".sections",
    "as_sections": ".sections",
    "StreamlineCurve": ".streamline_curve",
    "fit_streamline_curve": ".streamline_curve",
    "StreamlineSurface": ".streamline_surface",
    "fit_streamline_surface": ".streamline_surface",
    "ParametricSurface": ".surface",
}

__all__ = [
    "LINEAR_MODELS",
    "BSplineCurve",
    "BSplineSurface",
    "ClosureWarning",
    "ConvergenceWarning",
    "DataFileError",
    "FitError",
    "InvalidParameterError",
    "InvalidPointsError",
    "LinearSystemCurve",
    "MoveKind",
    "ParametricSurface",
    "Sections",
    "StreamlineCurve",
    "StreamlineSurface",
    "Toolpath",
    "ToolpathError",
    "UnfairFitWarning",
    "as_sections",
    "curve_from_dict",
    "fit_bspline_curve",
    "fit_bspline_surface",
    "fit_linear_system",
    "fit_streamline_curve",
    "fit_streamline_surface",
    "plan_finishing",
    "plan_roughing",
    "read_points",
    "read_sections",
    "surface_from_dict",
]


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())


def _curve_kinds() -> dict[str, Any]:
    from .bspline_curve import BSplineCurve
    from .streamline_curve import StreamlineCurve

    return {"streamline_curve": StreamlineCurve, "bspline_curve": BSplineCurve}


def _surface_kinds() -> dict[str, Any]:
    from .bspline_surface import BSplineSurface
    from .streamline_surface import StreamlineSurface

    return {"streamline_surface": StreamlineSurface, "bspline_surface": BSplineSurface}


def curve_from_dict(data: dict[str, Any]) -> Any:
    """Rebuild a fitted spline curve from ``to_dict()`` output (e.g. a saved fit.json).

    Returns a ``StreamlineCurve`` or a ``BSplineCurve``.
    """
    kinds = _curve_kinds()
    kind = data.get("kind") if isinstance(data, dict) else None
    if kind not in kinds:
        raise InvalidParameterError(
            f"not a saved curve: kind must be one of {sorted(kinds)}, got {kind!r}")
    return kinds[kind].from_dict(data)


def surface_from_dict(data: dict[str, Any]) -> Any:
    """Rebuild a fitted surface from ``to_dict()`` output (e.g. a saved blade.json).

    Returns a ``StreamlineSurface`` or a ``BSplineSurface``.

    Raises
    ------
    InvalidParameterError
        Not a saved surface, or a surface saved in another format version.
    """
    from .fitted_surface import SURFACE_FORMAT_VERSION

    kinds = _surface_kinds()
    kind = data.get("kind") if isinstance(data, dict) else None
    if kind not in kinds:
        raise InvalidParameterError(
            f"not a saved surface: kind must be one of {sorted(kinds)}, got {kind!r}")
    version = data.get("format_version")
    if version != SURFACE_FORMAT_VERSION:
        raise InvalidParameterError(
            f"surface format version {version!r}; this program reads version "
            f"{SURFACE_FORMAT_VERSION} (refit the surface)")
    try:
        return kinds[kind].from_dict(data)
    except (KeyError, TypeError, ValueError) as exc:
        raise InvalidParameterError(f"the saved {kind} is incomplete or damaged: {exc!r}") from None
