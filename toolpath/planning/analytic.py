"""Analytic surfaces with exact partials, for tests, demos and benchmarks.

Each is a :class:`~toolpath.surface.ParametricSurface` on the unit square with closed-form
first and second partials, so the planner's geometry can be checked against known answers:

* :class:`PlaneSurface` ``X = O + t U + s V`` (curvature 0);
* :class:`SpherePatch` ``X = C + R (sin th cos ph, sin th sin ph, cos th)``, ``t`` along the
  longitude ``ph`` (passes are latitude circles), ``s`` along the colatitude ``th``;
  outward normals (convex, ``k = -1/R``) or, with ``inside=True``, a bowl (``k = +1/R``);
* :class:`CylinderPatch` about the x axis, ``X = (x, R sin al, R cos al)``, passes around
  (``t`` = angle, closed when the angle spans 360 deg) or along (``t`` = x);
* :class:`PocketSurface` a plane ``z = -d exp(-rho^2 / (2 w^2))`` with a Gaussian dimple,
  whose smallest concave radius ``w^2 / d`` is at the bottom (for gouge tests);
* :class:`EllipticBladeSurface` closed elliptic sections ``(a cos 2pi t, b sin 2pi t)``
  stacked along z with ``a``, ``b`` linear in ``s``: a blade-like closed surface whose
  edges have the small radius ``b^2 / a``.

:meth:`to_dict` / :func:`analytic_surface_from_dict` write and read a JSON form with a
``format_version``; other versions are refused.
"""

from __future__ import annotations

from abc import abstractmethod
from typing import Any, ClassVar, Final

import numpy as np
from numpy.typing import NDArray

from ..errors import InvalidParameterError
from ..surface import ParametricSurface
from ..tolerances import ANGLE_SLACK_DEG, ROUND_OFF, TINY

__all__ = [
    "ANALYTIC_FORMAT_VERSION",
    "AnalyticSurface",
    "CylinderPatch",
    "EllipticBladeSurface",
    "PlaneSurface",
    "PocketSurface",
    "SpherePatch",
    "analytic_surface_from_dict",
]

ANALYTIC_FORMAT_VERSION: Final[int] = 1
"""Version of the JSON form written by :meth:`AnalyticSurface.to_dict`."""


def _vec3(value: Any, name: str) -> tuple[float, float, float]:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (3,) or not np.isfinite(arr).all():
        raise InvalidParameterError(f"{name} must be 3 finite numbers (mm), got {value!r}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def _positive(value: Any, name: str) -> float:
    out = float(value)
    if not np.isfinite(out) or out <= 0.0:
        raise InvalidParameterError(f"{name} must be a finite length > 0 mm, got {value!r}")
    return out


def _range(value: Any, name: str) -> tuple[float, float]:
    arr = np.asarray(value, dtype=float)
    if arr.shape != (2,) or not np.isfinite(arr).all() or arr[0] == arr[1]:
        raise InvalidParameterError(f"{name} must be two different finite numbers, "
                                    f"got {value!r}")
    return (float(arr[0]), float(arr[1]))


class AnalyticSurface(ParametricSurface):
    """Base of the analytic surfaces: JSON form and orientation from an outward hint."""

    kind: ClassVar[str]

    @abstractmethod
    def params(self) -> dict[str, Any]:
        """Constructor keywords (JSON-able) that rebuild the surface."""

    def to_dict(self) -> dict[str, Any]:
        """JSON form: ``{"kind", "format_version", "params"}``."""
        return {"kind": self.kind, "format_version": ANALYTIC_FORMAT_VERSION,
                "params": self.params()}

    def _orient(self, outward: NDArray[np.float64], t: float = 0.5, s: float = 0.5) -> None:
        """Set ``orientation`` so the normal at ``(t, s)`` agrees with ``outward``."""
        xt = self._partials(np.array([t]), np.array([s]), 1, 0)[0]
        xs = self._partials(np.array([t]), np.array([s]), 0, 1)[0]
        self.orientation = 1.0 if float(np.cross(xt, xs) @ outward) >= 0.0 else -1.0

    def closest_parameters(self, points_mm: NDArray[np.float64]
                           ) -> tuple[NDArray[np.float64], ...] | None:
        """The closest surface points' ``t``, ``s`` in closed form, where there is one.

        Returns ``t``, ``s`` and ``exact`` (n,): the rows whose closest point on the
        surface's own closed form lies within the unit square (the others are the clamped
        parameters, a seed only); None where the surface has no closed form
        (:func:`~.local.project_to_surface` then searches every point by Newton's method).
        """
        return None

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.params().items())
        return f"{type(self).__name__}({args})"


