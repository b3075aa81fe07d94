"""How far measured points scatter about a smooth curve through them.

Each sample's offset from the chord of its neighbours,
``r_i = p_i − (b p_{i−1} + a p_{i+1}) / (a + b)`` (``a``, ``b`` the steps before and after),
follows a smooth curve's curvature from sample to sample, so its second difference
``e_i = r_i − (r_{i−1} + r_{i+1}) / 2`` is what scatter adds: ~0 on exact points, however
unevenly spaced. For a Gaussian scatter σ on every coordinate each component of ``e``
across the curve spreads ``√(35/8) σ`` (evenly spaced: ``1.5 p_i − (p_{i−1} + p_{i+1}) +
(p_{i−2} + p_{i+2}) / 4``; the share along the chord moves the interpolation's weights, not
the offset), so the lower quartile of ``|e_i|`` (the **wobble**) is ``√(35/8) σ`` times the
lower quartile of a chi distribution with ``d − 1`` degrees of freedom
(:func:`wobble_per_sigma`: 1.59 in 3-D, 0.67 in 2-D); the quartile keeps a few sharp
features (a corner, a nose's ends) out of it.

On the bundled blades the estimate of σ is at most 0.00006 mm (exact points written with 6
decimals); with 1, 2 and 3 um of scatter added the median over the sections reads 0.9-1.2,
2.0-2.1 and 2.8-2.9 um.

A fit within a tolerance below :data:`SMOOTH_TOL_PER_SIGMA` σ follows the scatter: over a
thousand points Gaussian scatter reaches about 3.5 σ, what is left for the fit's own error
is small, and the fit must bend to take those points in, rippling where the points stand
close together (a blade's open edge, a nose). On the bundled blade with 3 um of scatter,
fitted within 0.01 mm (3.4 σ), the edge's curvature swung between -4.8 and +10 /mm and a
6 mm ball gouged; within 0.02 mm (7 σ) the fit is fair and the job runs.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["SMOOTH_TOL_PER_SIGMA", "follows_scatter", "point_scatter_mm", "point_wobble_mm",
           "scatter_turn_rad", "sections_scatter_mm", "wobble_per_sigma"]

#: A fit tolerance below this many σ of scatter makes the fit follow the scatter (the
#: bundled blades with 3 um of scatter, ``toolpath run`` 5-axis: the blade and the blunt
#: rotor ran from 5 σ, the propeller gouged at its seam at 5.1 σ and ran at 6.1 σ).
SMOOTH_TOL_PER_SIGMA = 6.0


def follows_scatter(tol_mm: float, scatter_mm: float) -> bool:
    """Whether a fit within ``tol_mm`` follows points scattering ``scatter_mm`` (σ)."""
    return tol_mm < SMOOTH_TOL_PER_SIGMA * scatter_mm


def point_wobble_mm(points: NDArray[np.float64],
                    steps: NDArray[np.float64] | None = None) -> float:
    """The wobble of ordered points ``(n, d)`` (module docstring), mm; 0 for fewer than 5.

    ``steps``: the lengths between consecutive points, when the caller has them.
    """
    points = np.asarray(points, dtype=float)
    if steps is None:
        steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    if steps.size < 4:
        return 0.0
    before, after = steps[:-1, None], steps[1:, None]
    offset = points[1:-1] - (after * points[:-2] + before * points[2:]) / np.maximum(
        before + after, np.finfo(float).tiny)
    wobble = np.linalg.norm(offset[1:-1] - 0.5 * (offset[:-2] + offset[2:]), axis=1)
    return float(np.percentile(wobble, 25.0))


def scatter_turn_rad(wobble_mm: float, before_mm: ArrayLike, after_mm: ArrayLike
                     ) -> NDArray[np.float64]:
    """How far scatter of wobble ``wobble_mm`` may turn a sample between two steps (rad).

    About ``w (1/a + 1/b)`` for the steps ``a`` before and ``b`` after: the sample's offset
    across the chords over their lengths.
    """
    before, after = np.asarray(before_mm, dtype=float), np.asarray(after_mm, dtype=float)
    return wobble_mm * (1.0 / before + 1.0 / after)


def wobble_per_sigma(dimensions: int) -> float:
    """The wobble per unit of Gaussian scatter σ of points in ``dimensions`` (>= 2)."""
    from scipy.stats import chi

    return float(np.sqrt(35.0 / 8.0) * chi.ppf(0.25, dimensions - 1))


def point_scatter_mm(points: NDArray[np.float64]) -> float:
    """The scatter σ of ordered points ``(n, d)`` about a smooth curve through them, mm."""
    points = np.asarray(points, dtype=float)
    return point_wobble_mm(points) / wobble_per_sigma(points.shape[1])


def sections_scatter_mm(sections: Sequence[NDArray[np.float64]]) -> float:
    """The median over the sections of their points' scatter σ, mm (0: no section)."""
    values = [point_scatter_mm(p) for p in sections]
    return float(np.median(values)) if values else 0.0
