"""Periodic cubic B-splines on [0, 1): the fits of closed curves and closed sections.

A closed fit must be smooth across its seam (``t = 0 ≡ 1``): position, tangent and
curvature. It is a periodic cubic spline, stored as an ordinary scipy ``BSpline`` so every
evaluator (scipy, the power-form patches of :mod:`toolpath.tensor_spline`, the compiled
kernels of :mod:`toolpath.compiled`) reads it unchanged on its base interval [0, 1]:

- **knots of one period** ``0 = κ_0 <= κ_1 <= ... <= κ_(N-1) < 1``: the seam is always a
  knot (multiplicity 1, or ``DEGREE`` where the data have a corner at the seam), the others
  interior knots as for an open fit;
- **extended knot vector**, the period knots continued by period 1 on both sides:
  ``κ_(N-3) − 1, κ_(N-2) − 1, κ_(N-1) − 1, κ_0, ..., κ_(N-1), 1 + κ_0, ..., 1 + κ_3``
  (``N + 7`` knots, base interval ``[knots[3], knots[N+3]] = [0, 1]``);
- **coefficients wrapped**: ``N + 3`` of them with ``c_(N+i) = c_i`` (``i < 3``); ``N`` are free.

Then ``S`` and its derivatives agree at ``t → 0+`` and ``t → 1−`` to the order the seam
knot allows (C2 for a simple seam knot, C0 at a seam corner).

**Least squares** (eq. 19 on a periodic basis): with the ``N`` periodic basis functions
``Ñ_j`` (the B-splines of the extended vector, the last three folded onto the first three),
``min Σ_i w_i ||S(t_i) − V_i||²`` subject to ``S(0) = V_0``: the seam passes through the
first data point exactly, as an open fit passes through both ends (the paper's
``G(0) = 0``, eq. 20, for the streamline model; for a closed section ``Y_n = 0``, so ``G`` is
periodic). Solved as the KKT system ``[[BᵀWB + εΔᵀΔ, a], [aᵀ, 0]] [c; λ] = [BᵀWV; V_0]``
with ``a = Ñ(0)`` and ``Δ`` the cyclic first differences of the coefficients at a tiny
weight ``ε`` (:data:`TIE_BREAK`: it only decides between fits the data cannot tell apart,
such as a piece between two corner knots with no sample inside); the normal matrix is
cyclic banded, built in O(n) from the sparse design matrix and solved dense (``N`` is at
most a few hundred control points: about a millisecond), a least-squares solve if singular.

**Knots.** The knot driver of :mod:`toolpath.adaptive` works unchanged on the clamped view
of the same knots (the period's interior knots between clamped ends at 0 and 1): because the
seam is always a knot, the spans of the periodic spline in [0, 1) *are* the clamped spans,
so corners, the ``|f''''|^{1/4}`` density, error sweeps, the tolerance search and the Lawson
polish apply as they are; :func:`adapt_closed_knots` translates counts and knot vectors
both ways. A seam on a densely sampled nose would make the view's ends (a fixed knot, the
ends of the seed, sweeps and mend) split the nose: the view is then cut open where the
data are sparsest instead, and the view's knot nearest the seam is moved onto it
(:func:`closed_cut`). Schoenberg-Whitney for a periodic spline: every span in [0, 1) holds
a data parameter and there are at least ``N`` of them (:func:`periodic_violation`).
"""

from __future__ import annotations

import dataclasses
import re
import warnings

import numpy as np
import scipy.interpolate
import scipy.linalg
import scipy.sparse
from numpy.typing import NDArray

from .adaptive import adapt_knots
from .errors import (
    ConvergenceWarning,
    FitError,
    InvalidParameterError,
    ToleranceNotReachedError,
    UnfairFitWarning,
    reissue_warnings,
)
from .knots import Corner
from .splinefit import DEGREE, clamped_knots, interior_knots
from .tolerances import ROUND_OFF

__all__ = [
    "TIE_BREAK",
    "adapt_closed_knots",
    "closed_cut",
    "free_coefficients",
    "from_clamped",
    "is_periodic",
    "periodic_knots",
    "periodic_lsq",
    "period_of",
    "periodic_violation",
    "to_clamped",
    "view_knots_on_loop",
]