class PlaneSurface(AnalyticSurface):
    """``X(t, s) = O + t U + s V``; normal ``U x V`` (the cutter's side).

    Parameters
    ----------
    origin_mm : 3 floats
        ``X(0, 0)``.
    t_vector_mm, s_vector_mm : 3 floats
        Edge vectors along ``t`` (the passes) and ``s``, mm.
    """

    kind = "analytic_plane"

    def __init__(self, origin_mm=(0.0, 0.0, 0.0), t_vector_mm=(40.0, 0.0, 0.0),
                 s_vector_mm=(0.0, 30.0, 0.0)) -> None:
        self.origin = np.array(_vec3(origin_mm, "origin_mm"))
        self.u = np.array(_vec3(t_vector_mm, "t_vector_mm"))
        self.v = np.array(_vec3(s_vector_mm, "s_vector_mm"))
        if np.linalg.norm(np.cross(self.u, self.v)) <= ROUND_OFF * (
                np.linalg.norm(self.u) * np.linalg.norm(self.v) + TINY):
            raise InvalidParameterError("t_vector_mm and s_vector_mm must not be parallel")

    def params(self) -> dict[str, Any]:
        """Constructor keywords."""
        return {"origin_mm": self.origin.tolist(), "t_vector_mm": self.u.tolist(),
                "s_vector_mm": self.v.tolist()}

    def _partials(self, t, s, dt, ds):
        n = t.size
        if (dt, ds) == (0, 0):
            return self.origin + t[:, None] * self.u + s[:, None] * self.v
        if (dt, ds) == (1, 0):
            return np.broadcast_to(self.u, (n, 3)).copy()
        if (dt, ds) == (0, 1):
            return np.broadcast_to(self.v, (n, 3)).copy()
        return np.zeros((n, 3))


class _SharedTrigonometry:
    """A surface whose partials share one evaluation of its trigonometry.

    ``_trig(t, s)`` computes it, ``_partials_of(trig, dt, ds)`` a partial from it.

    (:meth:`partials_many` gives the same values as :meth:`_partials` order by order: a
    frame's six partials took six times the trigonometry, most of a Newton step's cost.)
    """

    def partials_many(self, t: NDArray[np.float64], s: NDArray[np.float64],
                      orders: tuple[tuple[int, int], ...]
                      ) -> dict[tuple[int, int], NDArray[np.float64]]:
        """Several partials at once, the trigonometry computed once for all of them."""
        trig = self._trig(t, s)
        return {order: self._partials_of(trig, *order) for order in orders}

    def _partials(self, t, s, dt, ds):
        return self._partials_of(self._trig(t, s), dt, ds)


