"""Constant-coefficient streamline curves ``dX/dt = A X`` (paper Section 2).

The fitted curve is ``X(t) = expm(A t) X_0`` (eq. 3). ``A`` comes from one of four models:

- ``"P1-1"`` (eq. 9), two-point difference:
  ``min_A Σ_{i=1..n} ||X_i − X_{i−1} − Δt_i A X_i||²``;
- ``"P1-2"`` (eq. 10), three-point difference:
  ``min_A Σ_{i=1..n−1} ||α X_{i+1} + β X_i + γ X_{i−1} − δ A X_i||²`` with
  ``α = Δt_i²``, ``β = Δt_{i+1}² − Δt_i²``, ``γ = −Δt_{i+1}²``,
  ``δ = Δt_i Δt_{i+1} (Δt_i + Δt_{i+1})``;
- ``"P2"`` (eq. 13), trapezoid rule on the integral form:
  ``min_A Σ_{i=1..n} ||(I − Δt_i/2 A) X_i − (I + Δt_i/2 A) X_{i−1}||²``;
- ``"P0"`` (eq. 5), the exact model ``min_A Σ ||expm(A t_i) X_0 − X_i||²``, solved by
  nonlinear least squares (scipy.optimize.least_squares) started from P2, within
  :data:`P0_EVALUATIONS_PER_UNKNOWN` evaluations per unknown (a ``ConvergenceWarning``
  when that is not enough: the best ``A`` found is kept and its error reported).

P1 and P2 are linear least squares in the ``d²`` entries of ``A``: each residual is
``b_i − M_i a`` with ``a = vec(A)`` (row-major), and ``A x = (I ⊗ x^T) a``.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .arrays import as_curve_points
from .errors import ConvergenceWarning, InvalidParameterError
from .fit_methods import LINEAR_MODELS
from .parametrize import curve_parameters

__all__ = ["LINEAR_MODELS", "LinearSystemCurve", "fit_linear_system"]

#: P0's budget of residual evaluations, per unknown plus one (``d² + 1``: one forward
#: difference Jacobian): 20 Levenberg-Marquardt steps. The paper's curves need 1-7 steps
#: (Example 5: 33 evaluations of the 100 allowed in 2-D); scipy's default
#: (``100 d² (d² + 1)``, 9000 in 3-D) let points far from any ``dX/dt = A X`` (fuzzing:
#: four blade sections read as one curve) run for over ten minutes.
P0_EVALUATIONS_PER_UNKNOWN = 20
#: P0's stopping tolerances (``xtol``, ``ftol``, ``gtol`` of Levenberg-Marquardt, relative):
#: near round-off, against scipy's 1e-8, so the exact model is solved as far as doubles
#: allow; :data:`P0_EVALUATIONS_PER_UNKNOWN` bounds what that costs.
P0_STOP_TOL = 1e-14


@dataclass(frozen=True, eq=False)
class LinearSystemCurve:
    """The solution ``X(t) = expm(A t) X_0`` of ``dX/dt = A X`` (eqs. 2-3).

    Attributes
    ----------
    A : ndarray, shape (d, d)
        System matrix (1/parameter unit).
    x0 : ndarray, shape (d,)
        Initial point ``X(0)`` (mm), the first data point.
    params : ndarray, shape (n,)
        Parameter value of each data point.
    model : str
        The model that produced ``A``.
    max_error, rms_error : float
        Max and RMS distance (mm) between ``X(t_i)`` and the data points.
    """

    A: NDArray[np.float64]
    x0: NDArray[np.float64]
    params: NDArray[np.float64]
    model: str
    max_error: float
    rms_error: float

    def __call__(self, t: Any) -> NDArray[np.float64]:
        """Evaluate ``X(t) = expm(A t) X_0`` (eq. 3) at scalar or array ``t``.

        One batched matrix exponential over all ``t``; returns shape ``t.shape + (d,)``.
        """
        t = np.asarray(t, dtype=float)
        return _evaluate(self.A, self.x0, t.ravel()).reshape((*t.shape, self.x0.size))

    def derivative(self, t: Any, order: int = 1) -> NDArray[np.float64]:
        """Return ``d^k X/dt^k = A^k X(t)`` at ``t``, from the system itself."""
        if order not in (1, 2):
            raise InvalidParameterError(f"order must be 1 or 2, got {order!r}")
        x = self(t)
        ak = np.linalg.matrix_power(self.A, order)
        return x @ ak.T

    @property
    def n_control_points(self) -> int:
        """Degrees of freedom in the fit: the entries of ``A`` (``X_0`` is interpolated)."""
        return self.A.size

    def to_dict(self) -> dict[str, Any]:
        """Return a JSON-serializable description."""
        return {
            "kind": "linear_system",
            "model": self.model,
            "A": self.A.tolist(),
            "x0": self.x0.tolist(),
            "params": self.params.tolist(),
            "max_error": self.max_error,
            "rms_error": self.rms_error,
        }


def _evaluate(A: NDArray[np.float64], x0: NDArray[np.float64],
              t: NDArray[np.float64]) -> NDArray[np.float64]:
    """``expm(A t_k) X_0`` for every ``t_k``, as one batched ``expm`` call."""
    import scipy.linalg  # on first use: the CLI loads this module to list the models

    return scipy.linalg.expm(t[:, None, None] * A[None]) @ x0


def _rows(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Per point, the matrix ``M`` with ``A x = M vec(A)``: shape (m, d, d²)."""
    m, d = x.shape
    eye = np.eye(d)
    return (eye[None, :, :, None] * x[:, None, None, :]).reshape(m, d, d * d)


