"""Local geometry at contact points: pass frame, shape tensor, projection onto the surface.

In the orthonormal tangent basis of a pass (``e1`` along the pass, ``e2`` across it towards
increasing ``s``), with ``q = sqrt(G - F^2 / E)`` the distance across passes per unit ``s``:

* ``e1 = X_t / sqrt(E)``, ``e2 = (X_s - (F/E) X_t) / q``;
* the surface's second fundamental form (sign of :mod:`toolpath.surface`: positive is
  concave, the surface curving towards the cutter) is
  ``S11 = L / E``, ``S12 = (M - (F/E) L) / (sqrt(E) q)``,
  ``S22 = (N - 2 (F/E) M + (F/E)^2 L) / q^2``; ``S22`` is the normal curvature across the
  passes, ``S11`` along them;
* the geodesic curvature of the pass is ``kg = (X_tt . (n x e1)) / E``.

:func:`project_to_surface` finds the closest surface point by damped Newton steps on
``min |X(t, s) - p|^2`` (vectorized, fixed number of iterations).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..projection_kernel import (
    HALVINGS,
    SEAM_BEFORE_T,
    SEAM_SEARCH_T,
    halve_rows,
    mirror_nearer_rows,
    newton_step_rows,
    no_farther,
    other_face_nearer_rows,
    other_face_t,
    seam_corner_rows,
)
from ..surface import FRAME_ORDERS, ParametricSurface, parameter_pairs
from ..tolerances import TINY

__all__ = ["CONVERGED_MM", "EXTRA_ITERATIONS", "PassFrame", "pass_frame",
           "project_to_surface", "signed_distance_near", "tangent_frame"]

#: A Newton step moving the foot by less than this (mm) ends the search for that point
#: (the next would move it by about its square over the radius of curvature).
CONVERGED_MM = 1e-3
#: Newton steps at most beyond the requested ones, for the points not yet converged (a
#: point beside a leading edge, started a few hundredths of ``t`` away, can take over a
#: dozen; only those pay for them).
EXTRA_ITERATIONS = 24


@dataclass(frozen=True, eq=False)
class PassFrame:
    """Geometry of the surface at contact points ``(t, s)`` (flat arrays of length n).

    Attributes
    ----------
    point, normal, e1, e2 : ndarray, shape (n, 3)
        Contact point (mm), outward unit normal, unit pass direction (increasing ``t``)
        and unit across direction (towards increasing ``s``, in the tangent plane).
    speed_t : ndarray, shape (n,)
        ``|X_t|``, mm per unit ``t``.
    speed_s : ndarray, shape (n,)
        ``q``, distance across passes per unit ``s``, mm.
    s11, s12, s22 : ndarray, shape (n,)
        Second fundamental form in ``(e1, e2)``, 1/mm (positive = concave).
    kg : ndarray, shape (n,)
        Geodesic curvature of the pass, 1/mm.
    """

    point: NDArray[np.float64]
    normal: NDArray[np.float64]
    e1: NDArray[np.float64]
    e2: NDArray[np.float64]
    speed_t: NDArray[np.float64]
    speed_s: NDArray[np.float64]
    s11: NDArray[np.float64]
    s12: NDArray[np.float64]
    s22: NDArray[np.float64]
    kg: NDArray[np.float64]

    @property
    def max_concave_curvature(self) -> NDArray[np.float64]:
        """Largest principal curvature ``k_max`` (1/mm; > 0 where concave)."""
        return self.max_concave_curvature_at(slice(None))

    def max_concave_curvature_at(self, rows: NDArray[np.int64] | slice) -> NDArray[np.float64]:
        """:attr:`max_concave_curvature` at ``rows`` only."""
        s11, s12, s22 = self.s11[rows], self.s12[rows], self.s22[rows]
        return 0.5 * (s11 + s22) + np.sqrt(0.25 * (s11 - s22) ** 2 + s12**2)


def pass_frame(surface: ParametricSurface, t: ArrayLike, s: ArrayLike) -> PassFrame:
    """Evaluate :class:`PassFrame` at flat (broadcast) parameter arrays ``t``, ``s``.

    The partials from the surface (compiled where it has a kernel), the frame from them in
    one compiled pass (:func:`_frame_rows`, the formulas of the module docstring).
    """
    return _frame(surface, t, s, FRAME_ORDERS)


def tangent_frame(surface: ParametricSurface, t: ArrayLike, s: ArrayLike) -> PassFrame:
    """:func:`pass_frame` from the first partials only: the curvatures are NaN.

    Point, normal, ``e1``, ``e2`` and the speeds are the same numbers as
    :func:`pass_frame`'s.
    """
    return _frame(surface, t, s, FRAME_ORDERS[:3])


def _frame(surface: ParametricSurface, t: ArrayLike, s: ArrayLike,
           orders: tuple[tuple[int, int], ...]) -> PassFrame:
    tt, ss, _ = parameter_pairs(t, s, grid=False)
    parts = surface.partials_many(tt, ss, orders)
    n = tt.size
    vectors = np.empty((3, n, 3))  # normal, e1, e2
    scalars = np.empty((6, n))  # speed_t, speed_s, s11, s12, s22, kg
    zeros = None if len(orders) == len(FRAME_ORDERS) else np.zeros((n, 3))  # (not asked)
    _frame_rows(*(np.ascontiguousarray(parts[o], dtype=float) if o in parts else zeros
                  for o in FRAME_ORDERS), float(surface.orientation), vectors, scalars)
    if len(orders) < len(FRAME_ORDERS):
        scalars[2:] = np.nan
    return PassFrame(point=parts[0, 0], normal=vectors[0], e1=vectors[1], e2=vectors[2],
                     speed_t=scalars[0], speed_s=scalars[1], s11=scalars[2], s12=scalars[3],
                     s22=scalars[4], kg=scalars[5])


@numba.njit(cache=True)
def _frame_rows(x, xt, xs, xtt, xts, xss, orientation, vectors, scalars):
    """:class:`PassFrame`'s vectors and scalars at each row from the partials."""
    for i in range(x.shape[0]):
        e = xt[i, 0] * xt[i, 0] + xt[i, 1] * xt[i, 1] + xt[i, 2] * xt[i, 2]
        f = xt[i, 0] * xs[i, 0] + xt[i, 1] * xs[i, 1] + xt[i, 2] * xs[i, 2]
        g = xs[i, 0] * xs[i, 0] + xs[i, 1] * xs[i, 1] + xs[i, 2] * xs[i, 2]
        n0 = xt[i, 1] * xs[i, 2] - xt[i, 2] * xs[i, 1]
        n1 = xt[i, 2] * xs[i, 0] - xt[i, 0] * xs[i, 2]
        n2 = xt[i, 0] * xs[i, 1] - xt[i, 1] * xs[i, 0]
        size = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
        scale = orientation / size if size > 0.0 else orientation
        n0, n1, n2 = n0 * scale, n1 * scale, n2 * scale
        big_l = xtt[i, 0] * n0 + xtt[i, 1] * n1 + xtt[i, 2] * n2
        big_m = xts[i, 0] * n0 + xts[i, 1] * n1 + xts[i, 2] * n2
        big_n = xss[i, 0] * n0 + xss[i, 1] * n1 + xss[i, 2] * n2
        e_safe = max(e, TINY)
        e_len = math.sqrt(e_safe)
        ratio = f / e_safe
        q2 = max(g - f * ratio, TINY)
        q = math.sqrt(q2)
        e1 = (xt[i, 0] / e_len, xt[i, 1] / e_len, xt[i, 2] / e_len)
        for k in range(3):
            vectors[0, i, k] = (n0, n1, n2)[k]
            vectors[1, i, k] = e1[k]
            vectors[2, i, k] = (xs[i, k] - ratio * xt[i, k]) / q
        # kg: X_tt . (n x e1) / E
        side0 = n1 * e1[2] - n2 * e1[1]
        side1 = n2 * e1[0] - n0 * e1[2]
        side2 = n0 * e1[1] - n1 * e1[0]
        scalars[0, i] = e_len
        scalars[1, i] = q
        scalars[2, i] = big_l / e_safe
        scalars[3, i] = (big_m - ratio * big_l) / (e_len * q)
        scalars[4, i] = (big_n - 2.0 * ratio * big_m + ratio * ratio * big_l) / q2
        scalars[5, i] = (xtt[i, 0] * side0 + xtt[i, 1] * side1 + xtt[i, 2] * side2) / e_safe


