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

import dataclasses
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

import numpy as np
from numpy.typing import NDArray

from .arrays import as_positive_length
from .between_data import BETWEEN_DATA
from .errors import (
    ConvergenceWarning,
    FitError,
    InvalidParameterError,
    ToleranceNotReachedError,
    UnfairFitWarning,
)
from .fairness import FLAT_CURVATURE_PER_MM
from .knots import (
    Corner,
    detect_corners,
    dominant_point_knots,
    error_density,
    fourth_derivative_density,
    initial_dominant_points,
    place_knots,
    refine_dominant_points,
    turning_angles,
)
from .splinefit import DEGREE, end_interpolating_lsq, n_coefficients, schoenberg_whitney_violation
from .tolerances import TINY

__all__ = ["KNOT_METHODS", "KnotOptions", "adapt_knots", "check_given_knots", "knot_options"]

KNOT_METHODS = ("density", "dominant")
#: Error-equidistribution sweeps per knot count; the tolerance search carries the learned
#: density from one count to the next, so later counts start near the optimum.
DEFAULT_SWEEPS = 12

#: Preliminary fits giving the seed density, each on knots from the previous one's density
#: (a 120-point blade section at 20 control points: the first sweep starts at 0.29 mm after
#: one pass, 0.015 mm after five; Ex 4 at 44: 0.43 mm after one, 0.045 mm after three).
SEED_PASSES = 5
#: Sweeps stop once this many in a row lowered the max error by less than SWEEP_GAIN.
SWEEP_PATIENCE = 3
SWEEP_GAIN = 0.01

FitT = TypeVar("FitT")
FitAt = Callable[[NDArray[np.float64], NDArray[np.float64] | None],
                 tuple[FitT, NDArray[np.float64]]]
#: Lawson iterations of the minimax polish; the max error settles within about ten.
MINIMAX_STEPS = 12
#: Rounds of the fairness mend (:func:`_mend`), and the factor by which each round weighs
#: the errors around a stretch more (cumulative: eight rounds ask up to 4^8 x there).
MEND_ROUNDS = 8
MEND_TIGHTEN = 4.0
#: The mend stops after this many rounds in a row that found nothing fairer.
MEND_PATIENCE = 2
#: Spans either side of a stretch that the wide split and the curvature-jump knot reach.
MEND_REACH = 2
#: The mend's budget: at most this factor of the chosen fit's control points (with the
#: rounds, it bounds the mend's time). Trait-style sections (tests/toolpath/test_mend.py)
#: chosen at 13-17 control points needed up to 36 (2x left 1 in 150 unfair).
MEND_GROWTH = 3
#: Error-equidistribution sweeps of each mend search (it starts from the chosen knots).
MEND_SWEEPS = 4
#: ``fair_check(fit, knots)`` -> the unfair stretches of a fit: ``(t_start, t_end, size_mm,
#: what)`` with ``what`` naming it for a warning (e.g. "0.0021 mm concave at t=0.4961"),
#: and the data intervals it is off the data between points, ``(..., what, BETWEEN_DATA)``
#: (:func:`toolpath.between_data.between_data_over`), mended after the unfair ones.
FairCheck = Callable[[Any, NDArray[np.float64]], list[tuple]]
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
    #: The data's corners as the caller judged them (a union grid's sections vote,
    #: :func:`toolpath.fitted_surface.fit_grid`); None: detected on the points.
    corners: tuple[Corner, ...] | None = None


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


