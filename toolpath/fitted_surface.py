"""What the fitted surfaces share: grid fit, interpolation across sections, figures, JSON.

Both fits separate (Algorithm 4 with the reading of ``paper.md`` §3): with the ``s``
direction interpolating the sections, the tensor least squares of eq. 29 splits into one
least-squares fit per section, on **common** ``t``-knots, followed by not-a-knot
interpolation of each section's coefficients across ``s``. The per-section fits are solved
together as one curve in ``R^(3m)`` (row ``i`` = point ``i`` of every section), so the knot
driver of :mod:`toolpath.adaptive` (corners, error density, tolerance search, minimax
polish) serves surfaces unchanged, with a column's error being its worst section's.

A model describes section ``j`` by a **row** of numbers (its ``t``-coefficients, plus what
else it needs); the surface interpolates the rows across ``s``. Interpolating all rows but
row ``j`` and comparing the result at ``s_j`` with the data measures how well the surface
follows the blade *between* sections (leave-one-out; with twice the section spacing it
overstates the true in-between error of a cubic by up to about ``2^4``: kept for judging
frames). The figure reported between sections is the estimate of
:mod:`toolpath.between_sections` (the fit against the data interpolated across ``s``,
midway, plus the cubic interpolation error across ``s``).

Sections on a union grid (:mod:`toolpath.section_matching`) carry interpolated entries:
they are fitted with the data (the knot driver keeps every entry within the tolerance,
so each section follows its interpolating cubic between its points too), and
``max_error``/``rms_error`` are measured at the data entries only.
"""

from __future__ import annotations

import dataclasses
import functools
from abc import abstractmethod
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.interpolate
from numpy.typing import NDArray

from .adaptive import KnotOptions, adapt_knots
from .between_sections import between_sections_estimate
from .fairness import SAMPLES_PER_INTERVAL, surface_fair_check
from .fitted_curve import error_figures
from .knots import Corner, detect_corners, seam_multiplicity
from .periodic import adapt_closed_knots, free_coefficients
from .sections import Sections
from .splinefit import DEGREE, n_coefficients
from .surface import ParametricSurface
from .tensor_spline import TensorSpline, interpolate_across

__all__ = ["FittedSurface", "GridFit", "column_errors", "fit_grid"]

#: Bumped whenever ``to_dict`` changes shape; ``from_dict`` refuses other versions.
SURFACE_FORMAT_VERSION = 1