class SpherePatch(_SharedTrigonometry, AnalyticSurface):
    """Part of a sphere: ``t`` along the longitude, ``s`` along the colatitude.

    Parameters
    ----------
    radius_mm : float
        Sphere radius ``R``.
    centre_mm : 3 floats
        Sphere centre.
    longitude_deg : 2 floats
        Longitude at ``t = 0`` and ``t = 1``.
    colatitude_deg : 2 floats
        Colatitude (from +z) at ``s = 0`` and ``s = 1``; both strictly inside (0, 180)
        (the pole is a singular point of this parametrization).
    inside : bool
        ``False``: material inside, convex (``k = -1/R``); ``True``: a bowl, concave.
    """

    kind = "analytic_sphere"

    def __init__(self, radius_mm=50.0, centre_mm=(0.0, 0.0, 0.0),
                 longitude_deg=(-30.0, 30.0), colatitude_deg=(30.0, 60.0),
                 inside=False) -> None:
        self.radius = _positive(radius_mm, "radius_mm")
        self.centre = np.array(_vec3(centre_mm, "centre_mm"))
        self.lon = _range(longitude_deg, "longitude_deg")
        self.colat = _range(colatitude_deg, "colatitude_deg")
        if not all(0.5 <= c <= 179.5 for c in self.colat):
            raise InvalidParameterError(
                f"colatitude_deg must stay within [0.5, 179.5] deg (the poles are "
                f"singular), got {colatitude_deg!r}")
        self.inside = bool(inside)
        self._ph0, self._th0 = np.radians(self.lon[0]), np.radians(self.colat[0])
        self._dph = np.radians(self.lon[1] - self.lon[0])
        self._dth = np.radians(self.colat[1] - self.colat[0])
        mid_ph = self._ph0 + 0.5 * self._dph
        mid_th = self._th0 + 0.5 * self._dth
        radial = np.array([np.sin(mid_th) * np.cos(mid_ph), np.sin(mid_th) * np.sin(mid_ph),
                           np.cos(mid_th)])
        self._orient(-radial if self.inside else radial)

    def params(self) -> dict[str, Any]:
        """Constructor keywords."""
        return {"radius_mm": self.radius, "centre_mm": self.centre.tolist(),
                "longitude_deg": list(self.lon), "colatitude_deg": list(self.colat),
                "inside": self.inside}

    def _trig(self, t, s):
        """``sin ph, cos ph, sin th, cos th`` and zeros at flat ``t``, ``s``."""
        ph = self._ph0 + t * self._dph
        th = self._th0 + s * self._dth
        return np.sin(ph), np.cos(ph), np.sin(th), np.cos(th), np.zeros_like(t)

    def closest_parameters(self, points_mm: NDArray[np.float64]
                           ) -> tuple[NDArray[np.float64], ...]:
        """The closest points' ``t``, ``s``: the sphere's radial projection (exact).

        Every point but the centre has its closest sphere point on the ray from the centre
        through it (outside or inside alike), at longitude ``atan2(dy, dx)`` and colatitude
        ``atan2(sqrt(dx^2 + dy^2), dz)`` of ``d = p - C``; the longitude is taken within
        half a turn of the patch's middle. ``exact`` where that lies within the patch (to
        :data:`~toolpath.tolerances.ROUND_OFF` in ``t`` and ``s``, then clamped) and ``d``
        is not 0; the other rows' parameters clamped to the patch are a seed only.
        """
        d = np.asarray(points_mm, dtype=float).reshape(-1, 3) - self.centre
        rho = np.hypot(d[:, 0], d[:, 1])
        mid_ph = self._ph0 + 0.5 * self._dph
        turn = np.mod(np.arctan2(d[:, 1], d[:, 0]) - mid_ph + np.pi, 2.0 * np.pi) - np.pi
        t = 0.5 + turn / self._dph
        s = (np.arctan2(rho, d[:, 2]) - self._th0) / self._dth
        exact = ((t >= -ROUND_OFF) & (t <= 1.0 + ROUND_OFF) & (s >= -ROUND_OFF)
                 & (s <= 1.0 + ROUND_OFF) & ((rho > 0.0) | (d[:, 2] != 0.0)))
        return np.clip(t, 0.0, 1.0), np.clip(s, 0.0, 1.0), exact

    def _partials_of(self, trig, dt, ds):
        """The partial ``(dt, ds)`` from :meth:`_trig`'s values."""
        sp, cp, st, ct, zero = trig
        # derivatives of (sin th cos ph, sin th sin ph, cos th) in ph (k times) and th (j)
        if (dt, ds) == (0, 0):
            v = np.stack([st * cp, st * sp, ct], axis=1)
            return self.centre + self.radius * v
        if (dt, ds) == (1, 0):
            v = np.stack([-st * sp, st * cp, zero], axis=1) * self._dph
        elif (dt, ds) == (0, 1):
            v = np.stack([ct * cp, ct * sp, -st], axis=1) * self._dth
        elif (dt, ds) == (2, 0):
            v = np.stack([-st * cp, -st * sp, zero], axis=1) * self._dph**2
        elif (dt, ds) == (1, 1):
            v = np.stack([-ct * sp, ct * cp, zero], axis=1) * self._dph * self._dth
        else:
            v = np.stack([-st * cp, -st * sp, -ct], axis=1) * self._dth**2
        return self.radius * v


