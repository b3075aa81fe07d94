"""The baseline: a cubic B-spline fitted to the points directly, with the same knots logic.

``X(t) = Σ_j P_j N_j(t)`` with ``P_0 = X_0`` and ``P_{m−1} = X_n`` (end interpolation), the
interior control points by least squares, and the knots from :mod:`toolpath.adaptive`,
so it can run on exactly the knots the streamline fit uses. A closed curve is a periodic
cubic through ``X_0`` at the seam (:mod:`toolpath.periodic`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.interpolate
from numpy.typing import NDArray

from .adaptive import DEFAULT_SWEEPS, adapt_knots, knot_options
from .fairness import curve_fair_check
from .fitted_curve import FittedCurve, check_order, curve_data, error_figures
from .knots import DEFAULT_CORNER_ANGLE_DEG, seam_multiplicity
from .periodic import adapt_closed_knots
from .splinefit import DEGREE, end_interpolating_lsq

__all__ = ["BSplineCurve", "fit_bspline_curve"]


@dataclass(frozen=True, eq=False)
class BSplineCurve(FittedCurve):
    """A clamped cubic B-spline curve ``X(t)`` on [0, 1] (periodic when closed).

    Attributes
    ----------
    control_points : ndarray, shape (m, d)
        Control points (mm); the first and last are the first and last data points (closed:
        ``m = N + 3``, the last three repeating the first three).
    """

    control_points: NDArray[np.float64]

    @property
    def spline(self) -> scipy.interpolate.BSpline:
        """The curve as a scipy ``BSpline`` with vector coefficients."""
        return scipy.interpolate.BSpline(self.knots, self.control_points, DEGREE)

    def __call__(self, t: Any) -> NDArray[np.float64]:
        """Points ``X(t)`` (mm), shape ``t.shape + (d,)``."""
        return self.spline(np.asarray(t, dtype=float))

    def derivative(self, t: Any, order: int = 1) -> NDArray[np.float64]:
        """``d^k X / dt^k`` at ``t`` (mm per parameter unit^k)."""
        check_order(order)
        return self.spline(np.asarray(t, dtype=float), nu=order)

    def to_dict(self) -> dict[str, Any]:
        """JSON-serializable description; :meth:`from_dict` restores it exactly."""
        return {"kind": "bspline_curve", **self._common_dict(),
                "control_points": self.control_points.tolist()}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> BSplineCurve:
        """Rebuild from :meth:`to_dict` output."""
        return cls(control_points=np.asarray(data["control_points"], float),
                   **cls._common_fields(data))


def fit_bspline_curve(
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
    minimax: bool = True,
    fair: bool = True,
    closed: bool | None = False,
) -> BSplineCurve:
    """Fit an end-interpolating cubic B-spline to ordered points.

    Parameters
    ----------
    points : array_like, shape (n, 2) or (n, 3)
        Ordered points (mm).
    tol : float, optional
        Max distance (mm) allowed at the points; the fewest control points reaching it are
        searched. Exactly one of ``tol``, ``n_control_points`` and ``knots`` is given.
    n_control_points : int, optional
        Fit with this many control points (knots placed by ``knot_method``).
    max_control_points : int, optional
        Upper bound while searching for ``tol``.
    knots : array_like, optional
        A clamped cubic knot vector on [0, 1] to use exactly (closed: a periodic one, or a
        clamped one whose interior knots are used with a knot at the seam).
    params : {"chord", "centripetal", "uniform"} or array_like
        Parameters of the points in [0, 1] (closed: with one more for the return to the
        first point).
    knot_method : {"density", "dominant"}
        Knot placement (see :mod:`toolpath.knots`).
    corner_angle_deg : float or None
        Smallest turn (deg) considered for a corner; None disables corner knots.
    sweeps : int
        Error-equidistribution sweeps after the density seed.
    minimax : bool
        Polish each knot vector's least-squares fit towards the smallest max error
        (Lawson's reweighting); False gives the plain least-squares fit of eq. 19.
    fair : bool
        With ``tol``: tighten the fit where it turns concave between data that turn convex
        (:mod:`toolpath.fairness`) until it no longer does; a warning names what is left.
    closed : bool or None
        ``True``: a closed curve, fitted periodic (smooth across the seam); ``None``: read
        from how the points end (:mod:`toolpath.closure`, as ``toolpath fit curve`` does);
        ``False`` (default): open, through both end points (the paper's end conditions).

    Returns
    -------
    BSplineCurve

    Examples
    --------
    >>> import numpy as np
    >>> s = np.linspace(0, np.pi, 200)
    >>> curve = fit_bspline_curve(np.c_[np.cos(s), np.sin(s)] * 50.0, tol=0.001)
    >>> curve.max_error <= 0.001
    True
    """
    options = knot_options(tol=tol, n_control_points=n_control_points,
                           max_control_points=max_control_points, knots=knots,
                           knot_method=knot_method, corner_angle_deg=corner_angle_deg,
                           sweeps=sweeps, minimax=minimax)
    x, t, is_closed = curve_data(points, params, closed)

    def fit_at(knot_vector: NDArray[np.float64], weights: NDArray[np.float64] | None):
        spline = end_interpolating_lsq(t, x, knot_vector, weights)
        return spline.c, np.linalg.norm(spline(t) - x, axis=1)

    def make_curve(coef, knot_vector):
        return BSplineCurve(knots=knot_vector, params=t, max_error=0.0, rms_error=0.0,
                            control_points=np.asarray(coef), closed=is_closed)

    fair_check = (curve_fair_check(make_curve, x, options.tol, closed=is_closed)
                  if fair and options.tol else None)
    if is_closed:
        coef, errors, knot_vector = adapt_closed_knots(
            x, t, x, fit_at, options, seam=seam_multiplicity(x, corner_angle_deg),
            fair_check=fair_check)
        t, errors = t[:-1], errors[:-1]  # the seam point is the first again
    else:
        coef, errors, knot_vector = adapt_knots(x, t, x, fit_at, options, fair_check)
    max_error, rms_error = error_figures(errors)
    return BSplineCurve(knots=knot_vector, params=t, max_error=max_error, rms_error=rms_error,
                        control_points=np.asarray(coef), closed=is_closed)