#: Weight (relative to the normal matrix's mean diagonal) of the cyclic first differences
#: of the coefficients added to the least squares: it picks the shortest control polygon
#: among fits the data cannot tell apart and moves a determined fit by about this fraction
#: (1e-9 of a 100 mm coefficient is 1e-7 mm).
TIE_BREAK = 1e-9


def is_periodic(knots: NDArray[np.float64]) -> bool:
    """Whether ``knots`` is an extended periodic vector (it starts below its base interval)."""
    knots = np.asarray(knots, dtype=float)
    return knots.size >= 2 * DEGREE + 2 and bool(knots[0] < knots[DEGREE])


def period_of(knots: NDArray[np.float64]) -> NDArray[np.float64]:
    """The knots of one period, ``κ_0 = 0 ... κ_(N-1)``."""
    return np.asarray(knots[DEGREE:-(DEGREE + 1)], dtype=float)


def periodic_knots(period: NDArray[np.float64]) -> NDArray[np.float64]:
    """The extended vector from the knots of one period (``κ_0 = 0``, ``N >= DEGREE + 1``)."""
    k = np.sort(np.asarray(period, dtype=float))
    return np.concatenate((k[-DEGREE:] - 1.0, k, 1.0 + k[:DEGREE + 1]))


def free_coefficients(knots: NDArray[np.float64]) -> int:
    """Control points of a cubic on ``knots``: ``N`` for a periodic vector, else ``len − 4``."""
    extra = DEGREE if is_periodic(knots) else 0
    return len(knots) - DEGREE - 1 - extra


def periodic_violation(t: NDArray[np.float64], knots: NDArray[np.float64]) -> str | None:
    """Why the data parameters ``t`` cannot determine a periodic cubic on ``knots``, or None.

    ``t`` lies in [0, 1]; ``t = 1`` is the seam again (not counted as a sample).
    """
    knots = np.asarray(knots, dtype=float)
    if knots.size < 3 * DEGREE + 2:
        return (f"a periodic cubic knot vector needs at least {3 * DEGREE + 2} knots (4 in "
                f"a period), got {knots.size}")
    if np.any(np.diff(knots) < 0):
        return "knots must be non-decreasing"
    period = period_of(knots)
    if period[0] != 0.0 or knots[-(DEGREE + 1)] != 1.0:
        return "a periodic knot vector's base interval must be [0, 1] (knots[3] = 0)"
    if not np.allclose(knots, periodic_knots(period), rtol=0.0, atol=ROUND_OFF):
        return "knots must continue by period 1 on both sides of [0, 1]"
    _, counts = np.unique(period, return_counts=True)
    if counts.max() > DEGREE:
        return f"a knot repeats {counts.max()} times; at most {DEGREE} allowed"
    inside = t[t < 1.0]
    edges = np.append(np.unique(period), 1.0)
    held = np.histogram(inside, bins=edges)[0]
    if (held == 0).any():
        j = int(np.argmax(held == 0))
        return (f"knot span [{edges[j]:.6g}, {edges[j + 1]:.6g}] holds no data point "
                "(Schoenberg-Whitney condition); use fewer knots there")
    if inside.size < period.size:
        return f"{period.size} control points need at least as many points, got {inside.size}"
    return None


def _folded_basis(t: NDArray[np.float64], knots: NDArray[np.float64]):
    """Sparse ``(len(t), N)`` matrix of the periodic basis ``Ñ_j(t_i)`` (CSR)."""
    n_free = free_coefficients(knots)
    full = scipy.interpolate.BSpline.design_matrix(t, knots, DEGREE).tocsr()
    full.indices = np.mod(full.indices, n_free)  # columns N.. fold onto 0..
    folded = scipy.sparse.csr_matrix((full.data, full.indices, full.indptr),
                                     shape=(len(t), n_free))
    folded.sum_duplicates()
    return folded


