"""Streamline curves of a diagonalizable system ``dX/dt = T^{-1} D(t) T (X + c)`` (Alg. 3).

With ``G(t) = ∫_0^t D`` (eq. 16) the solution is

    ``X(t) = −c + T^{-1} exp(diag G(t)) T (X_0 + c)``                      (eq. 15, shifted)

so componentwise ``Z_k(t) = Z_{0,k} e^{G_k(t)}`` with ``Z = T (X + c)``. The fit:

1. parameters ``t_i`` (chord length in [0, 1]);
2. a frame ``(T, c)`` putting every ``Z_i`` in the positive cone (Algorithms 1, 2, plus a
   translation ``c``; the margin is chosen by fit error, see :mod:`toolpath.cone_frame`);
3. ``Y_i = log(Z_i / Z_0)`` componentwise;
4. each ``G_k`` a cubic B-spline (eq. 21) by least squares (eq. 19) with ``G(0) = 0``,
   ``G(1) = Y_n`` (eq. 20), on knots from :mod:`toolpath.adaptive`;
5. optionally, Gauss-Newton on the true error ``Σ ||X(t_i) − X_i||²`` over the interior
   control points of ``G`` (not in the paper: the log-space fit does not minimize it).

``D(t) = diag(G'(t))`` (eq. 22).

A closed curve has ``Y_n = 0`` (the last point is the first again), so ``G`` is a periodic
cubic with ``G(0) = 0`` kept exactly (:mod:`toolpath.periodic`): ``X`` is then periodic,
smooth across the seam, and ``X(0) = X_0``.
"""

from __future__ import annotations

import dataclasses
import functools
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np
import scipy.interpolate
import scipy.linalg
from numpy.typing import NDArray

from .adaptive import DEFAULT_SWEEPS, adapt_knots, check_given_knots, knot_options
from .bspline_curve import fit_bspline_curve
from .cone_frame import ConeFrame, candidate_frames, paper_frame
from .errors import (
    ConvergenceWarning,
    InvalidParameterError,
    LogRangeError,
    UnfairFitWarning,
    reissue_warnings,
)
from .fairness import curve_fair_check
from .fitted_curve import FittedCurve, check_order, curve_data, error_figures
from .knots import DEFAULT_CORNER_ANGLE_DEG, seam_multiplicity
from .periodic import adapt_closed_knots
from .splinefit import DEGREE, end_interpolating_lsq, n_coefficients

__all__ = ["FRAME_METHODS", "StreamlineCurve", "fit_in_frames", "fit_streamline_curve"]

_Fit = TypeVar("_Fit")

FRAME_METHODS = ("best", "paper")
#: Gauss-Newton steps of the true-error refinement; each one costs one dense lstsq.
REFINE_STEPS = 6
#: Cone frames tried, best first, when the knots the fit settles on make G leave the log
#: range in a frame chosen on the baseline's knots (:class:`LogRangeError`).
FRAME_TRIES = 3
#: Halvings of a Gauss-Newton step that raises the cost before the refinement stops.
REFINE_HALVINGS = 5
#: A Gauss-Newton trial is taken only when it lowers the cost by this share at least: a
#: smaller gain is round-off, and taking it would keep the refinement going for nothing.
_LEAST_DECREASE = 1e-9
#: Relative ridge on the normal matrix's diagonal: it keeps the banded Cholesky solve
#: defined where a direction has no data, and moves nothing else (round-off of the sums).
_RIDGE = 1e-12
#: How far (in natural log units) ``G``'s control points may leave the data's log range:
#: ``e^2.3 ≈ 10``, a fitted point ten times farther from the cone's apex (or closer to it)
#: than any data point is no fit; the fits of the paper's examples and the half profile
#: at 10-44 control points leave it by at most 0.25 (Ex 4 at 10), mostly by under 0.05.
LOG_MARGIN = float(np.log(10.0))


