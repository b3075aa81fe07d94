"""Fitting a curve or surface by method name and describing the result (CLI and demo)."""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from toolpath.errors import InvalidParameterError, ToolpathError, tolerance_to_give
from toolpath.fairness import SAMPLES_PER_INTERVAL, curve_fairness, surface_fairness
from toolpath.fit_methods import CURVE_METHODS, LINEAR_MODELS, SURFACE_METHODS
from toolpath.scatter import (
    SMOOTH_TOL_PER_SIGMA,
    follows_scatter,
    point_scatter_mm,
    sections_scatter_mm,
)

__all__ = [
    "CURVE_METHODS",
    "SURFACE_METHODS",
    "CurveFitReport",
    "SurfaceFitReport",
    "FAIR_TOL_STEPS",
    "SCATTER_FLOOR_MM",
    "fair_tolerance",
    "fit_curve_by_method",
    "fit_surface_by_method",
    "smoothing_advice",
    "unfair_advice",
]

@dataclass(frozen=True)
class CurveFitReport:
    """What a user reads after a fit: method, size, errors (mm), frame, time (s)."""

    method: str
    n_points: int
    n_control_points: int
    max_error_mm: float
    rms_error_mm: float
    tol_mm: float
    seconds: float
    T: list[list[float]] | None = None
    c_mm: list[float] | None = None
    A: list[list[float]] | None = None
    notes: list[str] = field(default_factory=list)
    #: :meth:`toolpath.fairness.Fairness.as_dict` of the fit (concave stretches, noses).
    fairness: dict[str, Any] | None = None
    closed: bool = False
    #: Estimated largest error between the data points (``toolpath.between_data``) and
    #: where; None for the constant-coefficient models.
    between_data_mm: float | None = None
    between_data_t: float | None = None
    between_data_basis: str | None = None
    #: How far the points scatter about a smooth curve through them, mm
    #: (:func:`toolpath.scatter.point_scatter_mm`).
    scatter_mm: float = 0.0

    @property
    def within_tol(self) -> bool:
        """Whether the max error meets the tolerance."""
        return self.max_error_mm <= self.tol_mm

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        out = {k: v for k, v in self.__dict__.items() if v is not None}
        out["within_tol"] = self.within_tol
        return out

    def lines(self) -> list[str]:
        """Human-readable report lines."""
        out = [
            f"method            {self.method}",
            f"points            {self.n_points}" + (" (closed)" if self.closed else " (open)"),
            f"control points    {self.n_control_points}",
            f"max error         {self.max_error_mm:.6f} mm"
            + ("" if self.within_tol else f"   (above tol {self.tol_mm:g} mm)"),
            f"rms error         {self.rms_error_mm:.6f} mm",
            *_between_data_lines(self.between_data_mm, None, self.between_data_t,
                                 self.between_data_basis),
            f"scatter           {self.scatter_mm:.4f} mm (the points about a smooth curve "
            "through them)",
            f"time              {self.seconds:.3f} s",
        ]
        for name, matrix in (("T", self.T), ("A", self.A)):
            if matrix is not None:
                rows = ["[" + ", ".join(f"{v: .6g}" for v in row) + "]" for row in matrix]
                out.append(f"{name:<18}" + rows[0])
                out.extend(" " * 18 + r for r in rows[1:])
        if self.c_mm is not None:
            out.append("c                 [" + ", ".join(f"{v:.6g}" for v in self.c_mm) + "] mm")
        out.extend(_fairness_lines(self.fairness))
        out.extend(f"note              {n}" for n in self.notes)
        return out


