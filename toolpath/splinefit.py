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
    "admissible_knots",
    "clamped_knots",
    "end_interpolating_lsq",
    "interior_knots",
    "n_coefficients",
    "schoenberg_whitney_violation",
]

#: Cubic splines throughout (the paper's eq. 21 and the baseline).
DEGREE = 3
#: Weight of the control points' second differences in the least squares, relative to the
#: normal matrix's mean diagonal (see :func:`_add_tie_break`).
TIE_BREAK = 1e-9
#: Least Cholesky pivot, relative to its diagonal entry, of a well-posed least squares; a
#: smaller one means a control point the data barely see, and the tie-break takes over.
MIN_PIVOT = 1e-10
#: Between interior knots equally near the middle of an unpinned span, drop the one
#: nearest ``j + 2``: a weight per index this small only breaks ties (knots lie in [0, 1]).
_DROP_TIE_BREAK = 1e-12


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
    return _interlacing_violation(t, knots)


def _interlacing_violation(t: NDArray[np.float64], knots: NDArray[np.float64]) -> str | None:
    """The Schoenberg-Whitney condition proper, for the end-interpolating fit.

    The least squares is uniquely solvable iff data parameters ``t_{i_0} < ... < t_{i_{m-1}}``
    can be matched to the basis functions with ``N_j(t_{i_j}) > 0``, i.e.
    ``k_j < t_{i_j} < k_{j+4}`` for the interior ``j`` (``t_0`` and ``t_n`` go to the ends).
    Both bounds grow with ``j``, so taking for each ``j`` the first free parameter past
    ``k_j`` finds a matching whenever one exists. Every span holding a point is not enough:
    a corner knot of multiplicity 3 beside one sample leaves a control point free.
    """
    j = _unpinned(t, knots)
    if j is None:
        return None
    return (f"control point {j} is not pinned down by the data: its knot span "
            f"[{knots[j]:.6g}, {knots[j + DEGREE + 1]:.6g}] holds too few points "
            "(Schoenberg-Whitney condition); use fewer knots there")


def admissible_knots(t: NDArray[np.float64], knots: NDArray[np.float64]
                     ) -> NDArray[np.float64]:
    """``knots`` less the interior knots that leave a span or a control point without data.

    A knot span of non-zero length holding no data parameter loses one copy of its inner
    end (its right end, or its left at the last span) until none is empty. Then, where the
    Schoenberg-Whitney matching (see :func:`_interlacing_violation`) fails at
    control point ``j``, the interior knot nearest the middle of ``j``'s support is dropped,
    widening it, until every control point is pinned down (a corner knot beside one sample
    loses one of its copies). Knot vectors that already satisfy the condition come back
    unchanged.
    """
    knots = np.asarray(knots, float)
    k = DEGREE + 1
    while len(knots) > 2 * k:  # first no span without data: one copy of its inner end goes
        edges = np.unique(knots)
        empty = np.flatnonzero(np.histogram(t, bins=edges)[0] == 0)
        if empty.size == 0:
            break
        j = int(empty[0])
        value = edges[j + 1] if j + 1 < edges.size - 1 else edges[j]
        knots = np.delete(knots, int(np.flatnonzero(knots == value)[0]))
    while len(knots) > 2 * k:
        j = _unpinned(t, knots)
        if j is None:
            break
        inner = np.arange(k, len(knots) - k)
        middle = 0.5 * (knots[j] + knots[j + k])
        drop = inner[np.argmin(np.abs(knots[inner] - middle)
                               + _DROP_TIE_BREAK * np.abs(inner - j - 2))]
        knots = np.delete(knots, drop)
    return knots


def _unpinned(t: NDArray[np.float64], knots: NDArray[np.float64]) -> int | None:
    """The first control point the interlacing matching cannot give a data parameter.

    The greedy matching ``i_j = max(i_{j-1} + 1, first i with t_i > k_j)``, ``i_0 = 0``,
    is ``i_j = j + max_{l <= j} (s_l − l)``: one cumulative maximum.
    """
    m = n_coefficients(knots)
    j = np.arange(m - 1)
    first = np.searchsorted(t, knots[:m - 1], side="right")
    first[0] = 0
    i = j + np.maximum.accumulate(first - j)
    bad = (i >= t.size - 1) | (t[np.minimum(i, t.size - 1)] >= knots[j + DEGREE + 1])
    bad[0] = False
    return int(np.argmax(bad)) if bad.any() else None


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
        if _far_outside(coef, values):  # a near-null direction the pivots did not show
            raise np.linalg.LinAlgError("control points far outside the data")
    except np.linalg.LinAlgError:
        # (nearly) rank-deficient: among the fits the data can hardly tell apart, the fairest
        _add_tie_break(bands, rhs, coef[[0, -1]])
        try:
            coef[1:-1] = _solve_banded_normal(bands[:, 1:-1], rhs[1:-1], min_pivot=0.0)
        except np.linalg.LinAlgError:  # data too thin for some basis function: min-norm fit
            inner = basis.toarray()[:, 1:-1]
            root = np.sqrt(w)[:, None]
            coef[1:-1] = np.linalg.lstsq(inner * root, rhs_values * root, rcond=None)[0]
    return scipy.interpolate.BSpline(knots, coef, DEGREE, extrapolate=False)