def _polish(trial: _Trial, fit_at: FitAt, options: KnotOptions,
            held: NDArray[np.float64] | None = None) -> _Trial:
    """Lower the max error on fixed knots by Lawson's iteratively reweighted least squares.

    ``w_i ← w_i e_i / Σ_j w_j e_j`` drives the weighted least-squares solution towards the
    minimax one (Lawson 1961); the best iterate is kept, so the max error never rises.
    Weights are kept above :data:`WEIGHT_FLOOR` times their mean: points the fit already
    meets (the interpolated ends have ``e = 0``) would otherwise reach weight 0, leave a
    basis function with no weighted data and make the normal equations singular (on the
    half profile that gave control points of 1e6 and ``exp`` overflow).

    ``held``: weights (relative to the mean, 1) kept as they are where finite; ``trial``
    is then the fit with them. Lawson's weights change from point to point with the error;
    on a nose sampled 0.02 mm apart that makes the error alternate in sign from point to
    point and the fit dent between them (a 0.0068 mm concave stretch beside a nose that
    the least-squares fit on the same knots leaves convex). Held there, they keep the
    fit a least-squares one along the nose.
    """
    if not options.minimax or trial.failure is not None:
        return trial
    best = trial
    held = np.full(trial.errors.size, np.nan) if held is None else held
    free = ~np.isfinite(held)
    weights = np.where(free, 1.0, held)
    errors = trial.errors
    for _ in range(MINIMAX_STEPS):
        if not np.isfinite(errors).all():
            break  # a reweighted fit overflowed: keep the best finite one
        weights = np.where(free, weights * errors, 0.0)
        total = weights.sum()
        if not np.isfinite(total) or total <= 0:
            break
        weights = np.maximum(weights / total * free.sum(), WEIGHT_FLOOR)
        weights = np.where(free, weights, held)
        current = _try(fit_at, trial.knots, weights, errors.size)
        if current.failure is not None:
            break
        errors = current.errors
        if current.max_error < best.max_error:
            best = current
    return best