def project_to_surface(surface: ParametricSurface, points_mm: ArrayLike, t0: ArrayLike,
                       s0: ArrayLike, *, iterations: int = 4
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                  NDArray[np.float64]]:
    """Closest surface points to ``points`` by Newton's method from ``(t0, s0)``.

    Minimizes ``f = |X(t, s) - p|^2 / 2`` by the damped Newton steps of
    :mod:`toolpath.projection_kernel` (the Hessian with its curvature terms, the
    Gauss-Newton matrix where it is not positive definite, steps clipped and halved while
    they would move away from ``p``, ``t`` wrapping on closed sections): compiled point by
    point where the surface has a kernel, else on rows of partials from the surface.

    ``iterations`` steps are taken for every point; points whose last step still moved
    the foot by more than :data:`CONVERGED_MM` take up to :data:`EXTRA_ITERATIONS` more
    (a foot found half-way gives a meaningless signed distance: from a poor start near a
    leading edge, -1.6 mm for a true -0.002 mm).

    Returns
    -------
    t, s : ndarray, shape (n,)
        Parameters of the closest points found.
    distance_mm : ndarray, shape (n,)
        ``|X(t, s) - p|``.
    """
    p = np.asarray(points_mm, dtype=float).reshape(-1, 3)
    kernel = surface.kernel()
    if kernel is not None:  # the same steps, compiled (toolpath.compiled.project_points)
        return kernel.project(p, t0, s0, iterations, EXTRA_ITERATIONS, CONVERGED_MM)
    t = np.array(np.broadcast_to(np.asarray(t0, dtype=float), (len(p),)))
    s = np.array(np.broadcast_to(np.asarray(s0, dtype=float), (len(p),)))
    closest = getattr(surface, "closest_parameters", None)
    found = closest(p) if closest is not None and iterations and len(p) else None
    if found is not None:  # the closed form's exact feet; Newton for the rows it leaves
        t_exact, s_exact, exact = found
        t[exact], s[exact] = t_exact[exact], s_exact[exact]
        rest = np.flatnonzero(~exact)
        if rest.size:
            t[rest], s[rest], _ = _newton_search(surface, p[rest], t[rest], s[rest],
                                                 iterations)
        return t, s, np.linalg.norm(surface(t, s) - p, axis=1)
    t, s, x = _newton_search(surface, p, t, s, iterations)
    return t, s, np.linalg.norm(x - p, axis=1)