class CylinderPatch(AnalyticSurface):
    """Part of a cylinder about the x axis: ``X = C + (x, R sin al, R cos al)``.

    Parameters
    ----------
    radius_mm : float
        Cylinder radius ``R``.
    centre_mm : 3 floats
        A point on the axis (``x = 0`` of the patch).
    angle_deg : 2 floats
        Angle ``al`` from +z towards +y at the two ends; a span of exactly 360 deg with
        ``passes="around"`` makes the sections closed (``closed_t``).
    length_mm : 2 floats
        ``x`` at the two ends.
    passes : {"around", "along"}
        ``t`` runs around the axis (passes are circles; across them the surface is
        straight) or along it (passes are straight lines; across them, circles).
    """

    kind = "analytic_cylinder"

    def __init__(self, radius_mm=20.0, centre_mm=(0.0, 0.0, 0.0), angle_deg=(-60.0, 60.0),
                 length_mm=(0.0, 30.0), passes="around") -> None:
        self.radius = _positive(radius_mm, "radius_mm")
        self.centre = np.array(_vec3(centre_mm, "centre_mm"))
        self.angle = _range(angle_deg, "angle_deg")
        self.length = _range(length_mm, "length_mm")
        if passes not in ("around", "along"):
            raise InvalidParameterError(f"passes must be 'around' or 'along', got {passes!r}")
        self.passes = passes
        span = abs(self.angle[1] - self.angle[0])
        if span > 360.0:
            raise InvalidParameterError(f"angle_deg spans {span} deg > 360 deg")
        self.closed_t = passes == "around" and abs(span - 360.0) < ANGLE_SLACK_DEG
        self._a0 = np.radians(self.angle[0])
        self._da = np.radians(self.angle[1] - self.angle[0])
        self._x0, self._dx = self.length[0], self.length[1] - self.length[0]
        mid = self._a0 + 0.5 * self._da
        self._orient(np.array([0.0, np.sin(mid), np.cos(mid)]))

    def params(self) -> dict[str, Any]:
        """Constructor keywords."""
        return {"radius_mm": self.radius, "centre_mm": self.centre.tolist(),
                "angle_deg": list(self.angle), "length_mm": list(self.length),
                "passes": self.passes}

    def _partials(self, t, s, dt, ds):
        around, along = (t, s) if self.passes == "around" else (s, t)
        da = dt if self.passes == "around" else ds  # derivative order in the angle
        dx = ds if self.passes == "around" else dt  # derivative order in x
        al = self._a0 + around * self._da
        zero = np.zeros_like(t)
        if da == 0 and dx == 0:
            v = np.stack([self._x0 + along * self._dx, self.radius * np.sin(al),
                          self.radius * np.cos(al)], axis=1)
            return self.centre + v
        if da == 0 and dx == 1:
            return np.stack([np.full_like(t, self._dx), zero, zero], axis=1)
        if dx >= 1:  # mixed or second derivative in x: zero
            return np.zeros((t.size, 3))
        if da == 1:
            v = np.stack([zero, np.cos(al), -np.sin(al)], axis=1) * self._da
        else:
            v = np.stack([zero, -np.sin(al), -np.cos(al)], axis=1) * self._da**2
        return self.radius * v