@dataclass(frozen=True, eq=False)
class StreamlineCurve(FittedCurve):
    """``X(t) = −c + T^{-1} exp(diag G(t)) T (X_0 + c)`` on [0, 1] (eq. 15, shifted by c).

    Attributes
    ----------
    T : ndarray, shape (d, d)
        Constant invertible matrix diagonalizing the system (scaled to unit 2-norm).
    c : ndarray, shape (d,)
        Translation (mm) putting the data in T's positive cone (zero when not needed).
    x0 : ndarray, shape (d,)
        ``X(0)``, the first data point (mm).
    g_coefficients : ndarray, shape (m, d)
        Control points of ``G`` (dimensionless; first row 0).
    frame_label : str
        How ``(T, c)`` was chosen.
    """

    T: NDArray[np.float64]
    c: NDArray[np.float64]
    x0: NDArray[np.float64]
    g_coefficients: NDArray[np.float64]
    frame_label: str = ""

    @property
    def G(self) -> scipy.interpolate.BSpline:
        """``G(t) = ∫_0^t D`` as a cubic scipy ``BSpline`` with vector coefficients."""
        return scipy.interpolate.BSpline(self.knots, self.g_coefficients, DEGREE)

    @property
    def z0(self) -> NDArray[np.float64]:
        """``T (X_0 + c)``: the start point in the cone frame."""
        return self.T @ (self.x0 + self.c)

    def D(self, t: Any) -> NDArray[np.float64]:
        """``D(t) = diag(G'(t))`` (eq. 22), shape ``t.shape + (d, d)``."""
        g1 = self.G(np.asarray(t, float), nu=1)
        return g1[..., :, None] * np.eye(g1.shape[-1])

    def _weights(self, t: Any) -> NDArray[np.float64]:
        return self.z0 * np.exp(self.G(np.asarray(t, float)))

    def __call__(self, t: Any) -> NDArray[np.float64]:
        """Points ``X(t)`` (mm), shape ``t.shape + (d,)``."""
        return self._weights(t) @ np.linalg.inv(self.T).T - self.c

    def derivative(self, t: Any, order: int = 1) -> NDArray[np.float64]:
        """Derivatives from the system itself.

        ``X' = T^{-1} D(t) T (X + c)`` and
        ``X'' = T^{-1} (D' + D²) T (X + c)``, i.e. per component of ``Z``:
        ``Z' = Z G'`` and ``Z'' = Z (G'' + G'^2)``.
        """
        check_order(order)
        t = np.asarray(t, float)
        g1 = self.G(t, nu=1)
        factor = g1 if order == 1 else self.G(t, nu=2) + g1**2
        return (self._weights(t) * factor) @ np.linalg.inv(self.T).T

    def to_dict(self) -> dict[str, Any]:
        """JSON-serializable description; :meth:`from_dict` restores it exactly."""
        return {"kind": "streamline_curve", **self._common_dict(), "T": self.T.tolist(),
                "c": self.c.tolist(), "x0": self.x0.tolist(),
                "g_coefficients": self.g_coefficients.tolist(),
                "frame_label": self.frame_label}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> StreamlineCurve:
        """Rebuild from :meth:`to_dict` output."""
        return cls(T=np.asarray(data["T"], float), c=np.asarray(data["c"], float),
                   x0=np.asarray(data["x0"], float),
                   g_coefficients=np.asarray(data["g_coefficients"], float),
                   frame_label=str(data.get("frame_label", "")), **cls._common_fields(data))


