"""The parametric surface every planner reads: ``X(t, s)`` on the unit square.

``t`` runs along the sections (the streamline, cutting direction) and ``s`` across them. A
subclass supplies only its partial derivatives (``_partials``); this base turns them into
evaluation on scattered pairs or grids, unit normals, the fundamental forms and curvatures,
so fitted surfaces (streamline, B-spline) and analytic ones (plane, sphere, cylinder) share
one geometry code path.

Differential geometry used (do Carmo, Sec. 3-3): with ``E = X_t.X_t``, ``F = X_t.X_s``,
``G = X_s.X_s`` and ``L = X_tt.n``, ``M = X_ts.n``, ``N = X_ss.n``, the normal curvature in
the parameter direction ``(dt, ds)`` is ``II/I = (L dt^2 + 2M dt ds + N ds^2) /
(E dt^2 + 2F dt ds + G ds^2)``; the principal curvatures are the roots of
``(EG - F^2) k^2 - (EN - 2FM + GL) k + (LN - M^2) = 0``. Curvature is negative where the
surface curves away from its normal (convex: a sphere with outward normals has ``k = -1/R``)
and positive where it curves towards it (concave: a pocket), so a ball cutter on the normal
side gouges where ``k > 1/R_cutter``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .errors import InvalidParameterError
from .vectors import cross_rows, unit

if TYPE_CHECKING:
    from .compiled import StreamlineKernel

__all__ = ["IsoCurve", "ParametricSurface", "SurfaceFrame", "outward_normals", "parameter_pairs"]

#: The highest total derivative order a surface must provide.
MAX_ORDER = 2
#: The partials a :class:`SurfaceFrame` needs.
FRAME_ORDERS = ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))


def parameter_pairs(t: ArrayLike, s: ArrayLike, grid: bool
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64], tuple[int, ...]]:
    """Flatten ``(t, s)`` (broadcast, or the outer grid) and return the output shape."""
    t_arr = np.asarray(t, dtype=float)
    s_arr = np.asarray(s, dtype=float)
    if grid:
        if t_arr.ndim > 1 or s_arr.ndim > 1:
            raise InvalidParameterError("grid evaluation takes 1-D t and s")
        t_arr, s_arr = np.atleast_1d(t_arr), np.atleast_1d(s_arr)
        shape = (t_arr.size, s_arr.size)
        tt, ss = np.meshgrid(t_arr, s_arr, indexing="ij")
    else:
        try:
            tt, ss = np.broadcast_arrays(t_arr, s_arr)
        except ValueError:
            raise InvalidParameterError(
                f"t {t_arr.shape} and s {s_arr.shape} do not broadcast together") from None
        shape = tt.shape
    flat_t, flat_s = tt.ravel(), ss.ravel()
    if not (np.isfinite(flat_t).all() and np.isfinite(flat_s).all()):
        raise InvalidParameterError("surface parameters t and s must be finite")
    return flat_t, flat_s, shape


def outward_normals(surface: ParametricSurface, xt: NDArray[np.float64],
                    xs: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit normals ``orientation * X_t x X_s``.

    (The cross product by :func:`~toolpath.vectors.cross_rows` where the two are alike:
    numpy's, bit for bit, without its set-up for any shapes.)
    """
    alike = np.shape(xt) == np.shape(xs) and np.shape(xt)[-1:] == (3,)
    return surface.orientation * unit(cross_rows(xt, xs) if alike else np.cross(xt, xs))