def _newton_search(surface: ParametricSurface, p: NDArray[np.float64],
                   t: NDArray[np.float64], s: NDArray[np.float64], iterations: int
                   ) -> tuple[NDArray[np.float64], ...]:
    """:func:`project_to_surface`'s Newton steps from ``t``, ``s`` (updated in place).

    Returns ``t``, ``s`` and the feet's points (mm).
    """
    x = np.empty_like(p)
    active = np.arange(len(p))
    moved = np.full(len(p), np.inf)
    for k in range(iterations + EXTRA_ITERATIONS):
        if k >= iterations:
            active = active[moved[active] > CONVERGED_MM]
        if not active.size:
            break
        t[active], s[active], x[active], moved[active] = _newton_step(
            surface, p[active], t[active], s[active])
    if not iterations:
        x = surface(t, s)
    return t, s, x


def signed_distance_near(surface: ParametricSurface, points_mm: ArrayLike, t0: ArrayLike,
                         s0: ArrayLike, *, iterations: int = 4
                         ) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                    NDArray[np.float64]]:
    """Signed distance ``(p - X) . n`` to the closest point found from ``(t0, s0)``, mm.

    Positive on the outward side. The foot by :func:`project_to_surface`; returns the
    distance and the foot's ``t``, ``s``. Beside a closed surface's seam the foot searched
    for from the other face too, the nearer kept; beside a corner there (a sharp trailing
    edge) the seam point where no farther, and ``|p - X|`` signed by the sum of the two
    one-sided normals (:func:`toolpath.projection_kernel.seam_corner`).
    """
    p = np.asarray(points_mm, dtype=float).reshape(-1, 3)
    kernel = surface.kernel()
    if kernel is not None:  # the projection and the normal at its foot in one pass
        t, s, signed = kernel.project(p, t0, s0, iterations, EXTRA_ITERATIONS, CONVERGED_MM,
                                      orientation=surface.orientation)
        return signed, t, s
    t, s, _ = project_to_surface(surface, p, t0, s0, iterations=iterations)
    x, normals = surface.points_and_normals(t, s)
    signed = np.einsum("ij,ij->i", p - x, normals)
    if surface.closed_t and len(p):
        _seam_rules(surface, p, t, s, x, signed, iterations)
    return signed, t, s