@dataclass(frozen=True)
class LogSpaceProblem:
    """The data seen in one cone frame: ``Y_i = log(Z_i / Z_0)``."""

    x: NDArray[np.float64]
    t: NDArray[np.float64]
    frame: ConeFrame

    @functools.cached_property
    def z(self) -> NDArray[np.float64]:
        return self.frame.to_cone(self.x)

    @functools.cached_property
    def y(self) -> NDArray[np.float64]:
        z = self.z
        return np.log(z / z[0])

    def points_from_g(self, g_values: NDArray[np.float64]) -> NDArray[np.float64]:
        return (self.z[0] * np.exp(g_values)) @ np.linalg.inv(self.frame.T).T - self.frame.c

    def fit(self, knots: NDArray[np.float64], refine: bool,
            weights: NDArray[np.float64] | None = None):
        spline = end_interpolating_lsq(self.t, self.y, knots, weights)
        coef = spline.c
        check_log_range(coef, self.y, knots)
        if refine:
            coef = self._refine(knots, coef, weights)
        g_values = scipy.interpolate.BSpline(knots, coef, DEGREE)(self.t)
        return coef, np.linalg.norm(self.points_from_g(g_values) - self.x, axis=1)

    def _refine(self, knots: NDArray[np.float64], coef: NDArray[np.float64],
                weights: NDArray[np.float64] | None) -> NDArray[np.float64]:
        """Gauss-Newton on ``Σ w_i ||X(t_i) − X_i||²`` over interior coefficients of G.

        ``∂X_i/∂P_{jk} = T^{-1}[:, k] Z_{0k} e^{G_k(t_i)} N_j(t_i)``. A step is halved
        until it lowers the cost and keeps ``G`` within :data:`LOG_MARGIN` of the data (at
        most :data:`REFINE_HALVINGS` times); the best coefficients are returned, so the
        refinement never leaves the log-space fit for a worse or unbounded one. Each step
        solves the banded normal equations (:func:`_gauss_newton_step`): O(m), not a dense
        least squares of the whole Jacobian.
        """
        design = scipy.interpolate.BSpline.design_matrix(self.t, knots, DEGREE)
        basis = design.toarray()
        local = design.data.reshape(self.t.size, DEGREE + 1)
        first = design.indices.reshape(self.t.size, DEGREE + 1)[:, 0]
        t_inv = np.linalg.inv(self.frame.T)
        z0 = self.z[0]
        root = np.ones(self.t.size) if weights is None else np.sqrt(weights)
        lo, hi = _log_bounds(self.y)

        def residual_of(c: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray]:
            w = z0 * np.exp(basis @ c)  # (n, d)
            return (w @ t_inv.T - self.frame.c - self.x) * root[:, None], w

        best = coef.copy()
        residual, w = residual_of(best)
        cost = float(np.sum(residual**2))
        for _ in range(REFINE_STEPS):
            try:
                step = _gauss_newton_step(local, first, best.shape[0], t_inv,
                                          w * root[:, None], residual)
            except np.linalg.LinAlgError:
                break
            for halving in range(REFINE_HALVINGS + 1):
                trial = best.copy()
                trial[1:-1] += step * 0.5**halving
                if np.all((trial >= lo) & (trial <= hi)):
                    trial_residual, trial_w = residual_of(trial)
                    trial_cost = float(np.sum(trial_residual**2))
                    if trial_cost < cost * (1 - _LEAST_DECREASE):
                        best, residual, w, cost = trial, trial_residual, trial_w, trial_cost
                        break
            else:
                break  # no step lowers the cost: converged
        return best