class SurfaceFrame:
    """First and second partials, unit normal and fundamental forms at many ``(t, s)``.

    Attributes are arrays of the evaluation shape (vectors gain a trailing 3):
    ``point, xt, xs, xtt, xts, xss, normal`` and ``E, F, G, L, M, N``.
    """

    def __init__(self, surface: ParametricSurface, t: ArrayLike, s: ArrayLike, grid: bool):
        flat_t, flat_s, shape = parameter_pairs(t, s, grid)
        parts = surface.partials_many(flat_t, flat_s, FRAME_ORDERS)
        vec = (*shape, 3)
        self.point = parts[0, 0].reshape(vec)
        self.xt, self.xs = parts[1, 0].reshape(vec), parts[0, 1].reshape(vec)
        self.xtt, self.xts = parts[2, 0].reshape(vec), parts[1, 1].reshape(vec)
        self.xss = parts[0, 2].reshape(vec)
        self.normal = outward_normals(surface, self.xt, self.xs)
        dot = np.einsum
        self.E = dot("...k,...k->...", self.xt, self.xt)
        self.F = dot("...k,...k->...", self.xt, self.xs)
        self.G = dot("...k,...k->...", self.xs, self.xs)
        self.L = dot("...k,...k->...", self.xtt, self.normal)
        self.M = dot("...k,...k->...", self.xts, self.normal)
        self.N = dot("...k,...k->...", self.xss, self.normal)

    def normal_curvature(self, dt: ArrayLike, ds: ArrayLike) -> NDArray[np.float64]:
        """``II/I`` in the parameter direction ``(dt, ds)`` (1/mm, sign as the module says)."""
        dt, ds = np.asarray(dt, dtype=float), np.asarray(ds, dtype=float)
        second = self.L * dt * dt + 2.0 * self.M * dt * ds + self.N * ds * ds
        first = self.E * dt * dt + 2.0 * self.F * dt * ds + self.G * ds * ds
        return second / np.where(first > 0.0, first, np.nan)

    def principal_curvatures(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(k_min, k_max)`` (1/mm), the roots of the module's quadratic."""
        a = self.E * self.G - self.F**2
        a = np.where(a > 0.0, a, np.nan)
        mean = (self.E * self.N - 2.0 * self.F * self.M + self.G * self.L) / (2.0 * a)
        gauss = (self.L * self.N - self.M**2) / a
        root = np.sqrt(np.maximum(mean**2 - gauss, 0.0))
        return mean - root, mean + root


class ParametricSurface(ABC):
    """A C2 surface ``X(t, s)``, ``0 <= t, s <= 1``, in millimetres.

    Subclasses implement :meth:`_partials` and may set ``closed_t`` (the sections are closed
    loops, ``X(0, s) == X(1, s)``) and ``orientation`` (``+1`` or ``-1``: the sign that makes
    ``orientation * X_t x X_s`` point outward, away from the material).
    """

    closed_t: bool = False
    orientation: float = 1.0

    @abstractmethod
    def _partials(self, t: NDArray[np.float64], s: NDArray[np.float64], dt: int, ds: int
                  ) -> NDArray[np.float64]:
        """``d^(dt+ds) X / dt^dt ds^ds`` at flat arrays ``t``, ``s`` -> ``(n, 3)``."""

    def partials_many(self, t: NDArray[np.float64], s: NDArray[np.float64],
                       orders: tuple[tuple[int, int], ...]
                       ) -> dict[tuple[int, int], NDArray[np.float64]]:
        """Several partials at once: ``{(dt, ds): (n, 3)}`` at flat ``t``, ``s``.

        Compiled when :meth:`kernel` offers it, else :meth:`_partials` order by order;
        override to share work between the partials otherwise.
        """
        kernel = self.kernel()
        if kernel is not None:
            return kernel.partials(t, s, orders)
        return {order: self._partials(t, s, *order) for order in orders}

    def kernel(self) -> StreamlineKernel | None:
        """The surface's compiled form (:mod:`toolpath.compiled`), or None (numpy only)."""
        return None

    def __call__(self, t: ArrayLike, s: ArrayLike, *, grid: bool = False) -> NDArray[np.float64]:
        """Points at the pairs ``(t, s)`` (broadcast) or, with ``grid=True``, on the grid."""
        return self.derivative(t, s, dt=0, ds=0, grid=grid)

    def derivative(self, t: ArrayLike, s: ArrayLike, *, dt: int = 1, ds: int = 0,
                   grid: bool = False) -> NDArray[np.float64]:
        """The partial derivative ``d^(dt+ds) X / dt^dt ds^ds`` (mm), total order <= 2."""
        for name, value in (("dt", dt), ("ds", ds)):
            if not isinstance(value, int | np.integer) or value < 0:
                raise InvalidParameterError(f"{name} must be a non-negative integer, got {value!r}")
        if dt + ds > MAX_ORDER:
            raise InvalidParameterError(
                f"derivatives up to total order {MAX_ORDER} are available, asked dt={dt}, ds={ds}")
        flat_t, flat_s, shape = parameter_pairs(t, s, grid)
        return self._partials(flat_t, flat_s, int(dt), int(ds)).reshape((*shape, 3))

    def frame(self, t: ArrayLike, s: ArrayLike, *, grid: bool = False) -> SurfaceFrame:
        """Every first- and second-order quantity at once (one evaluation per partial)."""
        return SurfaceFrame(self, t, s, grid)

    def normal(self, t: ArrayLike, s: ArrayLike, *, grid: bool = False) -> NDArray[np.float64]:
        """Unit normals, oriented outward (``orientation * X_t x X_s``)."""
        flat_t, flat_s, shape = parameter_pairs(t, s, grid)
        parts = self.partials_many(flat_t, flat_s, ((1, 0), (0, 1)))
        normal = outward_normals(self, parts[1, 0], parts[0, 1])
        return normal.reshape((*shape, 3))

    def points_and_normals(self, t: ArrayLike, s: ArrayLike, *, grid: bool = False
                           ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Points and outward unit normals from one evaluation of the three partials."""
        flat_t, flat_s, shape = parameter_pairs(t, s, grid)
        parts = self.partials_many(flat_t, flat_s, ((0, 0), (1, 0), (0, 1)))
        normal = outward_normals(self, parts[1, 0], parts[0, 1])
        return parts[0, 0].reshape((*shape, 3)), normal.reshape((*shape, 3))

    def principal_curvatures(self, t: ArrayLike, s: ArrayLike, *, grid: bool = False
                             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(k_min, k_max)`` in 1/mm; negative is convex seen from the normal side."""
        return self.frame(t, s, grid=grid).principal_curvatures()

    def streamline(self, s: float) -> IsoCurve:
        """The curve ``t -> X(t, s)`` at a fixed ``s``: a toolpath pass."""
        return IsoCurve(self, float(s))


class IsoCurve:
    """``t -> X(t, s0)``: callable, with derivatives along ``t``."""

    def __init__(self, surface: ParametricSurface, s: float):
        if not 0.0 <= s <= 1.0:
            raise InvalidParameterError(f"s must lie in [0, 1], got {s}")
        self.surface = surface
        self.s = s

    def __call__(self, t: ArrayLike) -> NDArray[np.float64]:
        """Points ``X(t, s0)``."""
        return self.surface(t, self.s)

    def derivative(self, t: ArrayLike, order: int = 1) -> NDArray[np.float64]:
        """``d^order X / dt^order`` at fixed ``s`` (order 1 or 2)."""
        return self.surface.derivative(t, self.s, dt=order, ds=0)

    def __repr__(self) -> str:
        return f"IsoCurve(s={self.s:g})"


def as_surface(value: Any) -> ParametricSurface:
    """Check that ``value`` is a surface (for functions taking one)."""
    if not isinstance(value, ParametricSurface):
        raise InvalidParameterError(
            f"expected a ParametricSurface, got {type(value).__name__}")
    return value
