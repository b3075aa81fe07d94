"""End mills: ball, flat and bull-nose (torus), their placement on a surface and their shape.

Industry convention, used in every spec string: **the number is the diameter in mm**
(``"ball:6"`` is a 6 mm ball-nose, radius 3 mm; ``"bull:10:2"`` a 10 mm bull-nose with a
2 mm corner radius). Internally every cutter is one shape: a cylinder of radius ``R``
(``radius_mm``) whose bottom edge is rounded with the corner radius ``r``
(``corner_radius_mm``): ``r = R`` is a ball, ``r = 0`` a flat end mill.

Geometry (unit surface normal ``n`` pointing out of the material, unit tool axis ``a``
from the tip towards the spindle, contact point ``P``):

* the radial direction of the contact, seen from the axis, is ``u = n_perp / |n_perp|``
  with ``n_perp = n - (n.a) a`` (``u = 0`` when ``n`` is parallel to ``a``: the flat face
  sits on the surface);
* the centre of the corner circle through the contact (the *core point*) is
  ``K = P + r n``, on the circle of radius ``R - r`` around the axis at height ``r`` above
  the tip: ``K = tip + r a - (R - r) u``;
* hence the cutter location (tool tip: the ball's bottom, the face centre) is
  ``tip = P + r n - r a + (R - r) u``. For a ball this is ``P + R (n - a)``.

The cutter's curvature at the contact (positive, curving towards ``n``): ``1 / r`` along
the meridian (the plane of ``a`` and ``u``) and ``|n_perp| / (R - r + r |n_perp|)`` along
the parallel ``a x u`` (Meusnier on the torus); in any other tangent direction Euler's
formula ``k(d) = k_mer cos^2 + k_par sin^2``. For a lead angle ``L`` on a bull-nose this
gives the classical effective radius ``(R - r) / sin L + r`` across the feed.

Examples
--------
>>> c = parse_cutter("ball:6")
>>> c.radius_mm, c.corner_radius_mm, c.spec
(3.0, 3.0, 'ball:6')
>>> parse_cutter("bull:10:2").corner_radius_mm
2.0
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InvalidParameterError
from ..vectors import unit
from .defaults import CUTTER_SPEC_HELP

__all__ = [
    "CUTTER_SPEC_HELP",
    "FLAT_EDGE_CURVATURE_PER_MM",
    "Cutter",
    "CutterKind",
    "parse_cutter",
    "radial_directions",
]

FLAT_EDGE_CURVATURE_PER_MM: Final[float] = 1.0e6
"""Curvature used for the sharp bottom edge of a flat end mill (1/mm): a 1 nm radius,
finite so the curvature algebra stays in floating point, far sharper than any surface."""

_PARALLEL_EPS: Final[float] = 1e-12
"""``|n_perp|`` below which the normal is taken as parallel to the tool axis."""

DEFAULT_FLUTE_DIAMETERS: Final[float] = 3.0
"""Default flute length in diameters: a standard-length finishing end mill."""


class CutterKind(StrEnum):
    """Shape family of an end mill."""

    BALL = "ball"
    FLAT = "flat"
    BULL = "bull"


def radial_directions(normals: ArrayLike, axes: ArrayLike
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``u = n_perp / |n_perp|`` and ``|n_perp|`` (``u = 0`` where ``n`` is along ``a``).

    Parameters
    ----------
    normals, axes : array_like, shape (..., 3)
        Unit surface normals and unit tool axes.

    Returns
    -------
    u : ndarray, shape (..., 3)
    sin_angle : ndarray, shape (...)
        ``|n_perp|``, the sine of the angle between normal and tool axis.
    """
    n = np.asarray(normals, dtype=float)
    a = np.asarray(axes, dtype=float)
    perp = n - np.einsum("...k,...k->...", n, a)[..., None] * a
    size = np.linalg.norm(perp, axis=-1)
    ok = size > _PARALLEL_EPS
    u = np.where(ok[..., None], perp / np.where(ok, size, 1.0)[..., None], 0.0)
    return u, np.where(ok, size, 0.0)


