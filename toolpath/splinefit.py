"""Cubic B-spline least squares with end interpolation, shared by every curve fitter.

A clamped cubic ``S(t) = Σ_j P_j N_j(t)`` on ``[0, 1]`` has ``S(0) = P_0`` and
``S(1) = P_{m−1}``, so the end conditions (the paper's eq. 20, ``G(0) = 0``,
``G(1) = Y_n``; or ``X(0) = X_0``, ``X(1) = X_n`` for the baseline) fix the first and last
coefficients, and the interior ones solve the linear least squares of eq. 19:
``min Σ_i w_i ||S(t_i) − V_i||²``.
"""

from __future__ import annotations

import numpy as np
import scipy.interpolate
import scipy.linalg
from numpy.typing import NDArray

from .errors import FitError

__all__ = [
    "DEGREE",
    "clamped_knots",
    "end_interpolating_lsq",
    "interior_knots",
    "n_coefficients",
    "schoenberg_whitney_violation",
]

#: Cubic splines throughout (the paper's eq. 21 and the baseline).
DEGREE = 3


def clamped_knots(interior: NDArray[np.float64], lo: float = 0.0, hi: float = 1.0
                  ) -> NDArray[np.float64]:
    """Full knot vector: ``lo`` and ``hi`` repeated ``DEGREE + 1`` times around ``interior``."""
    k = DEGREE + 1
    return np.concatenate((np.full(k, lo), np.sort(np.asarray(interior, float)), np.full(k, hi)))


def interior_knots(knots: NDArray[np.float64]) -> NDArray[np.float64]:
    """The interior knots (with multiplicity) of a clamped cubic knot vector."""
    return np.asarray(knots[DEGREE + 1:-(DEGREE + 1)])


def n_coefficients(knots: NDArray[np.float64]) -> int:
    """Number of control points of a cubic spline on ``knots``."""
    return len(knots) - DEGREE - 1


def schoenberg_whitney_violation(t: NDArray[np.float64], knots: NDArray[np.float64]
                                 ) -> str | None:
    """Return why the data parameters ``t`` cannot determine a spline on ``knots``, or None.

    Checked: the knot vector is clamped on ``[t_0, t_n]``, non-decreasing, no interior knot
    has multiplicity above ``DEGREE``, and every knot span of non-zero length holds at least
    one data parameter (so no control point floats free between the samples).
    """
    k = DEGREE + 1
    if len(knots) < 2 * k:
        return f"a cubic knot vector needs at least {2 * k} knots, got {len(knots)}"
    if np.any(np.diff(knots) < 0):
        return "knots must be non-decreasing"
    if not (np.all(knots[:k] == knots[0]) and np.all(knots[-k:] == knots[-1])):
        return f"knots must be clamped: the first and last {k} knots repeated"
    if not (np.isclose(knots[0], t[0]) and np.isclose(knots[-1], t[-1])):
        return (f"knots span [{knots[0]!r}, {knots[-1]!r}] but the parameters span "
                f"[{t[0]!r}, {t[-1]!r}]")
    inner = interior_knots(knots)
    if inner.size:
        _, counts = np.unique(inner, return_counts=True)
        if counts.max() > DEGREE:
            return f"an interior knot repeats {counts.max()} times; at most {DEGREE} allowed"
    edges = np.unique(knots)
    held = np.histogram(t, bins=edges)[0]
    if (held == 0).any():
        j = int(np.argmax(held == 0))
        return (f"knot span [{edges[j]:.6g}, {edges[j + 1]:.6g}] holds no data point "
                "(Schoenberg-Whitney condition); use fewer knots there")
    n_coef = n_coefficients(knots)
    if t.size < n_coef:
        return f"{n_coef} control points need at least as many points, got {t.size}"
    return None