def periodic_lsq(t: NDArray[np.float64], values: NDArray[np.float64],
                 knots: NDArray[np.float64], weights: NDArray[np.float64] | None = None
                 ) -> scipy.interpolate.BSpline:
    """Periodic least-squares cubic on ``knots`` through ``values[0]`` at the seam.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Increasing parameters, ``t[0] = 0``; samples at ``t = 1`` (the first point again,
        closing the loop) are not fitted (they are the seam, ``S(1) = S(0)``).
    values : ndarray, shape (n, d)
    knots : ndarray
        Extended periodic knot vector (:func:`periodic_knots`).
    weights : ndarray, shape (n,), optional
        Non-negative weights of the squared residuals.

    Returns
    -------
    scipy.interpolate.BSpline
        Coefficients ``(N + 3, d)``, wrapped; ``S(0) = S(1) = values[0]`` exactly.
    """
    problem = periodic_violation(t, knots)
    if problem is not None:
        raise FitError(problem)
    fitted = t < 1.0
    basis = _folded_basis(t[fitted], knots)
    v = np.asarray(values, dtype=float)[fitted]
    w = np.ones(basis.shape[0]) if weights is None else np.asarray(weights, float)[fitted]
    n_free = basis.shape[1]
    seam = _folded_basis(np.zeros(1), knots).toarray()[0]
    kkt = np.zeros((n_free + 1, n_free + 1))
    weighted = basis.multiply(w[:, None]).tocsr()
    normal = (basis.T @ weighted).toarray()  # O(n) to build: four basis values a row
    # the shortest control polygon among fits the data cannot tell apart (a piece between
    # two corner knots with no data inside, e.g. a blunt base closed by --closed: straight)
    ring = np.roll(np.eye(n_free), 1, axis=1) - np.eye(n_free)
    normal += TIE_BREAK * np.trace(normal) / n_free * (ring.T @ ring)
    kkt[:n_free, :n_free] = normal
    kkt[:n_free, n_free] = kkt[n_free, :n_free] = seam
    rhs = np.vstack((weighted.T @ v, values[:1]))
    try:
        solution = scipy.linalg.solve(kkt, rhs, assume_a="sym")
    except (np.linalg.LinAlgError, scipy.linalg.LinAlgWarning):
        solution = np.linalg.lstsq(kkt, rhs, rcond=None)[0]
    free = solution[:n_free]
    coef = np.vstack((free, free[:DEGREE]))
    return scipy.interpolate.BSpline(knots, coef, DEGREE, extrapolate=False)


def to_clamped(knots: NDArray[np.float64]) -> NDArray[np.float64]:
    """The clamped view of a periodic vector: its interior knots between clamped 0 and 1."""
    period = period_of(knots)
    return clamped_knots(period[period > 0.0])


def from_clamped(knots: NDArray[np.float64], seam: int = 1) -> NDArray[np.float64]:
    """The periodic vector of a clamped ``knots``' interior knots and a seam knot.

    The seam knot at 0 has multiplicity ``seam``. Fewer than ``DEGREE + 1`` knots in the
    period (a periodic cubic needs four) are made up by halving the longest span.
    """
    period = np.concatenate((np.zeros(seam), interior_knots(np.asarray(knots, float))))
    while period.size < DEGREE + 1:
        edges = np.append(period, 1.0)
        j = int(np.argmax(np.diff(edges)))
        period = np.sort(np.append(period, 0.5 * (edges[j] + edges[j + 1])))
    return periodic_knots(period)


#: The driver's cut moves off the seam when the seam's steps (in ``t``) are under this
#: fraction of the mean pair of steps round the loop (the seam is on a dense nose).
CUT_SPARSE_FRACTION = 0.5


def closed_cut(t: NDArray[np.float64], seam: int = 1) -> int:
    """Index of the sample where the knot driver cuts a closed loop open (0: at the seam).

    The driver places knots on an interval; its two ends are a fixed knot and the ends of
    its density seed, sweeps and mend. A seam on a nose sampled 100x denser than the flanks
    (a trailing edge whose nose circle meets the flanks G1 only) would fix a knot there and
    split the nose's knots, errors and repairs in two. So when the seam's two steps
    (``t_1 − t_(n−1) + 1``) are under :data:`CUT_SPARSE_FRACTION` of the mean pair (the
    seam is on densely sampled data) the loop is cut where its data are sparsest, at the
    sample whose two steps are longest; else, and at a corner (``seam > 1``: a corner is
    where a cut costs nothing), at the seam. ``t`` ends at the seam (``1``).
    """
    steps = np.diff(np.asarray(t, dtype=float))
    pairs = steps + np.roll(steps, 1)  # pairs[k]: the steps either side of sample k
    if seam > 1 or pairs[0] >= CUT_SPARSE_FRACTION * np.mean(pairs):
        return 0
    return int(np.argmax(pairs))