def _gauss_newton_step(local: NDArray[np.float64], first: NDArray[np.int64], m: int,
                       t_inv: NDArray[np.float64], w: NDArray[np.float64],
                       residual: NDArray[np.float64]) -> NDArray[np.float64]:
    """The Gauss-Newton step ``δ`` (m − 2, d) of the interior control points of ``G``.

    With ``J[(i, a), (j, k)] = T^{-1}[a, k] w_ik N_j(t_i)`` (``w`` the weighted
    ``Z_0 e^G``), ``J^T J δ = −J^T r`` where ``(J^T J)[(j, k), (j', k')] =
    Σ_i N_j N_j' w_ik w_ik' (T^{-T} T^{-1})[k, k']`` is banded: unknowns ordered
    ``u = (j − 1) d + k`` couple only within ``4d − 1``. ``local``/``first``: each data
    point's ``DEGREE + 1`` basis values and the index of the first. A relative
    :data:`_RIDGE` on the diagonal keeps the solve defined where a direction has no data.
    """
    d = w.shape[1]
    size = (m - 2) * d
    band = (DEGREE + 1) * d - 1
    gram = t_inv.T @ t_inv
    along = residual @ t_inv  # (J^T r) before the basis: Σ_a T^{-1}[a, k] r_ia
    upper = np.zeros((band + 1, size))
    rhs = np.zeros(size)
    for a in range(DEGREE + 1):
        j = first + a
        inside_a = (j >= 1) & (j <= m - 2)
        for k in range(d):
            u = (j - 1) * d + k
            np.add.at(rhs, u[inside_a], -(local[:, a] * w[:, k] * along[:, k])[inside_a])
            for b in range(DEGREE + 1):
                jb = first + b
                for kb in range(d):
                    ub = (jb - 1) * d + kb
                    keep = inside_a & (jb >= 1) & (jb <= m - 2) & (u <= ub)
                    value = local[:, a] * local[:, b] * w[:, k] * w[:, kb] * gram[k, kb]
                    np.add.at(upper, (band + u[keep] - ub[keep], ub[keep]), value[keep])
    upper[band] += _RIDGE * upper[band].max()
    return scipy.linalg.solveh_banded(upper, rhs).reshape(m - 2, d)