@dataclass(frozen=True)
class Cutter:
    """An end mill: cylinder of radius ``R`` with its bottom edge rounded by ``r``.

    Parameters
    ----------
    kind : CutterKind
        ``ball`` (``r = R``), ``flat`` (``r = 0``) or ``bull`` (``0 < r < R``).
    radius_mm : float
        Cutter radius ``R``, mm (half the diameter).
    corner_radius_mm : float
        Corner radius ``r``, mm.
    flute_length_mm : float
        Length of the cutting part from the tip, mm; the solid checked for gouges.
    """

    kind: CutterKind
    radius_mm: float
    corner_radius_mm: float
    flute_length_mm: float

    def __post_init__(self) -> None:
        try:
            kind = CutterKind(self.kind)
        except ValueError:
            raise InvalidParameterError(
                f"cutter kind must be one of {[k.value for k in CutterKind]}, "
                f"got {self.kind!r}") from None
        object.__setattr__(self, "kind", kind)
        for name in ("radius_mm", "corner_radius_mm", "flute_length_mm"):
            value = getattr(self, name)
            try:
                value = float(value)
            except (TypeError, ValueError):
                raise InvalidParameterError(
                    f"cutter {name} must be a number in mm, got {value!r}") from None
            if not math.isfinite(value) or value < 0.0:
                raise InvalidParameterError(
                    f"cutter {name} must be a finite length >= 0 mm, got {value!r}")
            object.__setattr__(self, name, value)
        big, small = self.radius_mm, self.corner_radius_mm
        if big <= 0.0:
            raise InvalidParameterError(f"cutter radius_mm must be > 0 mm, got {big!r}")
        if kind is CutterKind.BALL and small != big:
            raise InvalidParameterError(
                f"a ball cutter has corner_radius_mm == radius_mm ({big!r}), got {small!r}")
        if kind is CutterKind.FLAT and small != 0.0:
            raise InvalidParameterError(
                f"a flat cutter has corner_radius_mm == 0, got {small!r}")
        if kind is CutterKind.BULL and not 0.0 < small < big:
            raise InvalidParameterError(
                f"a bull-nose corner radius must lie strictly between 0 and the radius "
                f"{big!r} mm (diameter {2 * big!r}), got corner_radius_mm={small!r}")
        if self.flute_length_mm < big:
            raise InvalidParameterError(
                f"cutter flute_length_mm={self.flute_length_mm!r} must be at least the "
                f"radius {big!r} mm")

    # ------------------------------------------------------------------ naming
    @property
    def diameter_mm(self) -> float:
        """``2 R``, mm."""
        return 2.0 * self.radius_mm

    @property
    def spec(self) -> str:
        """The spec string that :func:`parse_cutter` reads back (diameter first)."""
        core = f"{self.kind.value}:{self.diameter_mm:g}"
        if self.kind is CutterKind.BULL:
            core += f":{self.corner_radius_mm:g}"
        return core

    def __str__(self) -> str:
        return (f"{self.spec} ({self.kind.value}-nose, diameter {self.diameter_mm:g} mm, "
                f"corner radius {self.corner_radius_mm:g} mm, flutes "
                f"{self.flute_length_mm:g} mm)")

    # ------------------------------------------------------------------ placement
    def tips_from_contacts(self, contacts_mm: ArrayLike, normals: ArrayLike,
                           axes: ArrayLike) -> NDArray[np.float64]:
        """Cutter locations (tool tips) touching the surface at the contact points.

        ``tip = P + r n - r a + (R - r) u`` (see the module docstring).

        Parameters
        ----------
        contacts_mm : array_like, shape (..., 3)
            Contact points ``P`` on the surface, mm.
        normals : array_like, shape (..., 3)
            Unit surface normals at ``P``, out of the material (the cutter's side).
        axes : array_like, shape (..., 3)
            Unit tool axes (tip towards spindle).

        Returns
        -------
        ndarray, shape (..., 3)
            Tool-tip positions, mm.
        """
        p = np.asarray(contacts_mm, dtype=float)
        n = np.asarray(normals, dtype=float)
        a = np.asarray(axes, dtype=float)
        r, big = self.corner_radius_mm, self.radius_mm
        if big == r:  # a ball: no flat part
            return p + r * n - r * a
        u, _ = radial_directions(n, a)
        return p + r * n - r * a + (big - r) * u

    # ------------------------------------------------------------------ curvature
    def curvature_tensor(self, normals: ArrayLike, axes: ArrayLike, e1: ArrayLike,
                         e2: ArrayLike) -> tuple[NDArray[np.float64], ...]:
        """The cutter's second fundamental form at the contact in the basis ``(e1, e2)``.

        ``C = k_mer m m^T + k_par p p^T`` with ``p = a x u`` (parallel) and ``m = n x p``
        (meridian), ``k_mer = 1 / r`` and ``k_par = |n_perp| / (R - r + r |n_perp|)``.
        Curvatures are positive (the cutter curves towards the normal side), 1/mm.
        A ball gives ``1/R`` in every direction; a flat or bull-nose face lying flat on
        the surface (``n`` along ``a``) gives 0.

        Parameters
        ----------
        normals, axes, e1, e2 : array_like, shape (..., 3)
            Unit normals, unit tool axes and an orthonormal tangent basis.

        Returns
        -------
        c11, c12, c22 : ndarray, shape (...)
            Components in 1/mm.
        """
        e1 = np.asarray(e1, dtype=float)
        e2 = np.asarray(e2, dtype=float)
        big, r = self.radius_mm, self.corner_radius_mm
        if self.kind is CutterKind.BALL:
            k = np.full(e1.shape[:-1], 1.0 / big)
            return k, np.zeros_like(k), k.copy()
        n = np.asarray(normals, dtype=float)
        a = np.asarray(axes, dtype=float)
        u, sin_na = radial_directions(n, a)
        k_mer = 1.0 / r if r > 0.0 else FLAT_EDGE_CURVATURE_PER_MM
        k_par = sin_na / ((big - r) + r * sin_na)
        flat_on = sin_na == 0.0
        k_mer = np.where(flat_on, 0.0, k_mer)
        p = np.cross(a, u)
        m = np.cross(n, p)
        pm1 = np.einsum("...k,...k->...", p, e1)
        pm2 = np.einsum("...k,...k->...", p, e2)
        mm1 = np.einsum("...k,...k->...", m, e1)
        mm2 = np.einsum("...k,...k->...", m, e2)
        c11 = k_mer * mm1 * mm1 + k_par * pm1 * pm1
        c12 = k_mer * mm1 * mm2 + k_par * pm1 * pm2
        c22 = k_mer * mm2 * mm2 + k_par * pm2 * pm2
        return c11, c12, c22

    def effective_radius_mm(self, normals: ArrayLike, axes: ArrayLike,
                            directions: ArrayLike) -> NDArray[np.float64]:
        """Radius of the cutter's normal section along a tangent direction, mm.

        ``1 / k(d)`` with Euler's formula on the cutter's principal curvatures (see
        :meth:`curvature_tensor`); ``inf`` where the flat face lies on the surface.
        """
        d = unit(np.asarray(directions, dtype=float))
        n = np.asarray(normals, dtype=float)
        other = np.cross(n, d)
        c11, _, _ = self.curvature_tensor(n, axes, d, other)
        with np.errstate(divide="ignore"):
            return np.where(c11 > 0.0, 1.0 / np.where(c11 > 0.0, c11, 1.0), np.inf)

    # ------------------------------------------------------------------ solid
    def signed_distance(self, points_mm: ArrayLike, tips_mm: ArrayLike,
                        axes: ArrayLike) -> NDArray[np.float64]:
        """Exact signed distance from points to the cutter solid, mm (< 0 inside).

        The solid is the set of points within ``r`` of the core cylinder
        ``{rho <= R - r, r <= z <= H - r}`` (``z`` along the axis from the tip, ``rho``
        from the axis, ``H`` the flute length): the flutes with the rounded bottom edge
        (and, harmlessly, a rounded top at the end of the flutes). Broadcasts
        ``points``, ``tips`` and ``axes`` over their leading dimensions.
        """
        p = np.asarray(points_mm, dtype=float) - np.asarray(tips_mm, dtype=float)
        a = np.asarray(axes, dtype=float)
        z = np.einsum("...k,...k->...", p, a)
        rho = np.sqrt(np.maximum(np.einsum("...k,...k->...", p, p) - z * z, 0.0))
        r, big, h = self.corner_radius_mm, self.radius_mm, self.flute_length_mm
        dx = rho - (big - r)
        dz = np.maximum(r - z, z - (h - r))
        outside = np.hypot(np.maximum(dx, 0.0), np.maximum(dz, 0.0))
        inside = np.minimum(np.maximum(dx, dz), 0.0)
        return outside + inside - r


