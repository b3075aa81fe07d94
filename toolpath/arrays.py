"""Validation of user arrays, done first so no error surfaces from deep inside numpy."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import InvalidParameterError, InvalidPointsError
from .tolerances import ROUND_OFF

__all__ = ["MIN_CURVE_POINTS", "as_curve_points", "as_positive_length"]

#: A cubic needs four points to be determined; fewer cannot be fitted.
MIN_CURVE_POINTS = 4
#: A step longer than this many times all the other steps together is a jump to an outlier.
OUTLIER_RATIO = 10.0
#: Most steps examined as jumps: out to a bad point and back, twice.
MAX_JUMPS = 4


def as_curve_points(points: Any, *, min_points: int = MIN_CURVE_POINTS) -> NDArray[np.float64]:
    """Return ordered curve points as a float ``(n, d)`` array, ``d`` in {2, 3}, or raise.

    Checks, in order: numeric, 2-D with 2 or 3 columns, at least ``min_points`` rows, all
    finite, no two consecutive points equal, non-zero length, no far outlier (a step longer
    than :data:`OUTLIER_RATIO` times all the other steps together).

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
    dup = steps <= ROUND_OFF * scale
    if dup.all():
        raise InvalidPointsError("the curve has zero length: all points coincide", index=0)
    if dup.any():
        i = int(np.argmax(dup))
        raise InvalidPointsError(
            f"points {i} and {i + 1} are the same point {tuple(arr[i].tolist())!r}; "
            "remove consecutive duplicates",
            index=i + 1,
        )
    _check_jumps(steps)
    return arr


def _check_jumps(steps: NDArray[np.float64]) -> None:
    """Refuse a curve with a far outlier (a jump: a step much longer than all the rest).

    A jump is one of at most :data:`MAX_JUMPS` steps that each exceed
    :data:`OUTLIER_RATIO` times the length of all the other steps together. A spike out to
    a bad point and back makes two such steps around it, a bad end point one; on a sampled
    contour no step is near ten times the rest of it, however unevenly it is sampled (on the
    development blades, 0.01 mm noses beside 8 mm flanks, the longest step is at most 0.03
    times the rest). Such a point is not a shape to fit: the fit
    would bend far out of its way or take seconds failing to.
    """
    if steps.size < 3:
        return
    order = np.argsort(steps)[::-1]
    sorted_steps = steps[order]
    rest = np.cumsum(sorted_steps[::-1])[::-1]  # rest[k] = sum of sorted_steps[k:]
    for k in range(1, min(MAX_JUMPS, steps.size - 1) + 1):
        if sorted_steps[k - 1] > OUTLIER_RATIO * rest[k]:
            jumps = np.sort(order[:k])
            _raise_jump(steps, jumps, float(rest[k]))


def _raise_jump(steps: NDArray[np.float64], jumps: NDArray[np.int64], rest: float) -> None:
    n = steps.size + 1
    if jumps.size >= 2:
        first, last = int(jumps[0]) + 1, int(jumps[1])
        which = f"point {first}" if first == last else f"points {first} to {last}"
    elif jumps[0] == 0 or jumps[0] == n - 2:
        first = 0 if jumps[0] == 0 else n - 1
        which = f"point {first}"
    else:
        first = int(jumps[0]) + 1
        raise InvalidPointsError(
            f"the curve jumps {steps[jumps[0]]:.6g} mm between points {first - 1} and {first} "
            f"while all its other steps add up to {rest:.6g} mm: two curves in one input, or "
            "a measuring error?", index=first)
    far = ", ".join(f"{steps[j]:.6g}" for j in jumps)
    raise InvalidPointsError(
        f"{which} lies far off the curve (steps of {far} mm to it, while all the other "
        f"steps add up to {rest:.6g} mm): a measuring error? remove or correct it",
        index=first)


def as_positive_length(value: Any, *, name: str) -> float:
    """Return ``value`` as a finite float > 0 (a tolerance in mm), or raise naming it."""
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name} must be a number in mm, got {value!r}") from None
    if not math.isfinite(out) or out <= 0.0:
        raise InvalidParameterError(f"{name} must be a finite length > 0 mm, got {value!r}")
    return out
