"""Choosing the knots of a curve fit: one driver for every method (Algorithm 3, steps 3-6).

A method is reduced to ``fit_at(knots) -> (fit, errors)``: the fit on a given knot vector
and the distance (mm) of each data point from it. The driver then

- fits a given knot vector (``knots=``), or
- places knots by **density** (corners at full multiplicity, ``|f''''|^{1/4}`` from a seed
  fit of ``seed_values``, then error-equidistribution sweeps), or by the paper's
  **dominant points**, and
- for a tolerance, searches the fewest control points whose fit has ``max_error <= tol``
  (exponential then binary search over the number of free knots).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import numpy as np
from numpy.typing import NDArray

from .arrays import as_positive_length
from .errors import FitError, InvalidParameterError
from .knots import (
    Corner,
    detect_corners,
    dominant_point_knots,
    error_density,
    initial_dominant_points,
    place_knots,
    refine_dominant_points,
    third_derivative_density,
)
from .splinefit import DEGREE, end_interpolating_lsq, n_coefficients, schoenberg_whitney_violation

__all__ = ["KNOT_METHODS", "KnotOptions", "adapt_knots", "check_given_knots", "knot_options"]

KNOT_METHODS = ("density", "dominant")
#: Error-equidistribution sweeps per knot count; the tolerance search carries the learned
#: density from one count to the next, so later counts start near the optimum.
DEFAULT_SWEEPS = 12
#: Turning angle (deg) from which a sharp turn may be a corner (Ex 5's corner is 20°).
DEFAULT_CORNER_ANGLE_DEG = 8.0

#: Sweeps stop once this many in a row lowered the max error by less than SWEEP_GAIN.
SWEEP_PATIENCE = 3
SWEEP_GAIN = 0.01

FitT = TypeVar("FitT")
FitAt = Callable[[NDArray[np.float64], NDArray[np.float64] | None],
                 tuple[FitT, NDArray[np.float64]]]
#: Lawson iterations of the minimax polish; the max error settles within about ten.
MINIMAX_STEPS = 12
#: The minimax polish lowers the least-squares max error by well under this factor
#: (measured: 15-35% on the paper's examples), so attempts further from tol skip it.
POLISH_REACH = 1.6
#: Least weight (relative to the mean, 1) of a point in the minimax polish; small enough
#: not to slow the polish (the max error is the same to 3 digits on the paper's examples),
#: large enough to keep the weighted normal equations well conditioned.
WEIGHT_FLOOR = 1e-3


@dataclass(frozen=True)
class KnotOptions:
    """What decides the knots: exactly one of ``tol``, ``n_control_points``, ``knots``."""

    tol: float | None
    n_control_points: int | None
    max_control_points: int | None
    knots: NDArray[np.float64] | None
    method: str
    corner_angle_deg: float | None
    sweeps: int
    minimax: bool
    #: Knots of a related fit for the same request (e.g. the B-spline probe of a streamline
    #: fit): the search starts at their count and density instead of from scratch.
    start_knots: NDArray[np.float64] | None = None


def knot_options(*, tol: Any, n_control_points: Any, max_control_points: Any, knots: Any,
                 knot_method: str, corner_angle_deg: Any, sweeps: int, minimax: bool
                 ) -> KnotOptions:
    """Validate the knot options shared by the curve fitters."""
    given = [name for name, v in (("tol", tol), ("n_control_points", n_control_points),
                                  ("knots", knots)) if v is not None]
    if len(given) != 1:
        raise InvalidParameterError(
            "give exactly one of tol, n_control_points or knots; got "
            + (", ".join(given) if given else "none")
        )
    if knot_method not in KNOT_METHODS:
        raise InvalidParameterError(
            f"knot_method must be one of {KNOT_METHODS}, got {knot_method!r}")
    tol_mm = None if tol is None else as_positive_length(tol, name="tol")
    for name, value in (("n_control_points", n_control_points),
                        ("max_control_points", max_control_points)):
        if value is not None and (not isinstance(value, int | np.integer)
                                  or value < DEGREE + 1):
            raise InvalidParameterError(
                f"{name} must be an integer >= {DEGREE + 1}, got {value!r}")
    knot_array = None
    if knots is not None:
        try:
            knot_array = np.asarray(knots, dtype=float)
        except (TypeError, ValueError):
            raise InvalidParameterError(f"knots must be numeric, got {knots!r}") from None
        if knot_array.ndim != 1 or not np.isfinite(knot_array).all():
            raise InvalidParameterError("knots must be a 1-D array of finite values")
    if corner_angle_deg is not None:
        corner_angle_deg = float(corner_angle_deg)
    if not isinstance(sweeps, int) or sweeps < 0:
        raise InvalidParameterError(f"sweeps must be an integer >= 0, got {sweeps!r}")
    return KnotOptions(tol_mm, n_control_points, max_control_points, knot_array, knot_method,
                       corner_angle_deg, sweeps, bool(minimax))


@dataclass
class _Trial(Generic[FitT]):
    fit: FitT
    errors: NDArray[np.float64]
    knots: NDArray[np.float64]
    #: Why the method could not fit these knots (the errors are then infinite).
    failure: FitError | None = None

    @property
    def max_error(self) -> float:
        return float(self.errors.max())


def _try(fit_at: FitAt, knots: NDArray[np.float64], weights: NDArray[np.float64] | None,
         n_points: int) -> _Trial:
    """``fit_at`` on ``knots`` as a trial, or as a failure a search moves past.

    A fit the method refuses (:class:`FitError`), or one that is not finite, is a trial of
    infinite error carrying the reason.
    """
    try:
        fit, errors = fit_at(knots, weights)
    except FitError as exc:
        return _Trial(None, np.full(n_points, np.inf), knots, exc)
    errors = np.asarray(errors, dtype=float)
    if not np.isfinite(errors).all():
        failure = FitError(f"the fit on {n_coefficients(knots)} control points is not "
                           "finite at every data point")
        return _Trial(fit, np.full(errors.shape, np.inf), knots, failure)
    return _Trial(fit, errors, knots)


def _checked(trial: _Trial) -> _Trial:
    """The trial if it is a fit, else its failure raised."""
    if trial.failure is not None:
        raise trial.failure
    return trial


def _polish(trial: _Trial, fit_at: FitAt, options: KnotOptions) -> _Trial:
    """Lower the max error on fixed knots by Lawson's iteratively reweighted least squares.

    ``w_i ← w_i e_i / Σ_j w_j e_j`` drives the weighted least-squares solution towards the
    minimax one (Lawson 1961); the best iterate is kept, so the max error never rises.
    Weights are kept above :data:`WEIGHT_FLOOR` times their mean: points the fit already
    meets (the interpolated ends have ``e = 0``) would otherwise reach weight 0, leave a
    basis function with no weighted data and make the normal equations singular (on the
    half profile that gave control points of 1e6 and ``exp`` overflow).
    """
    if not options.minimax or trial.failure is not None:
        return trial
    best = trial
    weights = np.ones_like(trial.errors)
    errors = trial.errors
    for _ in range(MINIMAX_STEPS):
        weights = weights * errors
        total = weights.sum()
        if not np.isfinite(total) or total <= 0:
            break
        weights = weights / total * weights.size
        weights = np.maximum(weights, WEIGHT_FLOOR)
        current = _try(fit_at, trial.knots, weights, errors.size)
        if current.failure is not None:
            break
        errors = current.errors
        if current.max_error < best.max_error:
            best = current
    return best


def _seed_density(t: NDArray[np.float64], values: NDArray[np.float64], corners: list[Corner]):
    """Density ``|f''''|^{1/4}`` from a preliminary fit on evenly spread knots."""
    n_free = int(np.clip(t.size // 6, 4, 120))
    flat = (np.array([0.0, 1.0]), np.ones(1))
    knots = place_knots(t, corners, *flat, n_free)
    spline = end_interpolating_lsq(t, values, knots)
    return third_derivative_density(spline.t, spline.c)


def check_given_knots(t: NDArray[np.float64], knots: NDArray[np.float64]) -> None:
    """Raise :class:`InvalidParameterError` naming why ``knots`` cannot fit data at ``t``."""
    problem = schoenberg_whitney_violation(t, knots)
    if problem is not None:
        raise InvalidParameterError(f"knots cannot be fitted: {problem}")


def adapt_knots(points: NDArray[np.float64], t: NDArray[np.float64],
                seed_values: NDArray[np.float64], fit_at: FitAt, options: KnotOptions
                ) -> tuple[FitT, NDArray[np.float64], NDArray[np.float64]]:
    """Run a method with the knots the options ask for.

    Returns
    -------
    fit, errors, knots
        The chosen fit, its per-point error (mm) and its knot vector.

    Raises
    ------
    FitError
        When ``tol`` cannot be reached within ``max_control_points`` (or the data's count).
    """
    if options.knots is not None:
        check_given_knots(t, options.knots)
        trial = _checked(_try(fit_at, options.knots, None, t.size))
        trial = _polish(trial, fit_at, options)
        return trial.fit, trial.errors, trial.knots
    if options.method == "dominant":
        trial = _dominant(points, t, fit_at, options)
    else:
        trial = _density(points, t, seed_values, fit_at, options)
    trial = _checked(trial)
    return trial.fit, trial.errors, trial.knots


def _limit(options: KnotOptions, n_points: int) -> int:
    limit = n_points
    if options.max_control_points is not None:
        limit = min(limit, options.max_control_points)
    return limit


def _density(points, t, seed_values, fit_at, options: KnotOptions) -> _Trial:
    corners = ([] if options.corner_angle_deg is None
               else detect_corners(points, t, min_angle_deg=options.corner_angle_deg))
    fixed = DEGREE + 1 + DEGREE * len(corners)
    if options.start_knots is not None and options.tol is not None:
        edges = np.unique(options.start_knots)
        density = 1.0 / np.maximum(np.diff(edges), 1e-12)
    else:
        edges, density = _seed_density(t, seed_values, corners)
    learned = [(edges, density)]  # the density the latest attempt ended with

    def attempt(n_free: int) -> _Trial:
        """Fit with ``n_free`` free knots: seed from the latest density, then sweeps."""
        knots = place_knots(t, corners, *learned[-1], n_free)
        best = current = _try(fit_at, knots, None, t.size)
        stale = 0
        for _ in range(options.sweeps):
            if current.failure is not None:
                break  # no error density to learn from
            learned.append(error_density(current.knots, t, current.errors))
            knots = place_knots(t, corners, *learned[-1], n_free)
            current = _try(fit_at, knots, None, t.size)
            if current.max_error < best.max_error * (1.0 - SWEEP_GAIN):
                best, stale = current, 0
            else:
                if current.max_error < best.max_error:
                    best = current
                stale += 1
                if stale >= SWEEP_PATIENCE:
                    break  # the density has settled
        if options.tol is not None and best.max_error > POLISH_REACH * options.tol:
            return best  # the polish cannot bring this count within tol: skip its cost
        return _polish(best, fit_at, options)

    limit = _limit(options, t.size)
    if options.n_control_points is not None:
        return attempt(max(options.n_control_points - fixed, 0))
    tol = options.tol
    assert tol is not None
    if options.start_knots is not None:
        start = int(np.clip(n_coefficients(options.start_knots) - fixed, 0, limit - fixed))
        return _search_near(attempt, start, tol, limit - fixed)
    # exponential search for a passing count, then bisection for the fewest
    lo, n_free, best_fail = -1, 1, None
    passing: _Trial | None = None
    while True:
        if n_free + fixed > limit:
            n_free = limit - fixed
        trial = attempt(max(n_free, 0))
        if trial.max_error <= tol:
            passing, hi = trial, n_free
            break
        best_fail = trial if best_fail is None or trial.max_error < best_fail.max_error \
            else best_fail
        lo = n_free
        if n_free + fixed >= limit:
            _raise_not_reached(tol, best_fail)
        n_free *= 2
    return _bisect(attempt, lo, hi, passing, tol)


def _raise_not_reached(tol: float, best_fail: _Trial) -> None:
    _checked(best_fail)
    raise FitError(
        f"tol={tol!r} mm not reached with {n_coefficients(best_fail.knots)} control "
        f"points (best max error {best_fail.max_error:.6g} mm); raise "
        "max_control_points or tol"
    )


def _bisect(attempt, lo: int, hi: int, passing: _Trial, tol: float) -> _Trial:
    """Fewest free knots in ``(lo, hi]`` passing ``tol`` (``lo`` fails, ``hi`` passes)."""
    while hi - lo > 1:
        mid = (lo + hi) // 2
        trial = attempt(mid)
        if trial.max_error <= tol:
            passing, hi = trial, mid
        else:
            lo = mid
    return passing


def _search_near(attempt, start: int, tol: float, most: int) -> _Trial:
    """The fewest free knots passing ``tol``, searched outward from ``start``.

    Down one at a time while passing (a related fit's count is usually within one or two),
    else up by doubling steps, then bisection.
    """
    trial = attempt(start)
    if trial.max_error <= tol:
        n_free = start
        while n_free > 0:
            lower = attempt(n_free - 1)
            if lower.max_error > tol:
                break
            trial, n_free = lower, n_free - 1
        return trial
    lo, step, best_fail = start, 1, trial
    while True:
        n_free = min(lo + step, most)
        trial = attempt(n_free)
        if trial.max_error <= tol:
            return _bisect(attempt, lo, n_free, trial, tol)
        if trial.max_error < best_fail.max_error:
            best_fail = trial
        if n_free >= most:
            _raise_not_reached(tol, best_fail)
        lo, step = n_free, step * 2


def _dominant(points, t, fit_at, options: KnotOptions) -> _Trial:
    corners = ([] if options.corner_angle_deg is None
               else detect_corners(points, t, min_angle_deg=options.corner_angle_deg))
    dominant = initial_dominant_points(points, corners)
    target = options.n_control_points
    limit = _limit(options, t.size)
    if target is not None and dominant.size > target:
        keep = np.unique(np.linspace(0, dominant.size - 1, target).round().astype(int))
        dominant = dominant[keep]
    while True:
        knots = dominant_point_knots(t, dominant, corners)
        trial = _polish(_checked(_try(fit_at, knots, None, t.size)), fit_at, options)
        count = n_coefficients(knots)
        if target is not None and count >= target:
            return trial
        if target is None and trial.max_error <= options.tol:
            return trial
        if count >= limit:
            if target is not None:
                return trial
            raise FitError(
                f"tol={options.tol!r} mm not reached with {count} control points (dominant "
                f"points; best max error {trial.max_error:.6g} mm)"
            )
        grown = refine_dominant_points(points, dominant, trial.errors)
        if grown.size == dominant.size:  # the worst segment cannot be split: any other
            free = np.setdiff1d(np.arange(t.size), dominant)
            gaps = np.diff(dominant)
            k = int(np.argmax(gaps))
            grown = np.union1d(dominant, [free[np.searchsorted(free, dominant[k])]
                                          if gaps[k] > 1 else free[0]])
        dominant = grown
