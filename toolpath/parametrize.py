"""Curve parameters: chord-length, centripetal and uniform, normalized to [0, 1]."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import InvalidParameterError

__all__ = ["PARAM_METHODS", "cumulative_parameters", "curve_parameters", "unit_curve_parameters"]

PARAM_METHODS = ("chord", "centripetal", "uniform")


def cumulative_parameters(points: NDArray[np.float64], params: str = "chord"
                          ) -> NDArray[np.float64]:
    """Accumulated parameter of ``points`` before normalization, from 0.

    ``"chord"``: ``Σ_{j<=i} |X_j − X_{j−1}|`` (mm); ``"centripetal"``: the same with the
    square root of each chord; ``"uniform"``: ``i``. :func:`curve_parameters` divides it
    by its last value.
    """
    if params == "uniform":
        return np.arange(points.shape[0], dtype=float)
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    if params == "centripetal":
        steps = np.sqrt(steps)
    return np.concatenate(([0.0], np.cumsum(steps)))


def curve_parameters(points: NDArray[np.float64], params: Any = "chord") -> NDArray[np.float64]:
    """Return one parameter value per point, increasing from 0 to 1.

    Parameters
    ----------
    points : ndarray, shape (n, d)
        Validated, ordered points (mm).
    params : {"chord", "centripetal", "uniform"} or array_like, shape (n,)
        ``"chord"``: accumulated chord length ``t_i = Σ_{j<=i} |X_j − X_{j−1}| / L`` (the
        paper's choice, Section 3); ``"centripetal"``: the same with the square root of each
        chord; ``"uniform"``: ``i / (n − 1)``. An array is used as given (it must be strictly
        increasing); it is not rescaled, so true ODE time can be passed to the
        constant-coefficient models.

    Raises
    ------
    InvalidParameterError
        For an unknown method, or an array of the wrong length or not strictly increasing.
    """
    n = points.shape[0]
    if isinstance(params, str):
        if params not in PARAM_METHODS:
            raise InvalidParameterError(
                f"params must be one of {PARAM_METHODS} or an array, got {params!r}"
            )
        if params == "uniform":
            return np.linspace(0.0, 1.0, n)
        t = cumulative_parameters(points, params)
        return t / t[-1]
    try:
        t = np.asarray(params, dtype=float)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"params must be numeric, got {params!r}") from None
    if t.shape != (n,):
        raise InvalidParameterError(
            f"params must have one value per point: shape ({n},), got {t.shape}"
        )
    if not np.isfinite(t).all():
        i = int(np.argmax(~np.isfinite(t)))
        raise InvalidParameterError(f"params[{i}] is not finite: {t[i]!r}")
    steps = np.diff(t)
    if (steps <= 0).any():
        i = int(np.argmax(steps <= 0))
        raise InvalidParameterError(
            f"params must increase strictly: params[{i}] = {t[i]!r} >= params[{i + 1}] = "
            f"{t[i + 1]!r}"
        )
    return t


def unit_curve_parameters(points: NDArray[np.float64], params: Any = "chord"
                          ) -> NDArray[np.float64]:
    """:func:`curve_parameters` mapped affinely onto [0, 1] (where spline fits live)."""
    t = curve_parameters(points, params)
    return (t - t[0]) / (t[-1] - t[0])
