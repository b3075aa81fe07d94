"""Samples of the design surface: the nodes where the cut is compared with the design.

The surface ``X(t, s)`` is sampled on a grid uniform in each parameter, with counts chosen
from the largest parameter speeds ``|X_t|`` and ``|X_s|`` measured on a probe grid, so the
distance between neighbouring samples is at most the asked spacing everywhere (not only on
average). Each sample carries the outward unit normal ``n = orientation X_t x X_s / |.|``,
its share of the area ``|X_t x X_s| dt ds`` (trapezoid weights), and the surface's
convexity ``max(-k_min, 0)`` (1/mm; :mod:`toolpath.surface` signs curvature negative where
the surface curves away from its normal), which widens the neighbourhood searched for the
cutter around convex edges. Convexity comes from a coarse grid, taking the largest value
at the four corners of the coarse cell a sample falls in: it changes slowly and is only
used to bound a search radius.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

import numpy as np
from numpy.typing import NDArray

from toolpath.surface import ParametricSurface, parameter_pairs

from .errors import VerificationError
from .vectors import row_norms

__all__ = ["DesignSamples", "sample_design", "surface_points_normals"]

FloatArray = NDArray[np.float64]

_PROBE: Final[int] = 65
"""Probe grid size for parameter speeds and curvature (65 x 65 evaluations)."""


@dataclass(frozen=True, eq=False)
class DesignSamples:
    """A parameter grid of design-surface samples.

    Attributes
    ----------
    t, s : ndarray, shapes (n_t,), (n_s,)
        Parameter values of the grid lines.
    points : ndarray, shape (n_t, n_s, 3)
        Surface points, mm (workpiece frame).
    normals : ndarray, shape (n_t, n_s, 3)
        Unit outward normals (zero where the parametrization is degenerate).
    area_mm2 : ndarray, shape (n_t, n_s)
        Area each sample stands for, mm^2 (sums to the surface area).
    convexity_per_mm : ndarray, shape (n_t, n_s)
        ``max(-k_min, 0)`` bounded over the surrounding coarse cell, 1/mm.
    spacing_t_mm, spacing_s_mm : float
        Largest distance between neighbouring samples along ``t`` and ``s``, mm.
    """

    t: FloatArray
    s: FloatArray
    points: FloatArray
    normals: FloatArray
    area_mm2: FloatArray
    convexity_per_mm: FloatArray
    spacing_t_mm: float
    spacing_s_mm: float

    @property
    def shape(self) -> tuple[int, int]:
        """``(n_t, n_s)``."""
        return (self.t.shape[0], self.s.shape[0])

    @property
    def size(self) -> int:
        """Number of samples."""
        return self.t.shape[0] * self.s.shape[0]


def _speeds(surface: ParametricSurface) -> tuple[float, float]:
    g = np.linspace(0.0, 1.0, _PROBE)
    xt = surface.derivative(g, g, dt=1, ds=0, grid=True)
    xs = surface.derivative(g, g, dt=0, ds=1, grid=True)
    return float(np.linalg.norm(xt, axis=2).max()), float(np.linalg.norm(xs, axis=2).max())


def _convexity(surface: ParametricSurface, t: FloatArray, s: FloatArray) -> FloatArray:
    """Convexity at every sample, from a coarse grid (largest over the coarse cell)."""
    ct = np.linspace(0.0, 1.0, min(_PROBE, max(t.shape[0], 2)))
    cs = np.linspace(0.0, 1.0, min(_PROBE, max(s.shape[0], 2)))
    with np.errstate(invalid="ignore", divide="ignore"):
        k_min, _ = surface.principal_curvatures(ct, cs, grid=True)
    conv = np.nan_to_num(np.maximum(-k_min, 0.0), nan=0.0)
    cell = np.maximum(np.maximum(conv[:-1, :-1], conv[1:, :-1]),
                      np.maximum(conv[:-1, 1:], conv[1:, 1:]))
    it = np.clip(np.searchsorted(ct, t, side="right") - 1, 0, cell.shape[0] - 1)
    js = np.clip(np.searchsorted(cs, s, side="right") - 1, 0, cell.shape[1] - 1)
    return cell[np.ix_(it, js)]


def _trapezoid(x: FloatArray, closed: bool) -> FloatArray:
    if x.shape[0] == 1:
        return np.ones(1)
    step = np.diff(x)
    w = np.zeros_like(x)
    if closed:
        return np.full_like(x, 1.0 / x.shape[0])
    w[:-1] += 0.5 * step
    w[1:] += 0.5 * step
    return w


def surface_points_normals(surface: ParametricSurface, t: FloatArray, s: FloatArray,
                           *, grid: bool = False) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Points, unit outward normals and ``|X_t x X_s|`` (mm^2 per unit parameter area).

    Parameters
    ----------
    surface : ParametricSurface
        The design surface.
    t, s : ndarray
        Parameters (broadcast, or the outer grid with ``grid=True``).
    grid : bool
        Evaluate on the grid ``t x s``.

    Returns
    -------
    points, normals : ndarray, shape (..., 3)
        Points in mm and unit normals (zero where the parametrization degenerates).
    jacobian_mm2 : ndarray, shape (...)
        Area element ``|X_t x X_s|``.
    """
    # the three partials in one evaluation (one pass of a compiled surface's kernel)
    flat_t, flat_s, shape = parameter_pairs(t, s, grid)
    parts = surface.partials_many(flat_t, flat_s, ((0, 0), (1, 0), (0, 1)))
    points, xt, xs = (parts[order].reshape((*shape, 3)) for order in ((0, 0), (1, 0), (0, 1)))
    cross = np.cross(xt, xs)
    jac = row_norms(cross)
    ok = jac > 1e-12 * np.maximum(row_norms(xt) * row_norms(xs),
                                  1e-300)
    normals = np.where(ok[..., None], cross / np.where(ok, jac, 1.0)[..., None], 0.0)
    return points, surface.orientation * normals, jac


