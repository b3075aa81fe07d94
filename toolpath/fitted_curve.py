"""What every fitted cubic curve shares: parameters, knots, error figures, JSON form."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import InvalidParameterError
from .splinefit import n_coefficients

__all__ = ["FittedCurve", "check_order", "error_figures"]


def error_figures(errors: NDArray[np.float64]) -> tuple[float, float]:
    """Max and RMS of per-point distances (mm)."""
    return float(errors.max()), float(np.sqrt(np.mean(errors**2)))


def check_order(order: int) -> None:
    """Derivatives are offered to second order (what curvature and feeds need)."""
    if order not in (1, 2):
        raise InvalidParameterError(f"order must be 1 or 2, got {order!r}")


@dataclass(frozen=True, eq=False)
class FittedCurve:
    """Fields common to the streamline and B-spline curves.

    Attributes
    ----------
    knots : ndarray
        Clamped cubic knot vector on [0, 1].
    params : ndarray, shape (n,)
        Parameter of each data point (chord length in [0, 1] by default).
    max_error, rms_error : float
        Max and RMS distance (mm) from the data points to the curve at their parameters.
    """

    knots: NDArray[np.float64]
    params: NDArray[np.float64]
    max_error: float
    rms_error: float

    @property
    def n_control_points(self) -> int:
        """Control points per coordinate: ``len(knots) − 4``."""
        return n_coefficients(self.knots)

    def _common_dict(self) -> dict[str, Any]:
        return {
            "knots": self.knots.tolist(),
            "params": self.params.tolist(),
            "max_error": self.max_error,
            "rms_error": self.rms_error,
        }

    @staticmethod
    def _common_fields(data: dict[str, Any]) -> dict[str, Any]:
        return {
            "knots": np.asarray(data["knots"], float),
            "params": np.asarray(data["params"], float),
            "max_error": float(data["max_error"]),
            "rms_error": float(data["rms_error"]),
        }
