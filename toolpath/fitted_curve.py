"""What every fitted cubic curve shares: parameters, knots, error figures, JSON form."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .arrays import MIN_CURVE_POINTS, as_curve_points
from .closure import close_loop, read_seam
from .errors import InvalidParameterError, InvalidPointsError
from .parametrize import unit_curve_parameters
from .periodic import free_coefficients

__all__ = ["FittedCurve", "check_order", "curve_data", "error_figures"]


def error_figures(errors: NDArray[np.float64]) -> tuple[float, float]:
    """Max and RMS of per-point distances (mm)."""
    return float(errors.max()), float(np.sqrt(np.mean(errors**2)))


def curve_data(points: Any, params: Any, closed: bool | None
               ) -> tuple[NDArray[np.float64], NDArray[np.float64], bool]:
    """Validated points, their parameters in [0, 1] and whether the curve is closed.

    ``closed=None`` reads the seam (:func:`toolpath.closure.read_seam`). A closed curve's
    points come back with the first one repeated at the end (``t = 1``, the seam), so
    ``params`` given as an array then has one value per point and one for the return.
    """
    x = as_curve_points(points)
    is_closed = read_seam(x).closed if closed is None else bool(closed)
    if is_closed:
        x = close_loop(x)
        if len(x) - 1 < MIN_CURVE_POINTS:
            raise InvalidPointsError(
                f"a closed curve needs at least {MIN_CURVE_POINTS} distinct points, got "
                f"{len(x) - 1}")
    return x, unit_curve_parameters(x, params), is_closed


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
        Clamped cubic knot vector on [0, 1]; for a closed curve the extended periodic
        vector of :mod:`toolpath.periodic` (base interval [0, 1], ``X(0) = X(1)``).
    params : ndarray, shape (n,)
        Parameter of each data point (chord length in [0, 1] by default).
    max_error, rms_error : float
        Max and RMS distance (mm) from the data points to the curve at their parameters.
    closed : bool
        A closed curve: periodic on [0, 1), position, tangent and curvature continuous
        across the seam ``t = 0 ≡ 1`` (C0 only where the data have a corner there).
    """

    knots: NDArray[np.float64]
    params: NDArray[np.float64]
    max_error: float
    rms_error: float
    closed: bool = field(default=False, kw_only=True)

    @property
    def n_control_points(self) -> int:
        """Control points per coordinate: ``len(knots) − 4`` (free ones when periodic)."""
        return free_coefficients(self.knots)

    def _common_dict(self) -> dict[str, Any]:
        return {
            "knots": self.knots.tolist(),
            "params": self.params.tolist(),
            "max_error": self.max_error,
            "rms_error": self.rms_error,
            "closed": self.closed,
        }

    @staticmethod
    def _common_fields(data: dict[str, Any]) -> dict[str, Any]:
        return {
            "knots": np.asarray(data["knots"], float),
            "params": np.asarray(data["params"], float),
            "max_error": float(data["max_error"]),
            "rms_error": float(data["rms_error"]),
            "closed": bool(data.get("closed", False)),
        }
