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

from .bspline_curve import BSplineCurve, fit_bspline_curve
from .bspline_surface import BSplineSurface, fit_bspline_surface
from .errors import (
    ConvergenceWarning,
    DataFileError,
    FitError,
    InvalidParameterError,
    InvalidPointsError,
    ToolpathError,
)
from .linear_system import LINEAR_MODELS, LinearSystemCurve, fit_linear_system
from .path import MoveKind, Toolpath
from .planning import plan_finishing, plan_roughing
from .pointio import read_points, read_sections
from .sections import Sections, as_sections
from .streamline_curve import StreamlineCurve, fit_streamline_curve
from .streamline_surface import StreamlineSurface, fit_streamline_surface
from .surface import ParametricSurface

__all__ = [
    "LINEAR_MODELS",
    "BSplineCurve",
    "BSplineSurface",
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

_KINDS = {"streamline_curve": StreamlineCurve, "bspline_curve": BSplineCurve}


def curve_from_dict(data: dict[str, Any]) -> StreamlineCurve | BSplineCurve:
    """Rebuild a fitted spline curve from ``to_dict()`` output (e.g. a saved fit.json)."""
    kind = data.get("kind") if isinstance(data, dict) else None
    if kind not in _KINDS:
        raise InvalidParameterError(
            f"not a saved curve: kind must be one of {sorted(_KINDS)}, got {kind!r}")
    return _KINDS[kind].from_dict(data)


_SURFACE_KINDS = {"streamline_surface": StreamlineSurface, "bspline_surface": BSplineSurface}


def surface_from_dict(data: dict[str, Any]) -> StreamlineSurface | BSplineSurface:
    """Rebuild a fitted surface from ``to_dict()`` output (e.g. a saved blade.json).

    Raises
    ------
    InvalidParameterError
        Not a saved surface, or a surface saved in another format version.
    """
    from .fitted_surface import SURFACE_FORMAT_VERSION

    kind = data.get("kind") if isinstance(data, dict) else None
    if kind not in _SURFACE_KINDS:
        raise InvalidParameterError(
            f"not a saved surface: kind must be one of {sorted(_SURFACE_KINDS)}, got {kind!r}")
    version = data.get("format_version")
    if version != SURFACE_FORMAT_VERSION:
        raise InvalidParameterError(
            f"surface format version {version!r}; this program reads version "
            f"{SURFACE_FORMAT_VERSION} (refit the surface)")
    try:
        return _SURFACE_KINDS[kind].from_dict(data)
    except (KeyError, TypeError, ValueError) as exc:
        raise InvalidParameterError(f"the saved {kind} is incomplete or damaged: {exc!r}") from None
