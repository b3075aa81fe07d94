"""Placing a surface in the workpiece frame: ``X'(t, s) = Q X(t, s) + d``.

A fitted blade comes in its design frame (for the development blade the stacking axis is
+x); the machine wants it in the workpiece frame of a setup (standing on the C table with
the stacking axis +Z, or lying on a router bed with the side to cut facing +Z).
:class:`PlacedSurface` is the rigid motion of a surface (a rotation keeps the parameters,
the closure and the outward side); :func:`rotation_from_spec` reads ``"y:-90,z:30"``
(successive right-handed rotations about the fixed axes, deg), :func:`spec_from_rotation`
writes one.

Examples
--------
>>> import numpy as np
>>> from toolpath.planning.analytic import PlaneSurface
>>> placed = PlacedSurface(PlaneSurface(), rotation_from_spec("y:-90"), (0.0, 0.0, 5.0))
>>> placed(0.0, 0.0).round(6).tolist(), placed.normal(0.5, 0.5).round(6).tolist()
([0.0, 0.0, 5.0], [-1.0, 0.0, 0.0])
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..compiled import StreamlineKernel
from ..errors import InvalidParameterError
from ..surface import ParametricSurface

__all__ = ["PlacedSurface", "centred_on_table", "rotation_from_spec", "spec_from_rotation"]

#: A rotation's ``Q Q^T`` may differ from the identity by this (per entry): a matrix built
#: in doubles is orthonormal to 1e-15, a product of a few to 1e-13; any real shear or
#: scale is far above it.
_ORTHONORMAL_ATOL = 1e-9


def _axis_rotation(axis: str, angle_deg: float) -> NDArray[np.float64]:
    c, s = np.cos(np.radians(angle_deg)), np.sin(np.radians(angle_deg))
    if axis == "x":
        return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    if axis == "y":
        return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rotation_from_spec(spec: str) -> NDArray[np.float64]:
    """Rotation matrix from ``"AXIS:DEG[,AXIS:DEG...]"`` (fixed axes, applied in order).

    Raises
    ------
    InvalidParameterError
        Naming the spec and the bad item.
    """
    out = np.eye(3)
    if not spec.strip():
        return out
    for item in spec.split(","):
        axis, _, value = item.strip().partition(":")
        axis = axis.strip().lower()
        try:
            angle = float(value)
        except ValueError:
            angle = float("nan")
        if axis not in ("x", "y", "z") or not np.isfinite(angle):
            raise InvalidParameterError(
                f"rotation {spec!r}: item {item.strip()!r} must be AXIS:DEG with AXIS one of "
                "x, y, z (e.g. 'y:-90,z:30')")
        out = _axis_rotation(axis, angle) @ out
    return out


def spec_from_rotation(rotation: ArrayLike) -> str:
    """``"x:A,y:B,z:C"`` (tenths of a degree, zeros left out) that reads back as ``rotation``.

    The rotations about fixed x, then y, then z: ``R = R_z(C) R_y(B) R_x(A)``
    (:func:`rotation_from_spec`'s order); ``""`` for the identity.
    """
    from scipy.spatial.transform import Rotation

    angles = Rotation.from_matrix(np.asarray(rotation, dtype=float)).as_euler("xyz",
                                                                              degrees=True)
    return ",".join(f"{axis}:{angle:.1f}".replace(".0", "")
                    for axis, angle in zip("xyz", angles, strict=True) if abs(angle) >= 0.05)


class PlacedSurface(ParametricSurface):
    """``Q X + d`` for a rotation ``Q`` and a translation ``d`` (mm).

    Parameters
    ----------
    surface : ParametricSurface
        The surface in its own frame.
    rotation : array_like, shape (3, 3)
        A proper rotation (orthonormal, determinant +1).
    translation_mm : array_like, shape (3,)
        Added after the rotation.
    """

    def __init__(self, surface: ParametricSurface, rotation: ArrayLike,
                 translation_mm: ArrayLike = (0.0, 0.0, 0.0)) -> None:
        q = np.asarray(rotation, dtype=float)
        if q.shape != (3, 3) or not np.allclose(q @ q.T, np.eye(3), atol=_ORTHONORMAL_ATOL) \
                or np.linalg.det(q) < 0.0:
            raise InvalidParameterError("rotation must be a proper 3x3 rotation matrix")
        d = np.asarray(translation_mm, dtype=float)
        if d.shape != (3,) or not np.isfinite(d).all():
            raise InvalidParameterError(f"translation_mm must be 3 finite numbers, got "
                                        f"{translation_mm!r}")
        self.base = surface
        self.rotation = q
        self.translation = d
        self.closed_t = surface.closed_t
        self.orientation = surface.orientation

    def _partials(self, t: NDArray[np.float64], s: NDArray[np.float64], dt: int, ds: int
                  ) -> NDArray[np.float64]:
        if self.kernel() is not None:  # (placed in the compiled pass)
            return self.partials_many(t, s, ((dt, ds),))[dt, ds]
        out = self.base._partials(t, s, dt, ds) @ self.rotation.T
        return out + self.translation if (dt, ds) == (0, 0) else out

    def partials_many(self, t: NDArray[np.float64], s: NDArray[np.float64],
                       orders: tuple[tuple[int, int], ...]
                       ) -> dict[tuple[int, int], NDArray[np.float64]]:
        """The base surface's partials in one pass (it may share work), then placed."""
        if self.kernel() is not None:
            return super().partials_many(t, s, orders)
        out = {order: d @ self.rotation.T
               for order, d in self.base.partials_many(t, s, orders).items()}
        if (0, 0) in out:
            out[(0, 0)] += self.translation
        return out

    def kernel(self) -> StreamlineKernel | None:
        """The base surface's compiled form, placed (None where the base has none)."""
        return self._compiled

    @functools.cached_property
    def _compiled(self) -> StreamlineKernel | None:
        base = self.base.kernel()
        return None if base is None else base.placed(self.rotation, self.translation)

    def __repr__(self) -> str:
        return (f"PlacedSurface({self.base!r}, rotation={self.rotation.round(6).tolist()}, "
                f"translation_mm={self.translation.tolist()})")


def centred_on_table(surface: ParametricSurface, rotation: ArrayLike, *,
                     base_height_mm: float = 20.0, probe: int = 65) -> PlacedSurface:
    """Rotate, then centre the bounding box on the table axis, its bottom on the table.

    The box's centre goes to x = y = 0 and its lowest point to z = ``base_height_mm``.
    """
    turned = PlacedSurface(surface, rotation)
    g = np.linspace(0.0, 1.0, probe)
    pts = turned(g, g, grid=True).reshape(-1, 3)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    shift = np.array([-(lo[0] + hi[0]) / 2.0, -(lo[1] + hi[1]) / 2.0, base_height_mm - lo[2]])
    return PlacedSurface(surface, rotation, shift)