def _cut_view(period: NDArray[np.float64], cut_t: float) -> NDArray[np.float64]:
    """Clamped knots of the driver's view cut at ``cut_t``: ``(κ − cut_t) mod 1``."""
    moved = np.mod(np.asarray(period, dtype=float) - cut_t, 1.0)
    return clamped_knots(np.sort(moved[moved > 0.0]))


def view_knots_on_loop(view_knots: NDArray[np.float64], view_t: NDArray[np.float64],
                       loop_t: NDArray[np.float64], cut_t: float) -> NDArray[np.float64]:
    """The loop's parameters of knots of a view cut open at ``cut_t``: ``(κ + t_k) mod 1``.

    ``view_t`` (increasing, ``[0, 1]``) are the view's samples and ``loop_t`` the loop's
    parameter of each. A knot that is exactly a view sample maps to that sample's own
    ``loop_t``, not to the rounded sum: a knot the mend put on a sample (the join of a
    curvature jump, :mod:`toolpath.adaptive`) came back past it, the sample fell into the
    span before, and on a nose sampled one span apart the span after held no data point
    (Schoenberg-Whitney); every jump-knot mend failed so on a DCA-style TE beside the seam
    (``tests/toolpath/test_mend.py``, seed 62), left 1.1 um concave.
    """
    view_knots = np.asarray(view_knots, dtype=float)
    row = np.minimum(np.searchsorted(view_t, view_knots), view_t.size - 1)
    on_sample = view_t[row] == view_knots
    return np.where(on_sample, loop_t[row], np.mod(view_knots + cut_t, 1.0))