def fit_curve_by_method(points: NDArray[np.float64], *, method: str, tol: float,
                        closed: bool | None = None) -> tuple[Any, CurveFitReport]:
    """Fit ``points`` with ``method`` (see ``CURVE_METHODS``) and report on it.

    ``closed`` (None: read from the points) applies to the spline methods; the
    constant-coefficient models fit open curves only.
    """
    if method not in CURVE_METHODS:
        raise InvalidParameterError(f"method must be one of {CURVE_METHODS}, got {method!r}")
    from toolpath import fit_bspline_curve, fit_linear_system, fit_streamline_curve

    start = time.perf_counter()
    if method == "streamline":
        curve = fit_streamline_curve(points, tol=tol, closed=closed)
    elif method == "bspline":
        curve = fit_bspline_curve(points, tol=tol, closed=closed)
    else:
        if closed:
            raise InvalidParameterError(
                f"--closed needs a spline method (streamline or bspline); {method} fits "
                "open curves only")
        curve = fit_linear_system(points, model=method)
    seconds = time.perf_counter() - start
    extra: dict[str, Any] = {}
    if method == "streamline":
        extra = {"T": curve.T.tolist(), "c_mm": curve.c.tolist(),
                 "notes": [f"frame: {curve.frame_label}"]}
    elif method in LINEAR_MODELS:
        extra = {"A": curve.A.tolist(),
                 "notes": ["constant-coefficient model: tol is reported, not enforced"]}
    is_closed = bool(getattr(curve, "closed", False))  # the linear models have no closed form
    fairness = curve_fairness(curve, points, closed=is_closed)
    extra["fairness"] = fairness.as_dict()
    if method not in LINEAR_MODELS:
        extra.update(_curve_between_data(curve, points))
    extra["notes"] = [*extra.get("notes", []), *fairness.warnings(tol)]
    extra["scatter_mm"] = point_scatter_mm(np.asarray(points, dtype=float))
    if method not in LINEAR_MODELS and follows_scatter(tol, extra["scatter_mm"]):
        extra["notes"].append("scatter: " + smoothing_advice(extra["scatter_mm"], tol))
    report = CurveFitReport(method=method, n_points=len(points),
                            closed=is_closed,
                            n_control_points=curve.n_control_points,
                            max_error_mm=curve.max_error, rms_error_mm=curve.rms_error,
                            tol_mm=tol, seconds=seconds, **extra)
    return curve, report


def _curve_between_data(curve: Any, points: NDArray[np.float64]) -> dict[str, Any]:
    """The between-data estimate of a spline curve fit, as report fields."""
    from toolpath.between_data import between_data_estimate

    t = np.asarray(curve.params, dtype=float)
    data = np.asarray(points, dtype=float)[:t.size]
    if curve.closed:
        t, data = np.append(t, 1.0), np.vstack((data, data[:1]))
    mm, where = between_data_estimate(curve, t, data, closed=bool(curve.closed))
    return {"between_data_mm": mm, "between_data_t": where,
            "between_data_basis": BETWEEN_DATA_BASIS}


def _between_data_lines(mm: float | None, section: int | None, t: float | None,
                        basis: str | None) -> list[str]:
    """``between data  0.011 mm (estimate: ..., largest at section 2 t=0.4812)``."""
    if mm is None:
        return []
    where = "" if t is None else (", largest at " + ("" if section is None
                                                       else f"section {section} ")
                                  + f"t={t:.4f}")
    return [f"between data      {mm:.6f} mm ({basis}{where})"]


#: What ``between_data_mm`` is (``toolpath.between_data``).
BETWEEN_DATA_BASIS = ("estimate: fit vs the data's interpolating cubic between points "
                      "+ interpolation error")
#: What ``between_sections_mm`` is (``toolpath.between_sections``).
BETWEEN_SECTIONS_BASIS = "estimate: fit vs data interpolated across sections + interpolation error"