def _seed_density(t: NDArray[np.float64], values: NDArray[np.float64], corners: list[Corner]):
    """Density ``|f''''|^{1/4}`` from preliminary fits (de Boor's NEWNOT iteration).

    The first fit has evenly spread knots; each of the ``SEED_PASSES`` fits estimates
    ``f''''`` from its own ``S'''`` jumps, and the next one places its knots by that
    estimate, so a feature narrower than the even spacing (a leading edge, Ex 4's 1.6 mm
    bend) is resolved before the density is used.
    """
    n_free = int(np.clip(t.size // 3, 4, 120))
    density = (np.array([0.0, 1.0]), np.ones(1))
    for _ in range(SEED_PASSES):
        knots = place_knots(t, corners, *density, n_free)
        spline = end_interpolating_lsq(t, values, knots)
        density = fourth_derivative_density(spline.t, spline.c)
    return density


def check_given_knots(t: NDArray[np.float64], knots: NDArray[np.float64]) -> None:
    """Raise :class:`InvalidParameterError` naming why ``knots`` cannot fit data at ``t``."""
    problem = schoenberg_whitney_violation(t, knots)
    if problem is not None:
        raise InvalidParameterError(f"knots cannot be fitted: {problem}")


def adapt_knots(points: NDArray[np.float64], t: NDArray[np.float64],
                seed_values: NDArray[np.float64], fit_at: FitAt, options: KnotOptions,
                fair_check: FairCheck | None = None
                ) -> tuple[FitT, NDArray[np.float64], NDArray[np.float64]]:
    """Run a method with the knots the options ask for.

    With ``fair_check`` and a tolerance, the chosen fit is then mended (:func:`_mend`)
    until it has no unfair stretch; fits on given knots or a given count are left as they
    are (the request fixes the knots).

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
    got = n_coefficients(trial.knots)
    if options.n_control_points is not None and got < options.n_control_points:
        warnings.warn(ConvergenceWarning(
            f"fitted with {got} control points, not the {options.n_control_points} control "
            "points asked: no knot span has room for another knot (each control point "
            "needs a data point of its own, Schoenberg-Whitney); give fewer control points"),
            stacklevel=3)
    if fair_check is not None and options.tol is not None:
        trial = _mend(trial, points, t, seed_values, fit_at, options, fair_check)
    return trial.fit, trial.errors, trial.knots


def _mend(trial: _Trial, points, t: NDArray[np.float64], seed_values, fit_at: FitAt,
          options: KnotOptions, fair_check: FairCheck) -> _Trial:
    """Mend the unfair stretches of a chosen fit until there are none.

    A fit within ``tol`` at the data may dent between them by about as much as its error
    swings from point to point: on a nose of radius 0.2 mm an error of 7 um alternating in
    sign bends the fit concave, and after a jump of the data's curvature (a nose circle
    meeting a flank tangentially, G1 but not G2) the cubic rings with the jump times the
    span squared on the flank side. Each round mends every stretch where it is:

    - the same knots, the polish's weights held (:func:`_polish`) at ``scale²`` around
      the stretches, ``scale`` growing :data:`MEND_TIGHTEN` times a round there (Lawson's
      weights, free to change from point to point on a dense nose, are what make the
      error alternate there);
    - the knot spans over the stretches halved, and with them :data:`MEND_REACH` spans
      either side (the ring's depth falls with the span²);
    - one knot fewer at each stretch: knots as dense as the data, or a corner's piece
      with fewer points than coefficients, let the spline swing between the points;
    - a knot where the data's curvature jumps beside each stretch (:func:`_jump_knots`),
      and a double knot there: a C2 cubic rings across a G1 join however dense its knots;
    - the same knots, the polish's weights held at ``1 / scale`` around the stretches
      (``scale`` as above): a C2 cubic fitting a
      jump of the data's curvature (a nose circle meeting its flank G1) as closely as the
      dense nose asks overshoots it, like a least-squares line through a step, and rings
      concave on the flank; let go there, it spreads the turn within ``tol`` instead
      (trait-style sections, ``tests/toolpath/test_mend.py``: a blunt base's LE ring of
      0.0010 mm and a DCA TE ring of 0.0013 mm went, in one and three rounds).

    Data intervals where the fit is estimated off the data between the points
    (:func:`toolpath.between_data.between_data_over`, entries of kind ``BETWEEN_DATA``)
    are mended the same way, once no unfair stretch is left, with one more candidate: the
    spans over them split, the polish's weights free (the span, not the points, needs to
    come closer). On the real-like blades' sections, tol 0.01, that took the largest true
    error between the data from 0.0126 / 0.0137 mm (propeller, streamline / B-spline) and
    0.0117 / 0.0118 mm (blunt rotor) to at most 0.0099 mm
    (``benchmarks/between_data_truth.py``).

    The fairest candidate within ``tol`` is kept (fewest unfair stretches, then fewest
    intervals off the data, then the shallowest deepest, then the fewest control
    points). Only when none of them is fairer than the
    round's start is the knot search run again from the current knots with the errors
    around the stretches times ``scale`` (knots gather there, but the search may add many
    elsewhere too). The rounds go on until the check passes, no candidate stays within
    ``tol``, :data:`MEND_ROUNDS` rounds have run, :data:`MEND_PATIENCE` rounds in a row
    found nothing fairer, or the budget of :data:`MEND_GROWTH` times the control points
    is spent; what is left of the fairest fit is named in a
    :class:`ConvergenceWarning`.
    """
    assert options.tol is not None
    most = min(_limit(options, t.size), MEND_GROWTH * n_coefficients(trial.knots))
    options = dataclasses.replace(options, max_control_points=most)
    scale = np.ones(t.size)
    stretches = fair_check(trial.fit, trial.knots)
    best = (_unfairness(stretches), trial, stretches)
    stale = 0
    for _ in range(MEND_ROUNDS):
        if not stretches:
            return trial
        if stale >= MEND_PATIENCE:
            break  # the mends have stopped helping (unfair data, not a fit's ripple)
        # the unfair stretches first; the intervals off the data between points once the
        # fit is fair (mending both at once, the holds and knots of the one undo the other)
        mending = [s for s in stretches if s[4:5] != (BETWEEN_DATA,)] or stretches
        scale = np.maximum(scale, _stretch_scale(trial.knots, t, mending, scale))
        # the polish's weights held around the stretches, as the tightening asks
        held = np.where(scale > 1.0, scale**2, np.nan)
        local = [
            # the same knots, the points around the stretches held closer
            _refit(trial, trial.knots, t, fit_at, options, held),
            # the spans over the stretches halved
            _refit(trial, _split_spans(trial.knots, t, mending), t, fit_at, options, held),
            # ... the weights left to the polish: a fit off the data between the points
            # there needs the span, not the points, held closer
            _refit(trial, _split_spans(trial.knots, t, mending), t, fit_at, options,
                   np.full(t.size, np.nan)) if mending[0][4:5] == (BETWEEN_DATA,) else None,
            # ... and the spans beside them: a ring after a jump of the data's curvature
            # (a nose meeting a flank) falls with the span squared on either side
            _refit(trial, _split_spans(trial.knots, t, mending, MEND_REACH), t, fit_at,
                   options, held),
            # knots as dense as the data (or a corner's piece with fewer points than
            # coefficients) let the spline swing between the points: fewer knots there
            _refit(trial, _thin_spans(trial.knots, mending), t, fit_at, options, held),
            # a knot where the data's curvature jumps beside each stretch
            _refit(trial, _jump_knots(trial.knots, points, t, mending), t, fit_at,
                   options, held),
            # ... a double one: the fit's curvature jumps there as the data's does
            _refit(trial, _jump_knots(trial.knots, points, t, mending, 2), t, fit_at,
                   options, held),
            # the same knots, the points around the stretches let go: a ring after a jump
            # of the data's curvature is the fit following the jump too closely
            _refit(trial, trial.knots, t, fit_at, options,
                   np.where(scale > 1.0, 1.0 / scale, np.nan)),
        ]
        tried = _scored(local, fair_check)
        if not tried or tried[0][0] >= _unfairness(stretches):
            # no local mend helps: the knot search again, the points around the
            # stretches asked closer (knots gather there; it may add many)
            tried = sorted(tried + _scored([_tightened(trial, points, t, seed_values, fit_at,
                                                       options, scale, held)], fair_check),
                           key=lambda item: item[:2])
        if not tried:
            break
        score, _, trial, stretches = tried[0]
        stale = 0 if _progress(score, best[0]) else stale + 1
        if score < best[0]:
            best = (score, trial, stretches)
    _, trial, stretches = best
    if stretches:
        warnings.warn(UnfairFitWarning(
            f"the fit stays unfair (or off the data between points) after adding knots "
            f"({n_coefficients(trial.knots)} control points): "
            f"{'; '.join(s[3] for s in stretches[:3])}"
            + (f" and {len(stretches) - 3} more" if len(stretches) > 3 else ""),
            _unfairness(stretches)), stacklevel=3)
    return trial


def _scored(candidates: list[_Trial | None], fair_check: FairCheck) -> list[tuple]:
    """``(unfairness, control points, trial, stretches)`` of the candidates.

    Fairest first, then the fewest control points.
    """
    tried = [(_unfairness(found), n_coefficients(c.knots), c, found)
             for c in candidates if c is not None for found in [fair_check(c.fit, c.knots)]]
    return sorted(tried, key=lambda item: item[:2])


def _tightened(trial: _Trial, points, t, seed_values, fit_at: FitAt, options: KnotOptions,
               scale: NDArray[np.float64], held: NDArray[np.float64]) -> _Trial | None:
    """The knot search run again from ``trial``'s knots with the errors times ``scale``.

    Its knots are then fitted and polished with the weights ``held`` around the stretches.
    """
    def scaled(knots, weights):
        fit, errors = fit_at(knots, weights)
        return fit, errors * scale

    # no minimax polish here: Lawson's weights would fall to ~0 away from the tightened
    # points and let the spline swing there; few sweeps: the knots are near already
    local = dataclasses.replace(options, start_knots=trial.knots, minimax=False,
                                sweeps=min(options.sweeps, MEND_SWEEPS))
    try:
        found = _density(points, t, seed_values, scaled, local)
    except FitError:
        return None
    return _refit(trial, found.knots, t, fit_at, options, held)


def _refit(trial: _Trial, knots: NDArray[np.float64], t, fit_at: FitAt,
           options: KnotOptions, held: NDArray[np.float64]) -> _Trial | None:
    """The fit on ``knots``, polished with the weights ``held`` where finite.

    When that loses ``tol``, the points are held at the square root of those weights
    instead: half as firmly on a log scale (``scale`` for ``scale²``), or let go half as
    far (``1 / √scale`` for ``1 / scale``). Why: the tolerance search stops at the first
    count whose fit passes, so the chosen fit is within ``tol`` by little; points held
    ``scale²`` times the mean pull the fit towards them, and the error that takes is
    pushed onto the free points a span or two away, which the polish cannot win back (it
    may only move weight among the free points). A mend needs less than that pull: the
    stretch's knots (a jump knot, the split spans) do most of the work, and the hold need
    only keep the polish's weights from alternating on a dense nose, which any hold does.
    On this machine's CPU (AMD EPYC) the trait-style blunt section of
    ``tests/toolpath/test_mend.py`` (seed 23, streamline) was left 0.0103 mm off the data
    between points, every other held candidate 0.2-20 % over ``tol``; its jump knot held
    at 16 was 0.2 % over, at 4 within ``tol`` by 5 % and fair.

    None if the knots cannot be fitted or lose ``tol`` either way.
    """
    assert options.tol is not None
    if n_coefficients(knots) > _limit(options, t.size) \
            or schoenberg_whitney_violation(t, knots) is not None:
        return None
    found = _held_fit(knots, t, fit_at, options, held)
    if found is None and np.isfinite(held).any():
        found = _held_fit(knots, t, fit_at, options, np.sqrt(held))
    return found


def _held_fit(knots: NDArray[np.float64], t, fit_at: FitAt, options: KnotOptions,
              held: NDArray[np.float64]) -> _Trial | None:
    """The fit on ``knots`` polished with the weights ``held``; None past ``tol``."""
    first = _try(fit_at, knots, np.where(np.isfinite(held), held, 1.0), t.size)
    if first.failure is not None:
        return None
    found = _polish(first, fit_at, options, held)
    return found if found.max_error <= options.tol else None


def _split_spans(knots: NDArray[np.float64], t: NDArray[np.float64], stretches,
                 reach: int = 0) -> NDArray[np.float64]:
    """``knots`` with the spans meeting a stretch split in the middle of their data.

    ``reach`` spans either side of them are split too. A span holding fewer than two data
    parameters stays whole (Schoenberg-Whitney).
    """
    edges = np.unique(knots)
    added = []
    for lo, hi, *_ in stretches:
        first = int(np.clip(np.searchsorted(edges, lo, side="right") - 1 - reach, 0,
                            edges.size - 2))
        last = int(np.clip(np.searchsorted(edges, hi, side="left") - 1 + reach, 0,
                           edges.size - 2))
        for j in range(first, max(last, first) + 1):
            inside = t[(t > edges[j]) & (t < edges[j + 1])]
            if inside.size >= 2:
                mid = inside.size // 2
                added.append(0.5 * (inside[mid - 1] + inside[mid]))
    return np.sort(np.concatenate((knots, np.unique(added))))


def _jump_knots(knots: NDArray[np.float64], points, t: NDArray[np.float64], stretches,
                copies: int = 1) -> NDArray[np.float64]:
    """``knots`` with a knot where the data's curvature jumps most near each stretch.

    A nose circle meeting a flank tangentially (G1, not G2) makes the data's curvature
    jump between two points; a C2 cubic cannot follow it and rings on the flank side, by
    the jump times the span squared. With a knot in the jump's interval the ring fades
    within that span (a propeller-style LE: 0.0027 mm concave without it, 0.0007 with
    it). The jump is the largest ``|ln(κ_{i+1} / κ_i)|`` of the discrete curvature
    (turning angle over the mean of the two steps) over the stretch's spans and
    :data:`MEND_REACH` spans either side, away from the corners (a knot of multiplicity
    ``DEGREE``: a corner's turn is no curvature jump to follow); its interval gets a knot
    in the middle unless it holds one. Stretches sharing a jump share its knot: each
    position goes in once, up to ``copies`` in all with the copies already there.

    ``copies=2``: the knot is a double one, the fit C1 there and its curvature free to
    jump as the data's does. A C2 fit across a G1 join rings however dense its knots (a
    propeller-style LE meeting its flank: a knot as dense as the data either side, 3.7 um
    concave, the normal turning back 7.6 deg); a double knot at the join leaves it fair.
    """
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    kappa = np.full(t.size, np.nan)
    kappa[1:-1] = turning_angles(points) / np.maximum(0.5 * (steps[:-1] + steps[1:]),
                                                        TINY)
    # curvature floored where the data are flat: a flank's few micrometres of noise take
    # its discrete turning to ~0 at a point, a jump of ln(1e-9) without the floor
    signed = np.diff(np.log(np.maximum(kappa, FLAT_CURVATURE_PER_MM)))
    jump = np.abs(signed)
    edges, counts = np.unique(knots, return_counts=True)
    corners = edges[1:-1][counts[1:-1] >= DEGREE]
    # the intervals either side of a data point at a corner, and one holding a corner
    near = np.searchsorted(corners, t[np.maximum(np.arange(t.size - 1) - 1, 0)], "left") \
        < np.searchsorted(corners, t[np.minimum(np.arange(t.size - 1) + 2, t.size - 1)],
                          "right")
    jump[near] = np.nan
    wanted = set()  # knot positions; two stretches near one jump pick it once
    for lo, hi, *_ in stretches:
        first = edges[max(int(np.searchsorted(edges, lo, side="right")) - 1 - MEND_REACH, 0)]
        last = edges[min(int(np.searchsorted(edges, hi, side="left")) + MEND_REACH,
                         edges.size - 1)]
        inside = np.flatnonzero((t[:-1] >= first) & (t[1:] <= last) & np.isfinite(jump))
        if inside.size == 0:
            continue
        i = int(inside[np.argmax(jump[inside])])
        at = _join(signed, t, i)
        there = knots[(knots > t[i]) & (knots < t[i + 1])] if at is None else \
            knots[knots == at]
        if there.size:
            wanted.add(float(there[0]))
        else:
            wanted.add(0.5 * (t[i] + t[i + 1]) if at is None else at)
    # each position up to ``copies`` in all, counting the copies already there
    added = [x for x in sorted(wanted) for _ in range(copies - int(np.sum(knots == x)))]
    return np.sort(np.concatenate((knots, added)))


def _join(signed: NDArray[np.float64], t: NDArray[np.float64], i: int) -> float | None:
    """The data parameter of the join whose curvature jump is largest in interval ``i``.

    ``signed``: ``ln(κ_{j+1} / κ_j)`` per interval. A sample at the join itself (a nose's
    last point, the flank's first) turns half as much as the nose's points, and the jump
    splits over the intervals either side of it, ``ln 2`` on the nose side: when the
    neighbouring interval jumps the same way by at least half that (or a quarter of the
    largest), the join is the sample they share; else it lies inside interval ``i``
    (None).
    """
    least = min(0.25 * abs(signed[i]), 0.5 * np.log(2.0))
    for j, shared in ((i - 1, i), (i + 1, i + 1)):
        if 0 <= j < signed.size and np.isfinite(signed[j]) \
                and signed[j] * signed[i] > 0 and abs(signed[j]) >= least:
            return float(t[shared])
    return None


def _thin_spans(knots: NDArray[np.float64], stretches) -> NDArray[np.float64]:
    """``knots`` less one copy of the interior knot nearest the middle of each stretch.

    A span too thin to split holds one data point or none: the knots there are as dense as
    the data (or a corner's knot leaves a piece with fewer points than coefficients), and
    the spline swings between the points.
    """
    values = np.unique(knots)[1:-1]
    if values.size == 0:
        return knots
    drop = {float(values[np.argmin(np.abs(values - 0.5 * (lo + hi)))])
            for lo, hi, *_ in stretches}
    keep = np.ones(knots.size, dtype=bool)
    for value in drop:
        keep[int(np.flatnonzero(knots == value)[0])] = False
    return knots[keep]


def _stretch_scale(knots: NDArray[np.float64], t: NDArray[np.float64], stretches,
                   scale: NDArray[np.float64]) -> NDArray[np.float64]:
    """Error factors: ``MEND_TIGHTEN`` times the current ones around every stretch."""
    edges = np.unique(knots)
    out = np.ones(t.size)
    for lo, hi, *_ in stretches:
        first = int(np.searchsorted(edges, lo, side="right")) - 2
        last = int(np.searchsorted(edges, hi, side="left")) + 1
        near = (t >= edges[max(first, 0)]) & (t <= edges[min(last, edges.size - 1)])
        out[near] = MEND_TIGHTEN * scale[near]
    return out


def _unfairness(stretches: list[tuple]) -> tuple[int, int, float, float]:
    """Order of fits by fairness, fairest first.

    Fewer unfair stretches, then fewer intervals off the data between points, then a
    shallower deepest stretch, then a smaller largest estimate.

    A concave stretch is what a cutter cannot follow; an interval estimated off the data
    may be the data's own uncertainty, so a mend never trades the first for the second.
    """
    off = [s for s in stretches if s[4:5] == (BETWEEN_DATA,)]
    unfair = [s for s in stretches if s[4:5] != (BETWEEN_DATA,)]
    return (len(unfair), len(off), max((s[2] for s in unfair), default=0.0),
            max((s[2] for s in off), default=0.0))


def _progress(new: tuple, old: tuple) -> bool:
    """Whether a round's fairest fit is a step on from the fairest so far.

    Fewer stretches or intervals, or the deepest (else the largest estimate) lower by more
    than :data:`SWEEP_GAIN`: an interval the data cannot tell better (a coarse nose) came
    down by 1e-6 mm a round and kept the mend going all its rounds (1.3 -> 7.0 s on a
    propeller section).
    """
    if new[:2] != old[:2]:
        return new[:2] < old[:2]
    if new[2] != old[2]:
        return new[2] < old[2] * (1.0 - SWEEP_GAIN)
    return new[3] < old[3] * (1.0 - SWEEP_GAIN)


def _limit(options: KnotOptions, n_points: int) -> int:
    limit = n_points
    if options.max_control_points is not None:
        limit = min(limit, options.max_control_points)
    return limit


#: Floor of a gap between given start knots (a repeated knot has none) where their
#: density is ``1 / gap``: it keeps the density finite, and huge where knots coincide.
_LEAST_KNOT_GAP = 1e-12


def _data_corners(points, t: NDArray[np.float64], options: KnotOptions) -> list[Corner]:
    """The data's corners: none without a corner angle, else the caller's, else detected."""
    if options.corner_angle_deg is None:
        return []
    if options.corners is not None:
        return list(options.corners)
    return detect_corners(points, t, min_angle_deg=options.corner_angle_deg)


def _density(points, t, seed_values, fit_at, options: KnotOptions) -> _Trial:
    corners = _data_corners(points, t, options)
    fixed = DEGREE + 1 + DEGREE * len(corners)
    if options.start_knots is not None and options.tol is not None:
        edges = np.unique(options.start_knots)
        density = 1.0 / np.maximum(np.diff(edges), _LEAST_KNOT_GAP)
    else:
        edges, density = _seed_density(t, seed_values, corners)
    learned = [(edges, density)]  # the density of the latest attempt's best knots

    def attempt(n_free: int) -> _Trial:
        """Fit with ``n_free`` free knots: seed from the latest density, then sweeps."""
        density = learned[-1]
        knots = place_knots(t, corners, *density, n_free)
        best = current = _try(fit_at, knots, None, t.size)
        best_density, stale = density, 0
        for _ in range(options.sweeps):
            if current.failure is not None:
                break  # no error density to learn from
            density = error_density(current.knots, t, current.errors)
            knots = place_knots(t, corners, *density, n_free)
            current = _try(fit_at, knots, None, t.size)
            if current.max_error < best.max_error * (1.0 - SWEEP_GAIN):
                best, best_density, stale = current, density, 0
            else:
                if current.max_error < best.max_error:
                    best, best_density = current, density
                stale += 1
                if stale >= SWEEP_PATIENCE:
                    break  # the density has settled
        learned.append(best_density)  # the next count starts from this count's best knots
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
    count = n_coefficients(best_fail.knots)
    raise ToleranceNotReachedError(
        f"tol={tol!r} mm not reached with {count} control points (best max error "
        f"{best_fail.max_error:.6g} mm); raise max_control_points or tol",
        tol_mm=tol, best_mm=float(best_fail.max_error), control_points=count)


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
    corners = _data_corners(points, t, options)
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
            raise ToleranceNotReachedError(
                f"tol={options.tol!r} mm not reached with {count} control points (dominant "
                f"points; best max error {trial.max_error:.6g} mm)",
                tol_mm=options.tol, best_mm=float(trial.max_error), control_points=count)
        grown = refine_dominant_points(points, dominant, trial.errors)
        if grown.size == dominant.size:  # the worst segment cannot be split: any other
            free = np.setdiff1d(np.arange(t.size), dominant)
            gaps = np.diff(dominant)
            k = int(np.argmax(gaps))
            grown = np.union1d(dominant, [free[np.searchsorted(free, dominant[k])]
                                          if gaps[k] > 1 else free[0]])
        dominant = grown