def column_errors(fitted: NDArray[np.float64], data: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distances ``(m, n)`` between fitted and data points, both ``(m, n, 3)``."""
    return np.linalg.norm(fitted - data, axis=2)


@dataclass(frozen=True)
class GridFit:
    """The ``t``-direction fit of every section on common knots."""

    knots_t: NDArray[np.float64]
    rows: NDArray[np.float64]  # (m, row length): each section's description
    errors: NDArray[np.float64]  # (m, n) distances at the data


def fit_grid(sections: Sections, seed_values: NDArray[np.float64], fit_at,
             options: KnotOptions, make_surface=None) -> GridFit:
    """Run the knot driver on the sections seen as one curve in ``R^(3m)``.

    ``fit_at(knots, weights) -> (rows (m, r), errors (m, n))`` fits every section on
    ``knots``; the driver sees the per-column worst error. With ``make_surface(grid)``
    (a :class:`GridFit` to its surface) and a tolerance, the chosen fit is mended until it
    is fair on every section and midway between (:mod:`toolpath.fairness`).
    """
    fair_check = None
    if make_surface is not None and options.tol is not None:
        fair_check = surface_fair_check(
            lambda fit, knots: make_surface(GridFit(knots, *fit)), sections.points,
            options.tol, per_interval=sections.samples_per_column(SAMPLES_PER_INTERVAL),
            data_mask=sections.data_mask)

    def driver_fit(knots, weights):
        rows, errors = fit_at(knots, weights)
        return (rows, errors), errors.max(axis=0)

    if sections.mask is not None and options.corner_angle_deg is not None \
            and options.corners is None:  # a union grid: its sections' own corners vote
        options = dataclasses.replace(
            options, corners=_voted_corners(sections, options.corner_angle_deg))
    if sections.closed:  # periodic along t (toolpath.periodic)
        seam = _seam_multiplicity(sections, options.corner_angle_deg)
        (rows, errors), _, knots = adapt_closed_knots(sections.stacked, sections.t,
                                                      seed_values, driver_fit, options,
                                                      seam=seam, fair_check=fair_check)
    else:
        (rows, errors), _, knots = adapt_knots(sections.stacked, sections.t, seed_values,
                                               driver_fit, options, fair_check)
    return GridFit(knots_t=knots, rows=rows, errors=errors)


def _seam_multiplicity(sections: Sections, corner_angle_deg: float | None) -> int:
    """The seam's knot multiplicity: ``DEGREE`` where the data have a corner there, else 1.

    All data: the columns as one curve (:func:`~toolpath.knots.seam_multiplicity`).
    On a union grid (:mod:`toolpath.section_matching`) each section's own points are
    judged, with its seam point (a data point, or read from its interpolating cubic where
    the edge lies between points), and the seam is a corner where at least half the
    sections have one there: the union's columns bunch up round the seam (sections of
    the same stations from other start points put columns a few hundred-thousandths
    apart there), and the turns between such columns tell nothing of a corner (a
    propeller's sharp trailing edges read no corner, and the fit rounded them).
    """
    if sections.mask is None:
        return seam_multiplicity(sections.stacked, corner_angle_deg)
    ends = np.zeros(sections.n_columns, bool)
    ends[[0, -1]] = True  # (the seam point and its copy at t = 1)
    votes = [seam_multiplicity(points[keep | ends], corner_angle_deg) > 1
             for points, keep in zip(sections.points, sections.mask, strict=True)]
    return DEGREE if 2 * sum(votes) >= len(votes) else 1


def _voted_corners(sections: Sections, corner_angle_deg: float) -> tuple[Corner, ...]:
    """A union grid's corners (seam apart): where at least half the sections have one.

    Each section's own data points are judged (:func:`~toolpath.knots.detect_corners`;
    closed: round the seam, as :func:`_seam_multiplicity` reads it). The union's columns
    bunch up wherever sections' stations fall close together, and the turns between such
    columns (each section interpolated at the others' stations) tell nothing of a corner:
    the DCA rotor with 2 um of scatter read corners of 9-44 deg within 0.005 of its seam
    on the stacked columns in 5 of 8 draws (a C0 knot there, its fit turning 8 deg concave
    in 2 um; a 6 mm ball gouged), where no more than one of its 11 sections read one on its
    own points. A section's corner counts for another's within the data steps beside
    either; the corner stands at the median of its sections' ``t``, on the column at or
    before it.
    """
    ends = np.zeros(sections.n_columns, bool)
    ends[[0, -1]] = sections.closed  # (a closed section's seam point and its copy)
    found = []  # (t, angle, section, reach in t)
    for j, (points, keep) in enumerate(zip(sections.points, sections.mask, strict=True)):
        rows = np.flatnonzero(keep | ends)
        t = sections.t[rows]
        for corner in detect_corners(points[rows], t, min_angle_deg=corner_angle_deg):
            i = corner.index
            reach = t[min(i + 1, t.size - 1)] - t[max(i - 1, 0)]
            found.append((corner.t, corner.angle_deg, j, reach))
    found.sort()
    corners, taken = [], np.zeros(len(found), bool)
    for a, (t_a, _, _, reach_a) in enumerate(found):
        if taken[a]:
            continue
        group = [b for b, (t_b, _, _, reach_b) in enumerate(found)
                 if not taken[b] and abs(t_b - t_a) <= max(reach_a, reach_b)]
        if 2 * len({found[b][2] for b in group}) < sections.n_sections:
            continue
        taken[group] = True
        at = float(np.median([found[b][0] for b in group]))
        column = int(np.searchsorted(sections.t, at, side="right")) - 1
        corners.append(Corner(at, float(np.median([found[b][1] for b in group])), column))
    return tuple(corners)


def _outward_sign(surface: ParametricSurface, sections: Sections) -> float:
    """+1 if ``X_t x X_s`` points away from each section's centroid on average, else -1."""
    normals = surface.normal(sections.t[None, :], sections.s[:, None])
    away = sections.points - sections.points.mean(axis=1, keepdims=True)
    return 1.0 if float(np.einsum("mnk,mnk->", normals, away)) >= 0.0 else -1.0


@dataclass(frozen=True, eq=False, kw_only=True)
class FittedSurface(ParametricSurface):
    """Fields and figures common to the fitted surfaces.

    Attributes
    ----------
    knots_t : ndarray
        Clamped cubic knots along the sections (common to all sections); closed sections:
        the extended periodic vector of :mod:`toolpath.periodic` (``t`` periodic on [0, 1),
        the rows' coefficients wrapped).
    knots_s : ndarray
        Not-a-knot cubic knots across the sections.
    row_coef : ndarray, shape (n_s, r)
        Coefficients across ``s`` of the section rows (see the subclass).
    t_params, s_params : ndarray
        Grid parameters of the data columns and sections.
    max_error, rms_error : float
        Distance (mm) from the data points to ``X(t_i, s_j)``.
    loo_error : float
        Largest leave-one-out error over the interior sections (mm): an upper bound of the
        error between sections, up to ``2^4`` times too large.
    saved_between_error : float, optional
        :attr:`between_error` as saved (JSON); ``None``: estimated from the sections fitted.
    closed_t : bool
        Closed sections: ``X`` periodic in ``t``, position, tangent and curvature continuous
        across the seam ``t = 0 ≡ 1`` (C0 only where the data have a corner there).
    orientation : float
        ``+1`` or ``-1``, making ``orientation * X_t x X_s`` point outward.
    """

    knots_t: NDArray[np.float64]
    knots_s: NDArray[np.float64]
    row_coef: NDArray[np.float64]
    t_params: NDArray[np.float64]
    s_params: NDArray[np.float64]
    max_error: float
    rms_error: float
    loo_error: float
    saved_between_error: float | None = None
    closed_t: bool = False
    orientation: float = 1.0

    # ------------------------------------------------------------------ model hooks
    @classmethod
    @abstractmethod
    def _row_points(cls, knots_t: NDArray[np.float64], row: NDArray[np.float64],
                    t: NDArray[np.float64], extra: dict[str, Any]) -> NDArray[np.float64]:
        """Points ``(n, 3)`` at ``t`` of the section described by ``row``."""

    @property
    def _n_tensor(self) -> int:
        """Leading entries of a row that are the tensor coefficients (``n_t * 3``)."""
        return n_coefficients(self.knots_t) * 3

    @functools.cached_property
    def tensor(self) -> TensorSpline:
        """The bicubic part: ``G(t, s)`` or ``X(t, s)`` (eq. 29)."""
        n_t, n_s = n_coefficients(self.knots_t), self.row_coef.shape[0]
        coef = self.row_coef[:, :self._n_tensor].reshape(n_s, n_t, 3).transpose(1, 0, 2)
        return TensorSpline(self.knots_t, self.knots_s, np.ascontiguousarray(coef))

    @functools.cached_property
    def between_error(self) -> float:
        """Estimated error between sections (mm).

        The surface against the data interpolated across ``s``, midway, plus the cubic
        interpolation error across ``s``
        (:func:`toolpath.between_sections.between_sections_estimate`). Estimated on first
        use (the report, JSON), so the fits tried while knots are chosen do not pay for it;
        NaN for a surface built neither by a fit nor from JSON that holds it.
        """
        if self.saved_between_error is not None:
            return self.saved_between_error
        sections = self.__dict__.get("_fitted_sections")
        if sections is None:
            return float("nan")
        return between_sections_estimate(self, sections)

    @property
    def n_control_points(self) -> tuple[int, int]:
        """Control points ``(along t, across s)`` per coordinate (free ones when periodic)."""
        return free_coefficients(self.knots_t), self.tensor.shape[1]

    # ------------------------------------------------------------------ building
    @classmethod
    def _from_grid(cls, sections: Sections, grid: GridFit, **fields: Any) -> FittedSurface:
        """Interpolate the rows across ``s`` and measure the result."""
        knots_s, row_coef = interpolate_across(sections.s, grid.rows)
        loo = cls._leave_one_out(sections, grid, fields)
        max_error, rms_error = error_figures(grid.errors[sections.data_mask])
        surface = cls(knots_t=grid.knots_t, knots_s=knots_s, row_coef=row_coef,
                      t_params=sections.t, s_params=sections.s, max_error=max_error,
                      rms_error=rms_error, loo_error=loo, closed_t=sections.closed, **fields)
        object.__setattr__(surface, "orientation", _outward_sign(surface, sections))
        surface.__dict__["_fitted_sections"] = sections  # for between_error, on demand
        return surface

    @classmethod
    def _leave_one_out(cls, sections: Sections, grid: GridFit, extra: dict[str, Any]) -> float:
        worst = 0.0
        for j in range(1, sections.n_sections - 1):
            keep = np.arange(sections.n_sections) != j
            knots_s, coef = interpolate_across(sections.s[keep], grid.rows[keep])
            row = scipy.interpolate.BSpline(knots_s, coef, DEGREE)(sections.s[j])
            points = cls._row_points(grid.knots_t, row, sections.t, extra)
            worst = max(worst, float(np.linalg.norm(points - sections.points[j], axis=1).max()))
        return worst

    # ------------------------------------------------------------------ JSON
    def _common_dict(self) -> dict[str, Any]:
        return {
            "format_version": SURFACE_FORMAT_VERSION,
            "knots_t": self.knots_t.tolist(), "knots_s": self.knots_s.tolist(),
            "row_coef": self.row_coef.tolist(), "t_params": self.t_params.tolist(),
            "s_params": self.s_params.tolist(), "max_error": self.max_error,
            "rms_error": self.rms_error, "loo_error": self.loo_error,
            "between_error": self.between_error, "closed_t": self.closed_t,
            "orientation": self.orientation,
        }

    @staticmethod
    def _common_fields(data: dict[str, Any]) -> dict[str, Any]:
        return {
            "knots_t": np.asarray(data["knots_t"], float),
            "knots_s": np.asarray(data["knots_s"], float),
            "row_coef": np.asarray(data["row_coef"], float),
            "t_params": np.asarray(data["t_params"], float),
            "s_params": np.asarray(data["s_params"], float),
            "max_error": float(data["max_error"]), "rms_error": float(data["rms_error"]),
            "loo_error": float(data["loo_error"]),
            # surfaces saved before the estimate existed: their leave-one-out upper bound
            "saved_between_error": float(data.get("between_error", data["loo_error"])),
            "closed_t": bool(data["closed_t"]),
            "orientation": float(data["orientation"]),
        }