def _seam_rules(surface: ParametricSurface, p: NDArray[np.float64], t: NDArray[np.float64],
                s: NDArray[np.float64], x: NDArray[np.float64], signed: NDArray[np.float64],
                iterations: int) -> None:
    """The seam rules of :mod:`toolpath.projection_kernel` on rows, in place (as compiled).

    A foot ``x`` within :data:`~toolpath.projection_kernel.SEAM_SEARCH_T` of the seam, or
    farther out one reading its point deeper than the point lies from the foot's mirror
    (:func:`~toolpath.projection_kernel.mirror_nearer`, :func:`_read_past_mirror`): the
    search again from the other face (:func:`~toolpath.projection_kernel.other_face_t`),
    the nearer foot kept, signed by its own normal; then the seam point where no farther
    (:func:`~toolpath.projection_kernel.seam_corner`).
    """
    near = np.flatnonzero((np.minimum(t, 1.0 - t) <= SEAM_SEARCH_T)
                          | _read_past_mirror(surface, p, t, s, signed))
    if not near.size:
        return
    t_o, s_o, _ = project_to_surface(surface, p[near], other_face_t(t[near]), s[near],
                                     iterations=iterations)
    x_o, n_o = surface.points_and_normals(t_o, s_o)
    other = np.empty(near.size, dtype=bool)
    other_face_nearer_rows(p[near], np.ascontiguousarray(x[near]), x_o, other)
    taken = near[other]
    t[taken], s[taken], x[taken] = t_o[other], s_o[other], x_o[other]
    signed[taken] = np.einsum("ij,ij->i", p[taken] - x_o[other], n_o[other])
    seam_x, n_after = surface.points_and_normals(np.zeros(near.size), s[near])
    n_before = surface.points_and_normals(np.full(near.size, SEAM_BEFORE_T), s[near])[1]
    seam_corner_rows(*(np.ascontiguousarray(a, dtype=float)
                       for a in (p, x, seam_x, n_before, n_after)), near, t, signed)


def _read_past_mirror(surface: ParametricSurface, p: NDArray[np.float64], t: NDArray[np.float64],
                      s: NDArray[np.float64], signed: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Rows :func:`~toolpath.projection_kernel.mirror_nearer`: read inside, past the mirror.

    The mirror ``X(1 - t, s)`` evaluated only at rows read inside (``signed < 0``).
    """
    out = np.zeros(len(p), dtype=bool)
    inside = np.flatnonzero(signed < 0.0)
    if inside.size:
        mirror = surface(other_face_t(t[inside]), s[inside])
        hit = np.empty(inside.size, dtype=bool)
        mirror_nearer_rows(*(np.ascontiguousarray(a, dtype=float)
                             for a in (p[inside], mirror, signed[inside])), hit)
        out[inside] = hit
    return out


def _newton_step(surface: ParametricSurface, p: NDArray[np.float64], t: NDArray[np.float64],
                 s: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """One damped Newton step of :func:`project_to_surface` at every row.

    The step from :func:`~toolpath.projection_kernel.newton_step` on the surface's partials,
    halved (:func:`~toolpath.projection_kernel.halve_rows`) up to
    :data:`~toolpath.projection_kernel.HALVINGS` times while its point is farther.
    Returns the new ``t, s``, the foot point there and how far the step moved it (mm).
    """
    closed = bool(surface.closed_t)
    f = surface.frame(t, s)
    partials = np.stack((f.point, f.xt, f.xs, f.xtt, f.xts, f.xss))
    n = len(p)
    t, s = np.ascontiguousarray(t, dtype=float), np.ascontiguousarray(s, dtype=float)
    step_t, step_s, here, new_t, new_s = (np.empty(n) for _ in range(5))
    newton_step_rows(partials, np.ascontiguousarray(p, dtype=float), t, s, closed, step_t,
                     step_s, here, new_t, new_s)
    worse = np.arange(n)
    x = np.empty_like(p)
    for _ in range(HALVINGS):
        x[worse] = surface(new_t[worse], new_s[worse])
        dn = x[worse] - p[worse]
        worse = worse[~no_farther(np.einsum("ij,ij->i", dn, dn), here[worse])]
        if not worse.size:
            break
        halve_rows(worse, t, s, closed, step_t, step_s, new_t, new_s)
    if worse.size:  # still farther after the last halving: the last step's point
        x[worse] = surface(new_t[worse], new_s[worse])
    return new_t, new_s, x, np.linalg.norm(x - f.point, axis=1)