@dataclass(frozen=True)
class SurfaceFitReport:
    """What a user reads after a surface fit: sizes, errors (mm), frame, time (s).

    ``points_per_section`` is the largest count; ``section_point_counts`` every section's
    (they may differ). ``between_sections_mm`` is an estimate of the error between the
    sections (``between_sections_basis``), ``leave_one_out_mm`` the old upper bound.
    """

    method: str
    n_sections: int
    points_per_section: int
    closed: bool
    n_control_points: tuple[int, int]
    max_error_mm: float
    rms_error_mm: float
    between_sections_mm: float
    tol_mm: float
    seconds: float
    notes: list[str] = field(default_factory=list)
    #: :meth:`toolpath.fairness.Fairness.as_dict` of the fit, on every section and midway.
    fairness: dict[str, Any] | None = None
    section_point_counts: list[int] = field(default_factory=list)
    leave_one_out_mm: float | None = None
    between_sections_basis: str = BETWEEN_SECTIONS_BASIS
    #: Estimated largest error between the data points along the sections
    #: (``toolpath.between_data``) and where (section index, t).
    between_data_mm: float | None = None
    between_data_section: int | None = None
    between_data_t: float | None = None
    between_data_basis: str = BETWEEN_DATA_BASIS
    #: How far the points scatter about smooth curves through them, mm (the median of
    #: the sections' σ, :func:`toolpath.scatter.sections_scatter_mm`).
    scatter_mm: float = 0.0

    @property
    def follows_scatter(self) -> bool:
        """Whether the tolerance is so tight that the fit follows the points' scatter."""
        return follows_scatter(self.tol_mm, self.scatter_mm)

    def smoothing_advice(self, flag: str | None = None) -> str:
        """What the scatter does to a fit within the tolerance (:func:`smoothing_advice`)."""
        return smoothing_advice(self.scatter_mm, self.tol_mm, flag)

    @property
    def within_tol(self) -> bool:
        """Whether the max error at the data meets the tolerance."""
        return self.max_error_mm <= self.tol_mm

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {**self.__dict__, "n_control_points": list(self.n_control_points),
                "within_tol": self.within_tol, "follows_scatter": self.follows_scatter}

    def lines(self) -> list[str]:
        """Human-readable report lines."""
        n_t, n_s = self.n_control_points
        counts = self.section_point_counts or [self.points_per_section]
        points = (f"{counts[0]}" if min(counts) == max(counts)
                  else f"{min(counts)}-{max(counts)}")
        out = [
            f"method            {self.method} surface",
            f"sections          {self.n_sections} x {points} points"
            + (" (closed)" if self.closed else " (open)"),
            f"control points    {n_t} x {n_s} (along x across)",
            f"max error         {self.max_error_mm:.6f} mm"
            + ("" if self.within_tol else f"   (above tol {self.tol_mm:g} mm)"),
            f"rms error         {self.rms_error_mm:.6f} mm",
            f"between sections  {self.between_sections_mm:.6f} mm ({self.between_sections_basis})",
            *_between_data_lines(self.between_data_mm, self.between_data_section,
                                 self.between_data_t, self.between_data_basis),
            f"scatter           {self.scatter_mm:.4f} mm (the points about smooth curves "
            "through them, median of the sections)",
            f"time              {self.seconds:.3f} s",
        ]
        out.extend(_fairness_lines(self.fairness))
        out.extend(f"note              {n}" for n in self.notes)
        return out


def _few_sections_note(n_sections: int, loo_mm: float, window: int) -> str:
    """What the between-sections figure leaves out below ``window`` sections (a 4th difference)."""
    return (f"between sections: {n_sections} sections, too few for the interpolation error "
            f"across them (a fourth difference needs {window}); the figure is the fit against "
            f"the data interpolated across the sections only; leave-one-out (each inner "
            f"section from the other {n_sections - 1}) {loo_mm:.4f} mm")


def _fairness_lines(fairness: dict[str, Any] | None) -> list[str]:
    """``fairness  0 concave stretches > 1 um (deepest 0.0000 mm)`` and the noses' line."""
    if fairness is None:
        return []
    return [f"fairness          {fairness['summary']}", f"noses             {fairness['noses']}"]


def fit_surface_by_method(sections: Any, *, method: str, tol: float, closed: bool | None = None
                          ) -> tuple[Any, SurfaceFitReport]:
    """Fit blade ``sections`` with ``method`` (see ``SURFACE_METHODS``) and report on it."""
    if method not in SURFACE_METHODS:
        raise InvalidParameterError(
            f"method must be one of {SURFACE_METHODS}, got {method!r}")
    from toolpath import as_sections
    from toolpath.between_data import surface_between_data
    from toolpath.between_sections import WINDOW

    start = time.perf_counter()
    grid = as_sections(sections, closed=closed)  # matched once, fitted as matched
    surface = _surface_fitter(method)(grid, tol=tol)
    seconds = time.perf_counter() - start
    notes = [f"frame: {surface.frame_label}"] if method == "streamline" else []
    counts = grid.data_counts
    fairness = _fairness(surface, grid)
    notes += fairness.warnings(tol)
    if grid.n_sections < WINDOW:
        notes.append(_few_sections_note(grid.n_sections, surface.loo_error, WINDOW))
    between_data, data_section, data_t = surface_between_data(surface, grid)
    scatter = sections_scatter_mm([p[keep] for p, keep in zip(grid.points, grid.data_mask,
                                                              strict=True)])
    report = SurfaceFitReport(
        method=method, n_sections=len(surface.s_params), points_per_section=max(counts),
        closed=surface.closed_t, n_control_points=surface.n_control_points,
        max_error_mm=surface.max_error, rms_error_mm=surface.rms_error,
        between_sections_mm=surface.between_error, tol_mm=tol, seconds=seconds, notes=notes,
        fairness=fairness.as_dict(), section_point_counts=counts,
        leave_one_out_mm=surface.loo_error, between_data_mm=between_data,
        between_data_section=data_section, between_data_t=data_t, scatter_mm=scatter)
    if report.follows_scatter:
        notes.append("scatter: " + report.smoothing_advice())
    return surface, report


