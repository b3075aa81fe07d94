"""The baseline: a bicubic tensor B-spline surface ``X(t, s) = Σ P_ab N_a(t) M_b(s)``.

Fitted exactly like the streamline surface (common ``t``-knots chosen by the same driver,
sections interpolated across ``s`` with not-a-knot ends), so the two compare on equal
terms; pass one surface's ``knots_t`` as the other's ``knots=`` for identical knots.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.interpolate
from numpy.typing import NDArray

from .adaptive import DEFAULT_SWEEPS, knot_options
from .fitted_surface import FittedSurface, column_errors, fit_grid
from .knots import DEFAULT_CORNER_ANGLE_DEG
from .sections import as_sections
from .splinefit import DEGREE, end_interpolating_lsq

__all__ = ["BSplineSurface", "fit_bspline_surface"]


@dataclass(frozen=True, eq=False, kw_only=True)
class BSplineSurface(FittedSurface):
    """Bicubic tensor B-spline; a section's row is its ``t``-control points ``(n_t * 3)``."""

    @classmethod
    def _row_points(cls, knots_t, row, t, extra) -> NDArray[np.float64]:
        return scipy.interpolate.BSpline(knots_t, row.reshape(-1, 3), DEGREE)(t)

    def _partials(self, t, s, dt, ds) -> NDArray[np.float64]:
        return self.tensor.partial(t, s, dt, ds)

    def partials_many(self, t, s, orders):
        """``{(dt, ds): (n, 3)}`` at once, from the tensor spline."""
        return self.tensor.partials(t, s, tuple(orders))

    def to_dict(self) -> dict[str, Any]:
        """JSON-serializable description; :meth:`from_dict` restores it exactly."""
        return {"kind": "bspline_surface", **self._common_dict()}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> BSplineSurface:
        """Rebuild from :meth:`to_dict` output."""
        return cls(**cls._common_fields(data))


def fit_bspline_surface(
    sections: Any,
    *,
    tol: float | None = None,
    n_control_points: int | None = None,
    max_control_points: int | None = None,
    knots: Any = None,
    closed: bool | None = None,
    params: Any = "chord",
    section_params: Any = None,
    knot_method: str = "density",
    corner_angle_deg: float | None = DEFAULT_CORNER_ANGLE_DEG,
    sweeps: int = DEFAULT_SWEEPS,
    minimax: bool = True,
    fair: bool = True,
) -> BSplineSurface:
    """Fit a bicubic B-spline surface through blade sections (the baseline).

    Parameters
    ----------
    sections : array_like, shape (m, n, 3), or a list of (n, 3) arrays
        Sections hub to tip (see :func:`toolpath.as_sections`).
    tol : float, optional
        Max distance (mm) at the data points; the fewest ``t``-control points reaching it
        are searched. Exactly one of ``tol``, ``n_control_points``, ``knots``.
    n_control_points : int, optional
        Control points along ``t`` (across ``s`` there is one per section).
    max_control_points : int, optional
        Upper bound along ``t`` while searching for ``tol``.
    knots : array_like, optional
        The clamped cubic ``t``-knot vector to use exactly.
    closed : bool, optional
        Closed sections, fitted periodic in ``t`` (default: read from how the sections end,
        :mod:`toolpath.closure`).
    params, section_params
        Grid parameters ``t`` and ``s`` (see :func:`toolpath.as_sections`).
    knot_method, corner_angle_deg, sweeps, minimax, fair
        As for :func:`toolpath.fit_bspline_curve`; fairness is checked on every section and
        midway between sections.

    Returns
    -------
    BSplineSurface
    """
    options = knot_options(tol=tol, n_control_points=n_control_points,
                           max_control_points=max_control_points, knots=knots,
                           knot_method=knot_method, corner_angle_deg=corner_angle_deg,
                           sweeps=sweeps, minimax=minimax)
    grid = as_sections(sections, closed=closed, params=params,
                       section_params=section_params)
    stacked = grid.stacked

    def fit_at(knot_vector, weights):
        spline = end_interpolating_lsq(grid.t, stacked, knot_vector, weights)
        m, n = grid.n_sections, grid.n_columns
        fitted = spline(grid.t).reshape(n, m, 3).transpose(1, 0, 2)
        rows = np.asarray(spline.c).reshape(-1, m, 3).transpose(1, 0, 2).reshape(m, -1)
        return rows, column_errors(fitted, grid.points)

    fitted = fit_grid(grid, stacked, fit_at, options,
                      (lambda fit: BSplineSurface._from_grid(grid, fit)) if fair else None)
    return BSplineSurface._from_grid(grid, fitted)