def disc_basis(axes: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Two unit vectors spanning the plane perpendicular to each axis (rows)."""
    helper = np.where(np.abs(axes[:, :1]) < 0.9, np.array([[1.0, 0.0, 0.0]]),
                      np.array([[0.0, 1.0, 0.0]]))
    b1 = np.cross(axes, helper)
    b1 /= np.linalg.norm(b1, axis=1, keepdims=True)
    return b1, np.cross(axes, b1)


@dataclass(frozen=True, eq=False)
class CutterShadow:
    """The cutting end of flat or bull-nose cutters seen along directions ``d`` (rows).

    Projected along ``d`` onto a plane with axes ``ex``, ``ez`` (orthonormal, both
    perpendicular to ``d``), the core disc (radius ``R - r`` about the axis, centre ``c``)
    is the ellipse ``c + A w``, ``|w| <= 1``, with ``A = (R - r) [[b1.ex, b2.ex],
    [b1.ez, b2.ez]]`` (``b1``, ``b2`` spanning the disc); the cutting end is that ellipse
    grown by the corner radius ``r``. Its boundary point with outward normal
    ``nu = (sin th, -cos th)`` (``th = 0`` faces ``-ez``) is ``c + A A^T nu / |A^T nu| + r nu``
    exactly (a disc seen edge-on jumps across its flat bottom at one angle). It is the
    section of the cutter swept straight along ``d``. The point itself, and where along
    ``d`` its cutter point lies: :func:`~toolpath.planning.cutter_kernel.shadow_point`.
    """

    centre_x: NDArray[np.float64]
    centre_z: NDArray[np.float64]
    matrix: tuple[NDArray[np.float64], ...]
    corner_radius_mm: float
    #: ``d . c`` and ``(R - r) (b1 . d, b2 . d)``: where along ``d`` the cutter points
    #: casting the boundary lie (see :func:`~toolpath.planning.cutter_kernel.shadow_point`)
    depth_centre: NDArray[np.float64]
    depth_matrix: tuple[NDArray[np.float64], ...]

    @classmethod
    def seen_along(cls, core_radius_mm: float, corner_radius_mm: float,
                   centre: NDArray[np.float64], axes: NDArray[np.float64],
                   ex: NDArray[np.float64], ez: NDArray[np.float64]) -> CutterShadow:
        """From the core disc centres (relative to the plane's origin), axes and plane axes.

        The view direction is ``d = ex x ez``.
        """
        b1, b2 = disc_basis(axes)

        def dot(u: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
            return np.einsum("ij,ij->i", u, v)

        d = np.cross(ex, ez)
        matrix = tuple(core_radius_mm * dot(b, e) for e in (ex, ez) for b in (b1, b2))
        depth = tuple(core_radius_mm * dot(b, d) for b in (b1, b2))
        return cls(dot(centre, ex), dot(centre, ez), matrix, corner_radius_mm,
                   dot(centre, d), depth)

def parse_cutter(spec: str, *, flute_length_mm: float | None = None) -> Cutter:
    """Read a cutter spec such as ``"ball:6"``, ``"flat:10"`` or ``"bull:10:2"``.

    Parameters
    ----------
    spec : str
        ``KIND:DIAMETER[:CORNER_RADIUS][:flute=LENGTH]`` in mm; the number after the kind
        is the **diameter** (industry convention). ``bull`` needs the corner radius.
    flute_length_mm : float, optional
        Flute length, mm; overrides ``flute=`` in the spec. Default three diameters.

    Returns
    -------
    Cutter

    Raises
    ------
    InvalidParameterError
        Naming the spec and the expected form.
    """
    if not isinstance(spec, str):
        raise InvalidParameterError(f"cutter spec must be a string ({CUTTER_SPEC_HELP}), "
                                    f"got {spec!r}")
    fields = [f.strip() for f in spec.strip().split(":")]
    flute = None
    if fields and fields[-1].lower().startswith("flute="):
        flute = fields.pop()[len("flute="):]
    kind = fields[0].lower() if fields else ""
    expected = {"ball": 2, "flat": 2, "bull": 3}
    if kind not in expected:
        raise InvalidParameterError(f"cutter spec {spec!r}: unknown kind {kind!r}; "
                                    f"expected {CUTTER_SPEC_HELP}")
    if len(fields) != expected[kind]:
        raise InvalidParameterError(
            f"cutter spec {spec!r}: a {kind} cutter takes {expected[kind] - 1} number(s) "
            f"after the kind; expected {CUTTER_SPEC_HELP}")
    try:
        numbers = [float(f) for f in fields[1:]]
        flute_value = float(flute) if flute is not None else None
    except ValueError:
        raise InvalidParameterError(f"cutter spec {spec!r}: not a number; expected "
                                    f"{CUTTER_SPEC_HELP}") from None
    diameter = numbers[0]
    if not math.isfinite(diameter) or diameter <= 0.0:
        raise InvalidParameterError(
            f"cutter spec {spec!r}: the diameter must be > 0 mm, got {diameter!r}")
    radius = diameter / 2.0
    corner = {"ball": radius, "flat": 0.0}.get(kind, numbers[-1])
    if flute_length_mm is not None:
        flute_value = float(flute_length_mm)
    if flute_value is None:
        flute_value = DEFAULT_FLUTE_DIAMETERS * diameter
    try:
        return Cutter(CutterKind(kind), radius, corner, flute_value)
    except InvalidParameterError as exc:
        raise InvalidParameterError(f"cutter spec {spec!r}: {exc}") from None