def smoothing_advice(scatter_mm: float, tol_mm: float, flag: str | None = None) -> str:
    """What a scatter of ``scatter_mm`` does to a fit within ``tol_mm``, and the cure.

    Told with ``flag`` (``--fit-tol``, ``--tol``) when given, else in plain words.
    """
    smooth_mm = tolerance_to_give(SMOOTH_TOL_PER_SIGMA * scatter_mm)
    asked, advised = ((f"{tol_mm:g} mm", f"a tolerance of {smooth_mm:g} mm") if flag is None
                      else (f"{flag} {tol_mm:g}", f"{flag} {smooth_mm:g}"))
    return (f"the points scatter {scatter_mm:.4f} mm about smooth curves through them, and "
            f"a fit within {asked} follows that scatter (its edges and noses ripple): "
            f"{advised} or more smooths it")


#: Tolerances tried, as multiples of the one asked, for a fair fit of scattered points that
#: the fit within the one asked left unfair (:func:`fair_tolerance`): the blunt rotor with
#: 1 um of scatter (seed 1) stayed unfair at 0.01 mm in every frame (99 control points for
#: 120 points a section) and fitted fair at 0.012 mm (41).
FAIR_TOL_STEPS = (1.2, 1.5, 2.0)

#: Points scattering less than this (mm) read as exact (exact points written with 6
#: decimals read 0.00006 mm at most): an unfair fit of them is not the scatter's doing.
SCATTER_FLOOR_MM = 0.0005


def fair_tolerance(sections: Any, report: SurfaceFitReport, method: str) -> float | None:
    """A wider tolerance that fits scattered points fair where ``report``'s fit stays unfair.

    Where the points scatter (at least :data:`SCATTER_FLOOR_MM`) and the fit within the
    tolerance asked is left with concave stretches, ``sections`` are fitted again with
    ``method`` within :data:`FAIR_TOL_STEPS` times that tolerance (each rounded up to a
    tolerance to give), the smallest first: the first with no concave stretch. None: the
    fit is fair, the points read exact, or none of them fits fair. (Up to three fits more:
    for a job that stopped on a gouge, to tell the user what cures it.)
    """
    fairness = report.fairness
    if (fairness is None or not fairness["concave_stretches"]
            or report.scatter_mm < SCATTER_FLOOR_MM):
        return None
    for step in FAIR_TOL_STEPS:
        tol_mm = tolerance_to_give(step * report.tol_mm)
        try:
            with warnings.catch_warnings():  # (a trial: its own warnings are no news)
                warnings.simplefilter("ignore")
                surface = _surface_fitter(method)(sections, tol=tol_mm)
        except ToolpathError:
            continue
        if not _fairness(surface, sections).n_concave:
            return tol_mm
    return None


def _surface_fitter(method: str) -> Any:
    """The surface fit of a method of ``SURFACE_METHODS`` (checked by the caller)."""
    from toolpath import fit_bspline_surface, fit_streamline_surface

    return fit_streamline_surface if method == "streamline" else fit_bspline_surface


def _fairness(surface: Any, sections: Any) -> Any:
    """:func:`~toolpath.fairness.surface_fairness` of a fit of ``sections``, as reported."""
    return surface_fairness(surface, sections.points,
                            per_interval=sections.samples_per_column(SAMPLES_PER_INTERVAL))


def unfair_advice(report: SurfaceFitReport, fair_tol_mm: float, flag: str) -> str:
    """What leaves ``report``'s fit unfair, and the tolerance (``flag``) that fits it fair."""
    return (f"the fit within {flag} {report.tol_mm:g} stays unfair, "
            f"{report.fairness['summary']}, where the points scatter "
            f"{report.scatter_mm:.4f} mm about smooth curves through them: {flag} "
            f"{fair_tol_mm:g} fits them fair")