class PocketSurface(AnalyticSurface):
    """Plane ``z = z0 - d exp(-rho^2 / (2 w^2))`` with a Gaussian pocket, normal up.

    ``X(t, s) = (x0 + t Lx, y0 + s Ly, f(x, y))``. At the bottom of the pocket both
    principal curvatures are ``d / w^2`` (concave), so the smallest concave radius is
    ``w^2 / d``; a ball larger than that gouges there.

    Parameters
    ----------
    size_mm : 2 floats
        ``(Lx, Ly)``.
    origin_mm : 3 floats
        ``(x0, y0, z0)``.
    centre_mm : 2 floats
        Pocket centre ``(xc, yc)``.
    depth_mm : float
        ``d`` (> 0 is a pocket; < 0 a bump).
    width_mm : float
        ``w``.
    """

    kind = "analytic_pocket"

    def __init__(self, size_mm=(40.0, 40.0), origin_mm=(0.0, 0.0, 0.0),
                 centre_mm=(20.0, 20.0), depth_mm=1.5, width_mm=2.0) -> None:
        size = np.asarray(size_mm, dtype=float)
        if size.shape != (2,) or not (np.isfinite(size).all() and (size > 0).all()):
            raise InvalidParameterError(f"size_mm must be two lengths > 0, got {size_mm!r}")
        self.size = (float(size[0]), float(size[1]))
        self.origin = np.array(_vec3(origin_mm, "origin_mm"))
        centre = np.asarray(centre_mm, dtype=float)
        if centre.shape != (2,) or not np.isfinite(centre).all():
            raise InvalidParameterError(f"centre_mm must be 2 numbers, got {centre_mm!r}")
        self.centre = (float(centre[0]), float(centre[1]))
        self.depth = float(depth_mm)
        if not np.isfinite(self.depth):
            raise InvalidParameterError(f"depth_mm must be finite, got {depth_mm!r}")
        self.width = _positive(width_mm, "width_mm")

    @property
    def min_concave_radius_mm(self) -> float:
        """``w^2 / d``, the radius at the bottom of the pocket (inf for a bump)."""
        return self.width**2 / self.depth if self.depth > 0.0 else float("inf")

    def params(self) -> dict[str, Any]:
        """Constructor keywords."""
        return {"size_mm": list(self.size), "origin_mm": self.origin.tolist(),
                "centre_mm": list(self.centre), "depth_mm": self.depth,
                "width_mm": self.width}

    def _partials(self, t, s, dt, ds):
        lx, ly = self.size
        x = self.origin[0] + t * lx
        y = self.origin[1] + s * ly
        dxc, dyc = x - self.centre[0], y - self.centre[1]
        w2 = self.width**2
        g = self.depth * np.exp(-(dxc**2 + dyc**2) / (2.0 * w2))
        zero = np.zeros_like(t)
        if (dt, ds) == (0, 0):
            return np.stack([x, y, self.origin[2] - g], axis=1)
        if (dt, ds) == (1, 0):
            return np.stack([np.full_like(t, lx), zero, lx * g * dxc / w2], axis=1)
        if (dt, ds) == (0, 1):
            return np.stack([zero, np.full_like(t, ly), ly * g * dyc / w2], axis=1)
        if (dt, ds) == (2, 0):
            return np.stack([zero, zero, lx * lx * g * (1.0 / w2 - dxc**2 / w2**2)], axis=1)
        if (dt, ds) == (1, 1):
            return np.stack([zero, zero, -lx * ly * g * dxc * dyc / w2**2], axis=1)
        return np.stack([zero, zero, ly * ly * g * (1.0 / w2 - dyc**2 / w2**2)], axis=1)


