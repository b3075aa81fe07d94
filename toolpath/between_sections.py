"""How far a fitted surface may be from the blade *between* its sections: an estimate.

A fitted surface interpolates its sections' rows across ``s`` by cubics, so between
sections ``j`` and ``j + 1`` (spacing ``h_j``) it departs from a smooth blade by the cubic
interpolation error, about ``5/384 h_j^4 |f''''|`` at worst (Hall's bound for cubic
spline interpolation; the midpoint error of the cubic through the interval's ends and
slopes), plus what it already misses at the sections (the fit error at the data). ``f''''``
along ``s`` is read from the grid itself: the fourth divided differences of each column
over five consecutive sections (times ``4! = 24``), the largest over the windows that
contain the interval (the end intervals have only the windows at the end).

So the estimate is ``max_error + max_j 5/384 h_j^4 |f''''|_j`` (mm). Measured against the
truth (``tests/toolpath/test_section_matching.py``, ``benchmarks/blade_truth.py``): on the
DCA rotor the fits are 0.008-0.015 mm off between sections where this says 0.007-0.010;
on the dev blade 0.0079 mm where it says 0.0076. Unmatched sections (column ``i`` joining
a nose point to a flank point) show up here as a large fourth difference. The
leave-one-out error (a section left out and interpolated from the others, twice the
spacing) overstates it by up to ``2^4`` and far more when sections are not matched.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["INTERPOLATION_CONSTANT", "between_sections_estimate", "interpolation_errors"]

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


def interpolation_errors(s: NDArray[np.float64], points: NDArray[np.float64]
                         ) -> NDArray[np.float64]:
    """Estimated cubic interpolation error across ``s`` per interval and column, mm.

    Parameters
    ----------
    s : ndarray, shape (m,)
        Section parameters, increasing (``m >= 5``; fewer give zeros: no fourth difference).
    points : ndarray, shape (m, N, 3)
        The grid: every section at every column (mm).

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
        out[j] = INTERPOLATION_CONSTANT * (s[j + 1] - s[j]) ** 4 * d4[first:last + 1].max(axis=0)
    return out


def between_sections_estimate(s: NDArray[np.float64], points: NDArray[np.float64],
                              data_error_mm: float) -> float:
    """The fit error at the data plus the largest interpolation error across ``s``, mm."""
    errors = interpolation_errors(s, points)
    return float(data_error_mm + (errors.max() if errors.size else 0.0))