def _solve_linear(lhs: NDArray[np.float64], rhs: NDArray[np.float64], d: int):
    """Least squares ``min ||lhs a − rhs||`` over stacked (m, d, d²) blocks."""
    a, *_ = np.linalg.lstsq(lhs.reshape(-1, d * d), rhs.reshape(-1), rcond=None)
    return a.reshape(d, d)


def _fit_p11(x, t):
    dt = np.diff(t)
    lhs = dt[:, None, None] * _rows(x[1:])
    return _solve_linear(lhs, x[1:] - x[:-1], x.shape[1])


def _fit_p12(x, t):
    dt = np.diff(t)
    h0, h1 = dt[:-1], dt[1:]
    alpha, beta, gamma = h0**2, h1**2 - h0**2, -(h1**2)
    delta = h0 * h1 * (h0 + h1)
    rhs = alpha[:, None] * x[2:] + beta[:, None] * x[1:-1] + gamma[:, None] * x[:-2]
    lhs = delta[:, None, None] * _rows(x[1:-1])
    return _solve_linear(lhs, rhs, x.shape[1])


def _fit_p2(x, t):
    dt = np.diff(t)
    lhs = 0.5 * dt[:, None, None] * _rows(x[1:] + x[:-1])
    return _solve_linear(lhs, x[1:] - x[:-1], x.shape[1])


def _fit_p0(x, t, *, evaluations_per_unknown: int = P0_EVALUATIONS_PER_UNKNOWN):
    """P0 by Levenberg-Marquardt from P2, within ``evaluations_per_unknown * (d² + 1)``."""
    import scipy.optimize

    d = x.shape[1]
    start = _fit_p2(x, t)

    def residual(a):
        return (_evaluate(a.reshape(d, d), x[0], t) - x).ravel()

    budget = evaluations_per_unknown * (d * d + 1)
    result = scipy.optimize.least_squares(residual, start.ravel(), method="lm",
                                          xtol=P0_STOP_TOL, ftol=P0_STOP_TOL,
                                          gtol=P0_STOP_TOL, max_nfev=budget)
    if result.status == 0:  # the budget ran out
        warnings.warn(f"P0 stopped after {result.nfev} evaluations without converging; "
                      "the best A found is kept (these points are far from dX/dt = A X)",
                      ConvergenceWarning, stacklevel=3)
    return result.x.reshape(d, d)


_MODELS = {"P0": _fit_p0, "P1-1": _fit_p11, "P1-2": _fit_p12, "P2": _fit_p2}


def fit_linear_system(points: Any, *, model: str = "P2", params: Any = "chord"
                      ) -> LinearSystemCurve:
    """Fit ``dX/dt = A X`` through ordered points (paper Section 2, eqs. 5, 9, 10, 13).

    Parameters
    ----------
    points : array_like, shape (n, 2) or (n, 3)
        Ordered points (mm); ``X_0`` is the first.
    model : {"P2", "P1-1", "P1-2", "P0"}
        The least-squares model (see the module docstring).
    params : {"chord", "centripetal", "uniform"} or array_like
        Parameter values; chord length in [0, 1] by default (the reading that matches the
        paper's tables). An array (e.g. the true ODE time) is used as given.

    Returns
    -------
    LinearSystemCurve

    Examples
    --------
    >>> import numpy as np, scipy.linalg
    >>> A = np.array([[0.0, -1.0], [1.0, 0.0]])
    >>> t = np.linspace(0.0, 1.0, 50)
    >>> pts = scipy.linalg.expm(t[:, None, None] * A) @ np.array([1.0, 0.0])
    >>> curve = fit_linear_system(pts, model="P0", params=t)
    >>> bool(np.allclose(curve.A, A, atol=1e-8))
    True
    """
    if model not in _MODELS:
        raise InvalidParameterError(f"model must be one of {LINEAR_MODELS}, got {model!r}")
    x = as_curve_points(points, min_points=3)
    t = curve_parameters(x, params)
    if t[0] != 0.0:
        t = t - t[0]
    A = _MODELS[model](x, t)
    err = np.linalg.norm(_evaluate(A, x[0], t) - x, axis=1)
    return LinearSystemCurve(A=A, x0=x[0].copy(), params=t, model=model,
                             max_error=float(err.max()), rms_error=float(np.sqrt(np.mean(err**2))))