def _far_outside(coef: NDArray[np.float64], values: NDArray[np.float64]) -> bool:
    """Whether a control point lies farther outside the data's bounding box than its size.

    A least-squares cubic's control polygon stays within a fraction of the box; one this
    far out means the normal equations were nearly singular along a direction the
    Cholesky pivots need not reveal (a decaying chain of control points near a clamped
    end: singular value 1.6e-10, least pivot ratio 2e-4, control points 5e3 out).
    """
    lo, hi = values.min(axis=0), values.max(axis=0)
    size = float((hi - lo).max())
    return bool(np.any(coef < lo - size) or np.any(coef > hi + size))


def _add_tie_break(bands: NDArray[np.float64], rhs: NDArray[np.float64],
                   ends: NDArray[np.float64]) -> None:
    """Add ``λ ||Δ² P||²`` (second differences of the control points) to the normal equations.

    ``λ = TIE_BREAK`` times the mean diagonal of ``B^T W B``: far below every well-determined
    direction, so a fit the data pin down moves by round-off, while a direction the data
    barely see (knots as dense as the samples, sites near the ends of their basis
    functions: singular values of 1e-17 on the half profile) takes the fairest control
    points instead of swinging by hundreds of mm between the samples. In place; the fixed
    end control points ``ends`` (2, d) move their terms to ``rhs``.
    """
    m = bands.shape[1]
    if m < 3:
        return
    lam = TIE_BREAK * float(bands[0, 1:-1].mean())
    r = np.arange(m - 2)  # row r of Δ² is P_r − 2 P_{r+1} + P_{r+2}
    diag = np.bincount(np.r_[r, r + 1, r + 2], weights=np.r_[np.ones(m - 2), np.full(m - 2, 4.0),
                                                               np.ones(m - 2)], minlength=m)
    off1 = np.bincount(np.r_[r, r + 1], weights=np.full(2 * (m - 2), -2.0), minlength=m)
    off2 = np.bincount(r, minlength=m).astype(float)
    bands[0] += lam * diag
    bands[1] += lam * off1
    bands[2] += lam * off2
    # interior rows coupled to the fixed ends: P[1, 0] = -2, P[2, 0] = 1 and mirrored
    rhs[1] -= lam * off1[0] * ends[0]
    rhs[2] -= lam * off2[0] * ends[0]
    rhs[m - 2] -= lam * off1[m - 2] * ends[1]
    rhs[m - 3] -= lam * off2[m - 3] * ends[1]


def _solve_banded_normal(bands: NDArray[np.float64], rhs: NDArray[np.float64], *,
                         min_pivot: float = MIN_PIVOT) -> NDArray[np.float64]:
    """Solve ``N c = r`` for the symmetric ``N`` given by its bands (``bands[o, j] = N[j, j+o]``).

    B-spline normal matrices are banded and, under the Schoenberg-Whitney condition,
    positive definite: a banded Cholesky solve costs O(m) instead of a dense QR. Raises
    ``LinAlgError`` when the matrix is not positive definite, or nearly not: a pivot
    ``u_jj² < min_pivot · N_jj`` (the control point is barely seen by the data).
    """
    m = bands.shape[1]
    if m == 0:
        return np.empty((0, rhs.shape[1]))
    upper = np.zeros((DEGREE + 1, m))
    for offset in range(min(DEGREE, m - 1) + 1):
        # upper form for cholesky_banded: ab[u + i - j, j] = a[i, j], i.e. N[j-o, j]
        upper[DEGREE - offset, offset:] = bands[offset, :m - offset]
    factor = scipy.linalg.cholesky_banded(upper)
    if np.any(factor[DEGREE] ** 2 < min_pivot * bands[0]):
        raise np.linalg.LinAlgError("nearly singular normal equations")
    return scipy.linalg.cho_solve_banded((factor, False), rhs)