class EllipticBladeSurface(_SharedTrigonometry, AnalyticSurface):
    """Closed elliptic sections stacked along z: a blade-like closed surface.

    ``X(t, s) = (a(s) cos 2 pi t, b(s) sin 2 pi t, z0 + s H)`` with ``a``, ``b`` linear in
    ``s`` from the hub values to the tip values. The edges at ``t = 0`` and ``t = 1/2`` have
    the radius ``b^2 / a``; the flanks ``a^2 / b``.

    Parameters
    ----------
    semi_axes_hub_mm, semi_axes_tip_mm : 2 floats
        ``(a, b)`` at ``s = 0`` and ``s = 1``.
    z_range_mm : 2 floats
        ``(z0, z0 + H)``.
    """

    kind = "analytic_elliptic_blade"
    closed_t = True

    def __init__(self, semi_axes_hub_mm=(30.0, 6.0), semi_axes_tip_mm=(26.0, 4.0),
                 z_range_mm=(0.0, 40.0)) -> None:
        hub = np.asarray(semi_axes_hub_mm, dtype=float)
        tip = np.asarray(semi_axes_tip_mm, dtype=float)
        for name, v in (("semi_axes_hub_mm", hub), ("semi_axes_tip_mm", tip)):
            if v.shape != (2,) or not (np.isfinite(v).all() and (v > 0).all()):
                raise InvalidParameterError(f"{name} must be two lengths > 0, got {v!r}")
        self.hub = (float(hub[0]), float(hub[1]))
        self.tip = (float(tip[0]), float(tip[1]))
        self.z_range = _range(z_range_mm, "z_range_mm")
        self._orient(np.array([1.0, 0.0, 0.0]), t=0.0)  # at t = 0 outward is +x

    def params(self) -> dict[str, Any]:
        """Constructor keywords."""
        return {"semi_axes_hub_mm": list(self.hub), "semi_axes_tip_mm": list(self.tip),
                "z_range_mm": list(self.z_range)}

    def _trig(self, t, s):
        """``cos 2 pi t``, ``sin 2 pi t``, ``a(s)``, ``b(s)`` and ``s`` at flat ``t``, ``s``."""
        th = 2.0 * np.pi * t
        a0, b0 = self.hub
        return (np.cos(th), np.sin(th), a0 + s * (self.tip[0] - a0),
                b0 + s * (self.tip[1] - b0), s)

    def _partials_of(self, trig, dt, ds):
        """The partial ``(dt, ds)`` from :meth:`_trig`'s values."""
        w = 2.0 * np.pi
        a0, b0 = self.hub
        da, db = self.tip[0] - a0, self.tip[1] - b0
        height = self.z_range[1] - self.z_range[0]
        c, sn, a, b, s = trig
        zero = np.zeros_like(s)
        if (dt, ds) == (0, 0):
            return np.stack([a * c, b * sn, self.z_range[0] + s * height], axis=1)
        if (dt, ds) == (1, 0):
            return np.stack([-a * w * sn, b * w * c, zero], axis=1)
        if (dt, ds) == (0, 1):
            return np.stack([da * c, db * sn, np.full_like(s, height)], axis=1)
        if (dt, ds) == (2, 0):
            return np.stack([-a * w * w * c, -b * w * w * sn, zero], axis=1)
        if (dt, ds) == (1, 1):
            return np.stack([-da * w * sn, db * w * c, zero], axis=1)
        return np.zeros((s.size, 3))


_KINDS: dict[str, type[AnalyticSurface]] = {
    cls.kind: cls for cls in (PlaneSurface, SpherePatch, CylinderPatch, PocketSurface,
                              EllipticBladeSurface)}


def analytic_surface_from_dict(data: Any) -> AnalyticSurface:
    """Rebuild an analytic surface from :meth:`AnalyticSurface.to_dict` output.

    Raises
    ------
    InvalidParameterError
        For another kind, another ``format_version`` or bad parameters, naming them.
    """
    if not isinstance(data, dict) or data.get("kind") not in _KINDS:
        kind = data.get("kind") if isinstance(data, dict) else type(data).__name__
        raise InvalidParameterError(
            f"not an analytic surface: kind must be one of {sorted(_KINDS)}, got {kind!r}")
    version = data.get("format_version")
    if version != ANALYTIC_FORMAT_VERSION:
        raise InvalidParameterError(
            f"analytic surface format_version {version!r}; this program reads version "
            f"{ANALYTIC_FORMAT_VERSION}")
    params = data.get("params", {})
    if not isinstance(params, dict):
        raise InvalidParameterError(f"'params' must be an object, got {params!r}")
    try:
        return _KINDS[data["kind"]](**params)
    except TypeError as exc:
        raise InvalidParameterError(f"{data['kind']}: bad params: {exc}") from None
