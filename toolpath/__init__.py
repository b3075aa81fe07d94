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
read_points
    Read points from CSV (header ``x,y[,z]``) or whitespace columns.
ToolpathError
    Base of every error raised for bad input (also a ``ValueError``).
"""

from __future__ import annotations

from typing import Any

from .bspline_curve import BSplineCurve, fit_bspline_curve
from .errors import (
    ConvergenceWarning,
    DataFileError,
    FitError,
    InvalidParameterError,
    InvalidPointsError,
    ToolpathError,
)
from .linear_system import LINEAR_MODELS, LinearSystemCurve, fit_linear_system
from .pointio import read_points
from .streamline_curve import StreamlineCurve, fit_streamline_curve

__all__ = [
    "LINEAR_MODELS",
    "BSplineCurve",
    "ConvergenceWarning",
    "DataFileError",
    "FitError",
    "InvalidParameterError",
    "InvalidPointsError",
    "LinearSystemCurve",
    "StreamlineCurve",
    "ToolpathError",
    "curve_from_dict",
    "fit_bspline_curve",
    "fit_linear_system",
    "fit_streamline_curve",
    "read_points",
]

_KINDS = {"streamline_curve": StreamlineCurve, "bspline_curve": BSplineCurve}


def curve_from_dict(data: dict[str, Any]) -> StreamlineCurve | BSplineCurve:
    """Rebuild a fitted spline curve from ``to_dict()`` output (e.g. a saved fit.json)."""
    kind = data.get("kind") if isinstance(data, dict) else None
    if kind not in _KINDS:
        raise InvalidParameterError(
            f"not a saved curve: kind must be one of {sorted(_KINDS)}, got {kind!r}")
    return _KINDS[kind].from_dict(data)