def _log_bounds(y: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per component, the range ``G``'s control points may take: the data's, ± LOG_MARGIN."""
    return y.min(axis=0) - LOG_MARGIN, y.max(axis=0) + LOG_MARGIN


def check_log_range(coef: NDArray[np.float64], y: NDArray[np.float64],
                    knots: NDArray[np.float64]) -> None:
    """Raise :class:`LogRangeError` if ``G``'s control points leave the data's log range.

    ``G`` lies in the convex hull of its control points, so bounding them bounds
    ``exp(G)`` everywhere on [0, 1]: the fitted curve then stays within a factor
    ``e^LOG_MARGIN`` of the data's extent in the cone frame and ``exp`` cannot overflow.
    ``y`` holds the log-space data ``(n, d)``; ``coef`` the control points ``(m, d)``
    (both may stack several sections side by side).
    """
    lo, hi = _log_bounds(y)
    outside = np.maximum(lo - coef, coef - hi).max(axis=1)
    if outside.max() > 0:
        j = int(np.argmax(outside))
        raise LogRangeError(
            f"the streamline fit swings out of the data's range near t = "
            f"{knots[j + 2]:.4g} (log-space control point {j} is {outside[j]:.3g} beyond "
            f"the data's log range widened by {LOG_MARGIN:.3g}): the knots are too dense "
            "for the data there, or the cone frame is near-singular; use fewer knots there")


def _ranked_frames(x: NDArray[np.float64], t: NDArray[np.float64],
                   knots: NDArray[np.float64]) -> list[ConeFrame]:
    """The candidate frames, best first by the max error of their log-space fit on ``knots``.

    ``knots`` should be about as many as the final fit will have (the best margin depends on
    it): the caller passes the B-spline baseline's knots for the same request. Frames whose
    fit leaves the log range (:func:`check_log_range`) are left out.

    Raises
    ------
    LogRangeError
        When no candidate frame fits on ``knots``, with the last candidate's reason.
    """
    scored, failure = [], None
    for candidate in candidate_frames(x):
        try:
            _, errors = LogSpaceProblem(x, t, candidate).fit(knots, refine=False)
        except LogRangeError as exc:
            failure = exc
            continue
        scored.append((float(errors.max()), len(scored), candidate))
    if scored:
        return [frame for *_, frame in sorted(scored, key=lambda item: item[:2])]
    if failure is not None:
        raise LogRangeError(f"no cone frame gives a streamline fit on {n_coefficients(knots)} "
                            f"control points: {failure}")
    return [paper_frame(x)]  # candidate_frames always yields translated frames for sane data


def fit_in_frames(frames: list[ConeFrame], fit_in: Callable[[ConeFrame], _Fit]
                  ) -> tuple[ConeFrame, _Fit]:
    """``fit_in(frame)`` in the first of ``frames`` (best first) in range and fair.

    The frames are ranked on the baseline's knots; the knots the fit settles on may still
    make ``G`` leave the data's log range in one (:class:`LogRangeError`), and the next
    one is tried then. A fit that stays unfair after its knots were mended
    (:class:`~toolpath.errors.UnfairFitWarning`) gives way to the next frame's too, and
    when no frame's fit is fair the fairest stands, with its warnings: points that scatter
    a micrometre about the blade, fitted on knots nearly as dense as they stand, may dent
    in one frame where the next is fair (the blunt rotor with 1 um of scatter: 13 um
    concave midway between its first two sections in the best-ranked frame, fair in the
    second). Curves and surfaces both fit this way.

    Raises
    ------
    LogRangeError
        The last frame's, when every frame leaves the log range.
    """
    kept: tuple | None = None  # (unfairness, frame, fit, warnings) of the fairest so far
    failure: LogRangeError | None = None
    for frame in frames:
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                fit = fit_in(frame)
        except LogRangeError as exc:
            failure = exc  # (the last one names the stretch)
            continue
        unfair = [w.message.unfairness for w in caught
                  if issubclass(w.category, UnfairFitWarning)]
        if not unfair:
            kept = ((), frame, fit, caught)
            break
        if kept is None or max(unfair) < kept[0]:
            kept = (max(unfair), frame, fit, caught)
    if kept is None:
        if failure is not None:
            raise failure
        raise InvalidParameterError("no cone frame to fit in")
    _, frame, fit, caught = kept
    reissue_warnings(caught)
    return frame, fit


def fit_streamline_curve(
    points: Any,
    *,
    tol: float | None = None,
    n_control_points: int | None = None,
    max_control_points: int | None = None,
    knots: Any = None,
    params: Any = "chord",
    knot_method: str = "density",
    corner_angle_deg: float | None = DEFAULT_CORNER_ANGLE_DEG,
    sweeps: int = DEFAULT_SWEEPS,
    frame: str = "best",
    refine: bool = False,
    minimax: bool = True,
    fair: bool = True,
    closed: bool | None = False,
) -> StreamlineCurve:
    """Fit a streamline curve of a diagonalizable system to ordered points (Algorithm 3).

    Parameters
    ----------
    points : array_like, shape (n, 2) or (n, 3)
        Ordered points (mm). Curves through or around the origin are fine (a translation
        ``c`` is added).
    tol : float, optional
        Max distance (mm) allowed at the points; the fewest control points of ``G``
        reaching it are searched. Exactly one of ``tol``, ``n_control_points``, ``knots``.
    n_control_points : int, optional
        Fit with this many control points per component of ``G``.
    max_control_points : int, optional
        Upper bound while searching for ``tol``.
    knots : array_like, optional
        A clamped cubic knot vector on [0, 1] to use exactly (e.g. a B-spline fit's);
        closed: a periodic one, or a clamped one whose interior knots are used.
    params : {"chord", "centripetal", "uniform"} or array_like
        Parameters of the points, mapped to [0, 1].
    knot_method : {"density", "dominant"}
        ``"density"``: corners + ``|f''''|^{1/4}`` equidistribution + error sweeps;
        ``"dominant"``: the paper's dominant points (Park & Lee).
    corner_angle_deg : float or None
        Smallest turn (deg) considered for a corner; None disables corner knots.
    sweeps : int
        Error-equidistribution sweeps per knot count.
    frame : {"best", "paper"}
        ``"best"``: the candidate frame with the smallest fit error on the knots the
        B-spline baseline needs for the same request; ``"paper"``: T = I in
        one octant, else Algorithm 1 with η = 0.05 or Algorithm 2 with ρ from the cone bound.
    refine : bool
        Minimize the true error ``Σ ||X(t_i) − X_i||²`` (Gauss-Newton) at every knot vector.
    minimax : bool
        Polish each knot vector's fit towards the smallest max error (Lawson's
        reweighting); False gives the plain least-squares fit of eq. 19.
    fair : bool
        With ``tol``: tighten the fit where it turns concave between data that turn convex
        (:mod:`toolpath.fairness`) until it no longer does; a warning names what is left.
    closed : bool or None
        ``True``: a closed curve, ``G`` periodic, the fit smooth across the seam; ``None``:
        read from how the points end (:mod:`toolpath.closure`, as ``toolpath fit curve``
        does); ``False`` (default): open, eq. 20's end conditions. Closed, ``knots`` and
        ``params`` follow :func:`toolpath.fit_bspline_curve`'s closed form.

    Returns
    -------
    StreamlineCurve

    Examples
    --------
    >>> import numpy as np
    >>> s = np.linspace(0, np.pi, 200)
    >>> curve = fit_streamline_curve(np.c_[np.cos(s), np.sin(s)] * 50.0, tol=0.001)
    >>> curve.max_error <= 0.001
    True
    """
    if frame not in FRAME_METHODS:
        raise InvalidParameterError(f"frame must be one of {FRAME_METHODS}, got {frame!r}")
    options = knot_options(tol=tol, n_control_points=n_control_points,
                           max_control_points=max_control_points, knots=knots,
                           knot_method=knot_method, corner_angle_deg=corner_angle_deg,
                           sweeps=sweeps, minimax=minimax)
    x, t, is_closed = curve_data(points, params, closed)
    if is_closed and refine:
        raise InvalidParameterError("refine is available for open curves only, not closed ones")
    if frame == "paper":
        frames = [paper_frame(x)]
    else:
        probe = options.knots
        if probe is not None:
            if not is_closed:  # a closed fit checks its periodic knots itself
                check_given_knots(t, probe)  # before the frames are tried on them
        else:
            with warnings.catch_warnings():  # the fit itself says what its probe would
                warnings.simplefilter("ignore", ConvergenceWarning)
                probe = fit_bspline_curve(x, tol=tol, n_control_points=n_control_points,
                                          max_control_points=max_control_points, params=t,
                                          knot_method=knot_method,
                                          corner_angle_deg=corner_angle_deg, sweeps=sweeps,
                                          minimax=False, fair=False, closed=is_closed).knots
        frames = _ranked_frames(x, t, probe)[:FRAME_TRIES]
        if options.knots is None and options.method == "density":
            # the baseline's knots for the same request: start the search there
            options = dataclasses.replace(options, start_knots=probe)
    seam = seam_multiplicity(x, corner_angle_deg) if is_closed else 1

    def fit_in(frame: ConeFrame):
        problem = LogSpaceProblem(x, t, frame)

        def make_curve(coef, knot_vector):
            return StreamlineCurve(knots=knot_vector, params=t, max_error=0.0, rms_error=0.0,
                                   T=frame.T, c=frame.c, x0=x[0].copy(),
                                   g_coefficients=np.asarray(coef), closed=is_closed)

        fair_check = (curve_fair_check(make_curve, x, options.tol, closed=is_closed)
                      if fair and options.tol else None)
        if is_closed:
            return adapt_closed_knots(x, t, problem.y,
                                      lambda k, w: problem.fit(k, refine, w), options,
                                      seam=seam, fair_check=fair_check)
        return adapt_knots(x, t, problem.y, lambda k, w: problem.fit(k, refine, w), options,
                           fair_check)

    chosen, (coef, errors, knot_vector) = fit_in_frames(frames, fit_in)
    if is_closed:
        t, errors = t[:-1], errors[:-1]  # the seam point is the first again
    max_error, rms_error = error_figures(errors)
    return StreamlineCurve(knots=knot_vector, params=t, max_error=max_error,
                           rms_error=rms_error, T=chosen.T, c=chosen.c,
                           x0=x[0].copy(), g_coefficients=np.asarray(coef),
                           frame_label=chosen.label, closed=is_closed)