def adapt_closed_knots(points: NDArray[np.float64], t: NDArray[np.float64],
                       seed_values: NDArray[np.float64], fit_at, options, *,
                       seam: int = 1, fair_check=None):
    """:func:`toolpath.adaptive.adapt_knots` for a periodic fit (``fair_check`` as there).

    ``points`` ``(n + 1, d)`` and ``t`` end at the seam (the first point again, ``t = 1``);
    ``fit_at(periodic_knots, weights)`` fits on a periodic vector. The driver works on the
    clamped view (module docstring), cut open at :func:`closed_cut`: at the seam, or, when
    the seam lies on a dense nose, at the sparsest sample ``t_k`` (the view's ``t`` is
    ``(t − t_k) mod 1``, its interior knots are the periodic ones less ``t_k``; of the
    view's knots the one nearest the seam is moved onto it, the seam staying a knot).
    Counts are translated (``N`` periodic control points are ``N + DEGREE + 1 − seam``
    clamped ones) and the chosen knots returned periodic.
    """
    t = np.asarray(t, dtype=float)
    given = options.knots
    if given is not None and is_periodic(given):  # a periodic vector to use as it is
        problem = periodic_violation(t, given)
        if problem is not None:
            raise InvalidParameterError(f"knots cannot be fitted: {problem}")
        seam = int(np.sum(period_of(given) == 0.0))
        given = to_clamped(given)
    n = t.size - 1
    k = 0 if given is not None else closed_cut(t, seam)
    cut_t = float(t[k])
    order = np.r_[k:n, 0:k, k]  # the view's samples, from the cut round to it again
    view_t = np.r_[t[k:n] - cut_t, t[0:k] + 1.0 - cut_t, 1.0] if k else t
    back = np.argsort(order[:-1], kind="stable")  # view row of each original sample

    def on_loop(view_knots: NDArray[np.float64]) -> NDArray[np.float64]:
        return view_knots_on_loop(view_knots, view_t, t[order], cut_t)

    def to_period(knots: NDArray[np.float64]) -> NDArray[np.float64]:
        if k == 0:
            return from_clamped(knots, seam)
        inner = np.sort(np.r_[on_loop(interior_knots(np.asarray(knots, float))), cut_t])
        # the seam must be a knot (the stored vector's base interval starts there): the
        # view's simple knot nearest to it moves there, so the count stays the view's (a
        # copy of a corner's knot would leave the corner C1: on a propeller-style TE wedge
        # 0.008 mm from the seam that rounded the wedge and rang 2-3 um concave beyond it)
        _, where, copies = np.unique(inner, return_inverse=True, return_counts=True)
        simple = copies[where] == 1
        nearest = np.argsort(np.where(simple, 0.0, 1.0) + np.minimum(inner, 1.0 - inner))
        for j in nearest[:2]:
            moved = from_clamped(clamped_knots(np.delete(inner, j)), seam)
            if periodic_violation(t, moved) is None:
                return moved
        return from_clamped(clamped_knots(inner), seam)

    def to_view(knots: NDArray[np.float64]) -> NDArray[np.float64]:
        if not is_periodic(knots):
            return knots
        if k == 0:
            return to_clamped(knots)
        # the seam's knot is one the view moved there: left out (measured on the DCA
        # rotor, a search started from the view's knots with it ended unfair at one seam)
        return _cut_view(period_of(knots)[period_of(knots) > 0.0], cut_t)

    offset = DEGREE + 1 - seam
    start = options.start_knots
    corners = options.corners  # (the caller's, judged on the loop: moved into the view)
    if corners is not None and k:
        corners = tuple(Corner(float(np.mod(c.t - cut_t, 1.0)), c.angle_deg,
                               int(back[c.index % n])) for c in corners)
    driver = dataclasses.replace(
        options, knots=given, corners=corners,
        n_control_points=(None if options.n_control_points is None
                          else options.n_control_points + offset),
        max_control_points=(None if options.max_control_points is None
                            else options.max_control_points + offset),
        start_knots=None if start is None else to_view(start))

    def in_view(errors: NDArray[np.float64]) -> NDArray[np.float64]:
        return errors if k == 0 else np.asarray(errors)[order]

    def wrapped(knots: NDArray[np.float64], weights: NDArray[np.float64] | None):
        if weights is not None and k:
            weights = np.asarray(weights)[np.r_[back, back[0]]]  # original order
        fit, errors = fit_at(to_period(knots), weights)
        return fit, in_view(errors)

    def view_stretch(stretch):
        lo, hi, *rest = stretch
        lo, hi = (float(np.mod(v - cut_t, 1.0)) for v in (lo, hi))
        return (lo, hi if hi >= lo else 1.0, *rest)

    wrapped_check = None if fair_check is None else (
        lambda fit, knots: [view_stretch(s) if k else s
                            for s in fair_check(fit, to_period(knots))])
    view_points = np.asarray(points)[order] if k else points
    view_seed = np.asarray(seed_values)[order] if k else seed_values
    def counted(text: str) -> str:  # counts in messages are the driver's (clamped) ones
        return re.sub(r"(\d+) control points",
                      lambda m: f"{int(m.group(1)) - offset} control points", text)

    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ConvergenceWarning)
            fit, errors, knots = adapt_knots(view_points, view_t, view_seed, wrapped, driver,
                                             wrapped_check)
    except ToleranceNotReachedError as exc:
        raise ToleranceNotReachedError(
            counted(str(exc)), tol_mm=exc.tol_mm, best_mm=exc.best_mm,
            control_points=exc.control_points - offset) from None
    except FitError as exc:
        raise FitError(counted(str(exc))) from None
    for warning in caught:
        if issubclass(warning.category, UnfairFitWarning):  # (its order of fairness kept)
            warnings.warn(UnfairFitWarning(counted(str(warning.message)),
                                           warning.message.unfairness), stacklevel=3)
        elif issubclass(warning.category, ConvergenceWarning):
            warnings.warn(ConvergenceWarning(counted(str(warning.message))), stacklevel=3)
        else:
            reissue_warnings([warning])
    if k:
        errors = np.asarray(errors)[np.r_[back, back[0]]]
    return fit, errors, to_period(knots)
