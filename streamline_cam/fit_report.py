"""Fitting a curve or surface by method name and describing the result (CLI and demo)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from toolpath import (
    LINEAR_MODELS,
    fit_bspline_curve,
    fit_bspline_surface,
    fit_linear_system,
    fit_streamline_curve,
    fit_streamline_surface,
)
from toolpath.errors import InvalidParameterError
from toolpath.fairness import curve_fairness, surface_fairness
from toolpath.sections import as_sections

__all__ = [
    "CURVE_METHODS",
    "SURFACE_METHODS",
    "CurveFitReport",
    "SurfaceFitReport",
    "fit_curve_by_method",
    "fit_surface_by_method",
]

CURVE_METHODS = ("streamline", "bspline", *LINEAR_MODELS)


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
    fairness = curve_fairness(curve, points, closed=bool(getattr(curve, "closed", False)))
    extra["fairness"] = fairness.as_dict()
    extra["notes"] = [*extra.get("notes", []), *fairness.warnings(tol)]
    report = CurveFitReport(method=method, n_points=len(points),
                            closed=bool(getattr(curve, "closed", False)),
                            n_control_points=curve.n_control_points,
                            max_error_mm=curve.max_error, rms_error_mm=curve.rms_error,
                            tol_mm=tol, seconds=seconds, **extra)
    return curve, report


SURFACE_METHODS = ("streamline", "bspline")


@dataclass(frozen=True)
class SurfaceFitReport:
    """What a user reads after a surface fit: sizes, errors (mm), frame, time (s)."""

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

    @property
    def within_tol(self) -> bool:
        """Whether the max error at the data meets the tolerance."""
        return self.max_error_mm <= self.tol_mm

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {**self.__dict__, "n_control_points": list(self.n_control_points),
                "within_tol": self.within_tol}

    def lines(self) -> list[str]:
        """Human-readable report lines."""
        n_t, n_s = self.n_control_points
        out = [
            f"method            {self.method} surface",
            f"sections          {self.n_sections} x {self.points_per_section} points"
            + (" (closed)" if self.closed else " (open)"),
            f"control points    {n_t} x {n_s} (along x across)",
            f"max error         {self.max_error_mm:.6f} mm"
            + ("" if self.within_tol else f"   (above tol {self.tol_mm:g} mm)"),
            f"rms error         {self.rms_error_mm:.6f} mm",
            f"between sections  {self.between_sections_mm:.6f} mm (leave-one-out, upper bound)",
            f"time              {self.seconds:.3f} s",
        ]
        out.extend(_fairness_lines(self.fairness))
        out.extend(f"note              {n}" for n in self.notes)
        return out


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
    start = time.perf_counter()
    fit = fit_streamline_surface if method == "streamline" else fit_bspline_surface
    surface = fit(sections, tol=tol, closed=closed)
    seconds = time.perf_counter() - start
    notes = [f"frame: {surface.frame_label}"] if method == "streamline" else []
    fairness = surface_fairness(surface, as_sections(sections, closed=surface.closed_t).points)
    notes += fairness.warnings(tol)
    report = SurfaceFitReport(
        method=method, n_sections=len(surface.s_params),
        points_per_section=len(surface.t_params) - int(surface.closed_t),
        closed=surface.closed_t, n_control_points=surface.n_control_points,
        max_error_mm=surface.max_error, rms_error_mm=surface.rms_error,
        between_sections_mm=surface.loo_error, tol_mm=tol, seconds=seconds, notes=notes,
        fairness=fairness.as_dict())
    return surface, report
