"""Names of the fitting methods (standard library only).

The command line offers them as choices and its ``--help`` lists them without loading
numpy; the fitting modules check a request against the same tuples.
"""

from __future__ import annotations

__all__ = ["CURVE_METHODS", "LINEAR_MODELS", "SURFACE_METHODS"]

LINEAR_MODELS = ("P0", "P1-1", "P1-2", "P2")
"""The linear-system curve models of :func:`toolpath.fit_linear_system` (Section 2)."""

CURVE_METHODS = ("streamline", "bspline", *LINEAR_MODELS)
"""Curve fits: the streamline curve, the B-spline baseline, or a linear-system model."""

SURFACE_METHODS = ("streamline", "bspline")
"""Surface fits: the streamline surface or the bicubic B-spline baseline."""
