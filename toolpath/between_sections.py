"""How far a fitted surface may be from the blade *between* its sections: an estimate.

The blade between sections is unknown; what is known is the data, and a smooth blade
between the sections differs from the cubic interpolant of the data across ``s`` by about
Hall's bound for cubic spline interpolation, ``5/384 h_j^4 |f''''|`` on the interval of
spacing ``h_j``, with ``f''''`` along ``s`` read from the grid itself: the fourth divided
differences of each column over five consecutive sections (times ``4! = 24``), the largest
over the windows that contain the interval (the end intervals have only the windows at
the end). So the estimate is

    ``max |X - D| + max_j 5/384 h_j^4 |f''''|_j``  (mm),

with ``D`` the **data surface** (each section's interpolating cubic along ``t`` through its
grid row, those interpolated across ``s`` by not-a-knot cubics, as the fitted rows are)
and ``|X - D|`` taken midway between the sections, at every column and midway between
columns: where the fit's own error, carried across the sections, goes.

Measured against the truth (``tests/toolpath/test_section_matching.py``: the DCA rotor's
truth contours midway between its sections; ``benchmarks/blade_truth.py``: the dev
blade's analytic surface), tol 0.003, 0.01 and 0.03 mm, both methods, open and closed:
estimate / true error 0.98-1.41. Sections that are not matched (column ``i`` joining a
nose point to a flank point) show as a large fourth difference. The leave-one-out error
(a section left out and interpolated from the others, twice the spacing) overstates all
this by up to ``2^4``, and far more where sections are not matched.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.interpolate
from numpy.typing import NDArray

from .sections import Sections
from .splinefit import DEGREE
from .tensor_spline import interpolate_across

__all__ = ["INTERPOLATION_CONSTANT", "between_sections_estimate", "fit_errors_between",
           "interpolation_errors"]

#: Hall's constant: ``|f - cubic spline interpolant| <= 5/384 h^4 max|f''''|``.
INTERPOLATION_CONSTANT = 5.0 / 384.0
#: Sections in a fourth divided difference.
WINDOW = 5


def _fourth_derivative(s: NDArray[np.float64], points: NDArray[np.float64]
                       ) -> NDArray[np.float64]:
    """``|f''''|`` (mm per unit ``s`` to the 4th) per window of five sections, ``(m - 4, N)``."""
    m = len(s)
    out = np.empty((m - WINDOW + 1, points.shape[1]))
    for w in range(m - WINDOW + 1):
        dd = points[w:w + WINDOW]
        nodes = s[w:w + WINDOW]
        for k in range(1, WINDOW):
            dd = (dd[1:] - dd[:-1]) / (nodes[k:] - nodes[:-k])[:, None, None]
        out[w] = 24.0 * np.linalg.norm(dd[0], axis=-1)
    return out


def interpolation_errors(s: NDArray[np.float64], points: NDArray[np.float64], *,
                         centred: bool = False) -> NDArray[np.float64]:
    """Estimated cubic interpolation error across ``s`` per interval and column, mm.

    Parameters
    ----------
    s : ndarray, shape (m,)
        Section parameters, increasing (``m >= 5``; fewer give zeros: no fourth difference).
    points : ndarray, shape (m, N, 3)
        The grid: every section at every column (mm).

    centred : bool
        Only the (one or two) windows with interval ``j`` in their middle, not all four
        containing it: a nose's fourth differences then do not spill onto the intervals
        two samples away (:mod:`toolpath.between_data`).

    Returns
    -------
    ndarray, shape (m - 1, N)
        ``5/384 h_j^4 max |f''''|`` over the windows containing interval ``j``.
    """
    s = np.asarray(s, dtype=float)
    m = len(s)
    if m < WINDOW:
        return np.zeros((max(m - 1, 0), points.shape[1]))
    d4 = _fourth_derivative(s, points)
    out = np.empty((m - 1, points.shape[1]))
    for j in range(m - 1):
        first = max(0, j + 1 - (WINDOW - 1))
        last = min(j, m - WINDOW)
        if centred:
            first, last = (int(np.clip(k, 0, m - WINDOW)) for k in (j - 2, j - 1))
        out[j] = INTERPOLATION_CONSTANT * (s[j + 1] - s[j]) ** 4 * d4[first:last + 1].max(axis=0)
    return out


def _midpoints(x: NDArray[np.float64]) -> NDArray[np.float64]:
    return 0.5 * (x[1:] + x[:-1])


def fit_errors_between(surface: Callable[..., NDArray[np.float64]], sections: Sections
                       ) -> NDArray[np.float64]:
    """``|X - D|`` (mm) midway between sections, at every column and between columns.

    Returns shape ``(m - 1, 2 n - 1)``: interval ``j``, then the columns and the midpoints
    between them in increasing ``t``.
    """
    m = sections.n_sections
    t = np.sort(np.concatenate((sections.t, _midpoints(sections.t))))
    along = scipy.interpolate.CubicSpline(
        sections.t, sections.points, axis=1,
        bc_type="periodic" if sections.closed else "not-a-knot")(t)  # (m, 2n - 1, 3)
    knots_s, coef = interpolate_across(sections.s, along.reshape(m, -1))
    s_mid = _midpoints(sections.s)
    data = scipy.interpolate.BSpline(knots_s, coef, DEGREE)(s_mid).reshape(m - 1, -1, 3)
    fitted = surface(np.tile(t, m - 1), np.repeat(s_mid, t.size)).reshape(data.shape)
    return np.linalg.norm(fitted - data, axis=2)


def between_sections_estimate(surface: Callable[..., NDArray[np.float64]],
                              sections: Sections) -> float:
    """The estimated largest error between the sections (module docstring), mm.

    ``surface(t, s)`` gives points ``(k, 3)`` of the fitted surface for arrays ``t, s``.
    """
    interpolation = interpolation_errors(sections.s, sections.points)
    return float(fit_errors_between(surface, sections).max()
                 + (interpolation.max() if interpolation.size else 0.0))
