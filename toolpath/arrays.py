"""Validation of user arrays, done first so no error surfaces from deep inside numpy."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import InvalidParameterError, InvalidPointsError

__all__ = ["MIN_CURVE_POINTS", "as_curve_points", "as_positive_length"]

#: A cubic needs four points to be determined; fewer cannot be fitted.
MIN_CURVE_POINTS = 4


def as_curve_points(points: Any, *, min_points: int = MIN_CURVE_POINTS) -> NDArray[np.float64]:
    """Return ordered curve points as a float ``(n, d)`` array, ``d`` in {2, 3}, or raise.

    Checks, in order: numeric, 2-D with 2 or 3 columns, at least ``min_points`` rows, all
    finite, no two consecutive points equal, non-zero length.

    Raises
    ------
    InvalidPointsError
        Naming the problem and, where there is one, the first offending point index.
    """
    try:
        arr = np.asarray(points, dtype=float)
    except (TypeError, ValueError) as exc:
        raise InvalidPointsError(
            f"points must be numeric, got {type(points).__name__}: {exc}") from None
    if arr.ndim != 2 or arr.shape[1] not in (2, 3):
        raise InvalidPointsError(
            f"points must have shape (n, 2) or (n, 3), got shape {arr.shape}"
        )
    n = arr.shape[0]
    if n < min_points:
        raise InvalidPointsError(
            f"a cubic fit needs at least {min_points} points, got {n}"
        )
    bad = ~np.isfinite(arr).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise InvalidPointsError(
            f"point {i} is not finite: {tuple(arr[i].tolist())!r}", index=i
        )
    steps = np.linalg.norm(np.diff(arr, axis=0), axis=1)
    scale = float(np.max(np.abs(arr))) or 1.0
    dup = steps <= 1e-12 * scale
    if dup.all():
        raise InvalidPointsError("the curve has zero length: all points coincide", index=0)
    if dup.any():
        i = int(np.argmax(dup))
        raise InvalidPointsError(
            f"points {i} and {i + 1} are the same point {tuple(arr[i].tolist())!r}; "
            "remove consecutive duplicates",
            index=i + 1,
        )
    return arr


def as_positive_length(value: Any, *, name: str) -> float:
    """Return ``value`` as a finite float > 0 (a tolerance in mm), or raise naming it."""
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name} must be a number in mm, got {value!r}") from None
    if not math.isfinite(out) or out <= 0.0:
        raise InvalidParameterError(f"{name} must be a finite length > 0 mm, got {value!r}")
    return out