def sample_design(surface: ParametricSurface, *, spacing_t_mm: float, spacing_s_mm: float,
                  max_samples: int) -> DesignSamples:
    """Sample the design surface on a grid no coarser than the asked spacings.

    Parameters
    ----------
    surface : ParametricSurface
        The design surface (workpiece frame, mm).
    spacing_t_mm, spacing_s_mm : float
        Largest distance between neighbouring samples along ``t`` and ``s``, mm.
    max_samples : int
        When the grid would hold more samples, both spacings grow by the same factor
        (keeping their ratio) until it does not.

    Returns
    -------
    DesignSamples

    Raises
    ------
    VerificationError
        For non-positive spacings or a surface with no extent.
    """
    for name, value in (("spacing_t_mm", spacing_t_mm), ("spacing_s_mm", spacing_s_mm)):
        if not (math.isfinite(value) and value > 0.0):
            raise VerificationError(f"{name} must be a finite length > 0 mm, got {value!r}")
    speed_t, speed_s = _speeds(surface)
    if not (speed_t > 0.0 and speed_s > 0.0):
        raise VerificationError(
            f"the surface has no extent (largest |X_t| = {speed_t!r}, |X_s| = {speed_s!r} mm)")
    n_t = max(math.ceil(speed_t / spacing_t_mm) + 1, 2)
    n_s = max(math.ceil(speed_s / spacing_s_mm) + 1, 2)
    if n_t * n_s > max_samples:
        scale = math.sqrt(n_t * n_s / max_samples)
        n_t = max(int(n_t / scale), 2)
        n_s = max(int(n_s / scale), 2)
    closed = bool(getattr(surface, "closed_t", False))
    t = np.linspace(0.0, 1.0, n_t, endpoint=not closed)
    s = np.linspace(0.0, 1.0, n_s)
    points, normals, jac = surface_points_normals(surface, t, s, grid=True)
    area = jac * np.outer(_trapezoid(t, closed), _trapezoid(s, False))
    step_t = speed_t / (n_t - (0 if closed else 1))
    step_s = speed_s / (n_s - 1)
    return DesignSamples(t=t, s=s, points=points, normals=normals, area_mm2=area,
                         convexity_per_mm=_convexity(surface, t, s),
                         spacing_t_mm=float(step_t), spacing_s_mm=float(step_s))