def end_interpolating_lsq(
    t: NDArray[np.float64],
    values: NDArray[np.float64],
    knots: NDArray[np.float64],
    weights: NDArray[np.float64] | None = None,
) -> scipy.interpolate.BSpline:
    """Least-squares cubic spline on ``knots`` through ``values[0]`` and ``values[-1]``.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Increasing parameters with ``t[0] = knots[0]`` and ``t[-1] = knots[-1]``.
    values : ndarray, shape (n, d)
        Values to fit.
    knots : ndarray
        Clamped cubic knot vector.
    weights : ndarray, shape (n,), optional
        Non-negative weights ``w_i`` of the squared residuals.

    Returns
    -------
    scipy.interpolate.BSpline
        With vector coefficients of shape ``(n_coef, d)``; ``S(t_0) = values[0]`` and
        ``S(t_n) = values[-1]`` hold exactly.

    A periodic ``knots`` (a closed curve, :mod:`toolpath.periodic`) gives the periodic fit
    through ``values[0]`` at the seam instead.
    """
    from .periodic import is_periodic, periodic_lsq  # periodic builds on this module

    if is_periodic(knots):
        return periodic_lsq(t, values, knots, weights)
    problem = schoenberg_whitney_violation(t, knots)
    if problem is not None:
        raise FitError(problem)
    basis = scipy.interpolate.BSpline.design_matrix(t, knots, DEGREE)
    n_coef = basis.shape[1]
    coef = np.empty((n_coef, values.shape[1]))
    coef[0], coef[-1] = values[0], values[-1]
    w = np.ones(t.size) if weights is None else np.asarray(weights, dtype=float)
    # every row of the design matrix holds DEGREE + 1 consecutive basis values
    local = basis.data.reshape(t.size, DEGREE + 1)
    first = basis.indices.reshape(t.size, DEGREE + 1)[:, 0]
    ends = np.zeros((t.size, 2))
    ends[:, 0] = np.where(first == 0, local[:, 0], 0.0)
    ends[:, 1] = np.where(first + DEGREE == n_coef - 1, local[:, DEGREE], 0.0)
    rhs_values = values - ends @ coef[[0, -1]]
    weighted = local * w[:, None]
    # banded normal matrix N = B^T W B: band o holds N[j, j + o]
    bands = np.zeros((DEGREE + 1, n_coef))
    for offset in range(DEGREE + 1):
        for a in range(DEGREE + 1 - offset):
            bands[offset] += np.bincount(first + a, weights=weighted[:, a] * local[:, a + offset],
                                         minlength=n_coef)
    rhs = basis.T @ (w[:, None] * rhs_values)  # B^T W v, the sparse product
    try:
        coef[1:-1] = _solve_banded_normal(bands[:, 1:-1], rhs[1:-1])
    except np.linalg.LinAlgError:
        # rank-deficient (data too thin for some basis function): QR gives the min-norm fit
        inner = basis.toarray()[:, 1:-1]
        root = np.sqrt(w)[:, None]
        coef[1:-1] = np.linalg.lstsq(inner * root, rhs_values * root, rcond=None)[0]
    return scipy.interpolate.BSpline(knots, coef, DEGREE, extrapolate=False)


def _solve_banded_normal(bands: NDArray[np.float64], rhs: NDArray[np.float64]
                         ) -> NDArray[np.float64]:
    """Solve ``N c = r`` for the symmetric ``N`` given by its bands (``bands[o, j] = N[j, j+o]``).

    B-spline normal matrices are banded and, under the Schoenberg-Whitney condition,
    positive definite: a banded Cholesky solve costs O(m) instead of a dense QR. Raises
    ``LinAlgError`` when the matrix is not positive definite.
    """
    m = bands.shape[1]
    if m == 0:
        return np.empty((0, rhs.shape[1]))
    upper = np.zeros((DEGREE + 1, m))
    for offset in range(min(DEGREE, m - 1) + 1):
        # upper form for solveh_banded: ab[u + i - j, j] = a[i, j], i.e. N[j-o, j]
        upper[DEGREE - offset, offset:] = bands[offset, :m - offset]
    return scipy.linalg.solveh_banded(upper, rhs)
