"""Placing measured blade points on the machine table (the setup) before fitting.

Measured sections come in the part's own frame (for a blade: the engine frame). A machine
cuts in its workpiece frame, whose origin is the work offset on the table (G54) and whose
+Z is up. A **placement** is the rigid motion ``x' = R x + d`` (``det R = 1``) taking one to
the other; it is reported with the program so the operator fixtures the part the same way.

Two setups cover blades, from the principal axes of the points (largest spread = span,
smallest = thickness):

- ``"flat"``: span along X, thickness along Z, the chosen side facing +Z (3-axis finishing
  of one side; the other side needs a second setup, flipped: ``side="second"``);
- ``"upright"``: span along Z (hub down), thickness along Y (5-axis: the tool reaches
  around the airfoil from the side).

The placed part's bounding box is centred on the origin in X and Y, and its lowest point
sits ``base_mm`` above the table (room for a fixture under a blade root). Whether the path
planned on it then stays inside the machine's travel is known only once it is planned:
:func:`toolpath.planning.travel.fit_travel` finds the smallest shift that makes it, and
:meth:`Placement.shifted` and :func:`translated_surface` apply it to the placement and to the
fitted surface (exactly: a rigid shift moves the planned path by the same vector).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .errors import InvalidParameterError
from .surface import ParametricSurface

__all__ = ["PLACEMENT_MODES", "Placement", "place_points", "translated_surface"]

PLACEMENT_MODES = ("flat", "upright", "none")


@dataclass(frozen=True)
class Placement:
    """``x' = rotation @ x + offset_mm``: part frame -> machine workpiece frame."""

    rotation: NDArray[np.float64]
    offset_mm: NDArray[np.float64]
    mode: str

    def apply(self, points: NDArray[np.float64]) -> NDArray[np.float64]:
        """Placed points (any leading shape, last axis 3)."""
        return points @ self.rotation.T + self.offset_mm

    def shifted(self, shift_mm: NDArray[np.float64]) -> Placement:
        """The same setup moved by ``shift_mm`` (workpiece frame, mm)."""
        return Placement(self.rotation, self.offset_mm + np.asarray(shift_mm, dtype=float),
                         self.mode)

    def describe(self) -> str:
        """One line for reports and program headers."""
        rows = "; ".join(" ".join(f"{v:+.6f}" for v in row) for row in self.rotation)
        offset = " ".join(f"{v:+.3f}" for v in self.offset_mm)
        return f"placement {self.mode}: x' = R x + d, R = [{rows}], d = [{offset}] mm"

    def as_dict(self) -> dict[str, object]:
        """JSON-ready form."""
        return {"mode": self.mode, "rotation": self.rotation.tolist(),
                "offset_mm": self.offset_mm.tolist()}


def _principal_axes(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rows: unit principal directions, largest spread first (right-handed)."""
    centred = points - points.mean(axis=0)
    _, _, vt = np.linalg.svd(centred, full_matrices=False)
    if np.linalg.det(vt) < 0:
        vt[2] = -vt[2]
    return vt


def place_points(points: NDArray[np.float64], *, mode: str = "flat", side: str = "first",
                 base_mm: float = 0.0) -> tuple[NDArray[np.float64], Placement]:
    """Place sections ``(m, n, 3)`` (or any ``(..., 3)`` points) on the table.

    Parameters
    ----------
    points : ndarray, shape (..., 3)
        Points in the part frame (mm); for sections, row ``j`` of the first axis is section
        ``j`` hub to tip, so the span runs hub -> tip.
    mode : {"flat", "upright", "none"}
        The setup (see the module); ``"none"`` keeps the part frame as the workpiece frame.
    side : {"first", "second"}
        ``"flat"`` only: which side faces +Z. ``"first"`` is the side of the first half of
        each section (for the bundled blade: the suction side).
    base_mm : float
        Height of the part's lowest point above the table (Z = 0).

    Returns
    -------
    placed, placement
    """
    if mode not in PLACEMENT_MODES:
        raise InvalidParameterError(f"placement must be one of {PLACEMENT_MODES}, got {mode!r}")
    if side not in ("first", "second"):
        raise InvalidParameterError(f"side must be 'first' or 'second', got {side!r}")
    pts = np.asarray(points, dtype=float)
    flat = pts.reshape(-1, 3)
    if mode == "none":
        return pts.copy(), Placement(np.eye(3), np.zeros(3), "none")
    span, _, thin = _principal_axes(flat)
    if pts.ndim == 3:  # hub -> tip along +span
        if (pts[-1].mean(axis=0) - pts[0].mean(axis=0)) @ span < 0:
            span = -span
        first_half = pts[:, : pts.shape[1] // 2].reshape(-1, 3).mean(axis=0)
        if (first_half - flat.mean(axis=0)) @ thin < 0:
            thin = -thin  # +thin points towards the first half's side
    if side == "second":
        thin = -thin
    if mode == "flat":
        x_axis, z_axis = span, thin
    else:
        x_axis, z_axis = np.cross(thin, span), span
        x_axis /= np.linalg.norm(x_axis)
    y_axis = np.cross(z_axis, x_axis)
    rotation = np.stack([x_axis, y_axis / np.linalg.norm(y_axis), z_axis])
    turned = flat @ rotation.T
    lo, hi = turned.min(axis=0), turned.max(axis=0)
    offset = np.array([-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, float(base_mm) - lo[2]])
    placement = Placement(rotation, offset, mode if mode == "upright" else f"flat/{side}")
    return placement.apply(pts), placement


def translated_surface(surface: ParametricSurface, shift_mm: NDArray[np.float64]
                       ) -> ParametricSurface:
    """``X(t, s) + d``: the surface moved by ``shift_mm`` (mm), the same kind where possible.

    A fitted surface stays a fitted surface (it saves to the same JSON): a B-spline's
    section rows are control points, each moved by ``d`` (a clamped B-spline's basis sums
    to one); a streamline surface ``X = -c + T^{-1}[Z_0 exp G]`` with ``Z_0 = T (X_0 + c)``
    keeps ``Z_0`` and ``G`` when ``X_0`` moves by ``d`` and ``c`` by ``-d``. Any other
    surface is wrapped in a :class:`~toolpath.planning.setup.PlacedSurface`.
    """
    from .bspline_surface import BSplineSurface
    from .planning.setup import PlacedSurface
    from .streamline_surface import StreamlineSurface

    d = np.asarray(shift_mm, dtype=float)
    if d.shape != (3,) or not np.isfinite(d).all():
        raise InvalidParameterError(f"shift_mm must be 3 finite numbers, got {shift_mm!r}")
    if isinstance(surface, StreamlineSurface):
        rows = surface.row_coef.copy()
        rows[:, -3:] += d
        return dataclasses.replace(surface, row_coef=rows, c=surface.c - d)
    if isinstance(surface, BSplineSurface):
        rows = (surface.row_coef.reshape(len(surface.row_coef), -1, 3) + d).reshape(
            surface.row_coef.shape)
        return dataclasses.replace(surface, row_coef=rows)
    return PlacedSurface(surface, np.eye(3), d)
