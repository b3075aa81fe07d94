"""Compiled evaluation and closest-point projection for streamline surfaces.

The planner spends most of its time evaluating ``X(t, s)`` and its partials a few at a
time inside Newton searches; in numpy every one of those steps costs a dozen temporary
arrays. Here the same mathematics runs point by point in machine code (numba):

* :func:`streamline_partials`: eq. 25, ``X = −c + T^{-1} [Z_0(s) ∘ exp(G(t, s))]`` and its
  partials up to order 2, exactly as :class:`toolpath.streamline_surface.StreamlineSurface`
  states them (``W_t = W G_t``, ``W_tt = W (G_tt + G_t²)``, ``W_s = e^G (Z_0' + Z_0 G_s)``,
  ``W_ts = W_s G_t + W G_ts``, ``W_ss = e^G (Z_0'' + 2 Z_0' G_s + Z_0 (G_ss + G_s²))``),
  ``G`` and ``X_0`` from their per-patch power forms (:mod:`toolpath.tensor_spline`), then
  a rigid placement ``R X + d`` (folded into the last step: ``M W + off``);
* :func:`project_points`: the damped Newton projection of
  :func:`toolpath.planning.local.project_to_surface`, one point at a time, with the steps
  of :mod:`toolpath.projection_kernel` (the numpy path takes the same ones); points inside
  moves (:func:`move_points`) go through it too, so the search compiles once.

The compiled loops take a surface as :class:`SurfaceArrays` and the search's settings as
:class:`NewtonSearch` (named tuples).

Kernels called only by other kernels are compiled ``no_cpython_wrapper=True,
no_cfunc_wrapper=True`` (here and in the planner's kernel modules): without the two wrappers
that let Python (or C) call them, which a first run compiled for each of them (about a
tenth of a CPU second each; Python must never call one: it would crash). None is inlined
by numba (``inline="always"``): numba's inlining made the search's compile slower and its
code slower too (issue 27: measured 25 % less CPU to project points without it).

A surface offers this through :class:`StreamlineKernel` (``surface.kernel()``); surfaces
without one (analytic test surfaces, B-spline baselines) keep the numpy path.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from .projection_kernel import (
    HALVINGS,
    SEAM_BEFORE_T,
    STEP_CLIP,
    mirror_nearer,
    near_seam,
    newton_step,
    no_farther,
    other_face_nearer,
    other_face_t,
    seam_corner,
    seam_lerp,
    trial,
)
from .row_threads import run_in_threads

__all__ = ["MOVES_CHUNK", "MoveStarts", "Moves", "NewtonSearch", "StreamlineKernel",
           "SurfaceArrays", "move_points", "n_partials", "project_points",
           "streamline_partials"]

#: Partials in the order the kernels write them: X, X_t, X_s, X_tt, X_ts, X_ss.
ORDERS = ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))


@dataclass(frozen=True, eq=False)
class StreamlineKernel:
    """Everything the compiled evaluation needs, as contiguous float arrays.

    Attributes
    ----------
    breaks_t, breaks_s : ndarray
        Distinct knots of ``G`` along ``t`` and ``s``.
    g_poly : ndarray, shape (n_l * n_m, 4, 3, 4)
        ``G``'s patch coefficients ``P[l n_m + m, p, k, q]`` of ``u^p v^q``.
    x0_breaks : ndarray
        Distinct knots of ``X_0(s)``.
    x0_poly : ndarray, shape (n_l, 4, 3)
        ``X_0``'s piece coefficients of ``v^p``.
    T, T_inv, c : ndarray
        The diagonalizing matrix, its inverse and the translation (mm) of eq. 25.
    rotation, translation_mm : ndarray
        The placement ``R X + d`` (identity and zero for a surface as fitted).
    closed_t : bool
        Sections are closed loops (``t`` wraps).
    """

    breaks_t: NDArray[np.float64]
    breaks_s: NDArray[np.float64]
    g_poly: NDArray[np.float64]
    x0_breaks: NDArray[np.float64]
    x0_poly: NDArray[np.float64]
    T: NDArray[np.float64]
    T_inv: NDArray[np.float64]
    c: NDArray[np.float64]
    rotation: NDArray[np.float64]
    translation_mm: NDArray[np.float64]
    closed_t: bool

    def placed(self, rotation: NDArray[np.float64], translation_mm: NDArray[np.float64]
               ) -> StreamlineKernel:
        """The kernel moved by a further ``X -> Q X + e``."""
        q = np.asarray(rotation, dtype=float)
        return dataclasses.replace(
            self, rotation=np.ascontiguousarray(q @ self.rotation),
            translation_mm=np.ascontiguousarray(q @ self.translation_mm + translation_mm))

    @cached_property
    def _output(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``M = R T^-1`` and ``off = d - R c``: ``R (-c + T^-1 W) + d = M W + off``."""
        return (np.ascontiguousarray(self.rotation @ self.T_inv),
                np.ascontiguousarray(self.translation_mm - self.rotation @ self.c))

    @cached_property
    def arrays(self) -> SurfaceArrays:
        """The arrays the compiled loops take (:class:`SurfaceArrays`)."""
        return SurfaceArrays(self.breaks_t, self.breaks_s, self.g_poly, self.x0_breaks,
                             self.x0_poly, self.T, self.c, *self._output)

    def partials(self, t: NDArray[np.float64], s: NDArray[np.float64],
                 orders: tuple[tuple[int, int], ...]
                 ) -> dict[tuple[int, int], NDArray[np.float64]]:
        """``{(dt, ds): (n, 3)}`` at flat ``t``, ``s``, total orders up to 2."""
        top = max(dt + ds for dt, ds in orders)
        t = _writable(np.ravel(t), float)
        s = _writable(np.ravel(s), float)
        out = np.empty((n_partials(top), t.size, 3))
        streamline_partials(t, s, self.arrays, top, out)
        return {order: out[ORDERS.index(order)] for order in orders}

    def search(self, iterations: int, extra: int, converged_mm: float,
               orientation: float = 0.0) -> NewtonSearch:
        """The :class:`NewtonSearch` of these settings on this surface."""
        return NewtonSearch(bool(self.closed_t), int(iterations), int(extra),
                            float(converged_mm), float(orientation))

    def project(self, points_mm: NDArray[np.float64], t0: NDArray[np.float64],
                s0: NDArray[np.float64], iterations: int, extra: int, converged_mm: float,
                orientation: float = 0.0
                ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Closest points by Newton's method: ``t, s`` and the distance (mm).

        With ``orientation`` (the surface's, +-1) the distance is signed: positive on the
        side the outward normal points to.
        """
        p = _writable(np.reshape(points_mm, (-1, 3)), float)
        t = np.array(np.broadcast_to(np.asarray(t0, dtype=float), (len(p),)))
        s = np.array(np.broadcast_to(np.asarray(s0, dtype=float), (len(p),)))
        dist = np.empty(len(p))
        project_points(p, self.arrays, self.search(iterations, extra, converged_mm,
                                                   orientation), t, s, dist)
        return t, s, dist

    def project_moves(self, moves: Moves, search: NewtonSearch
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Signed distances, less ``lift_mm``, of points inside moves, projected.

        Move ``j`` of ``moves`` (:class:`Moves`) goes from point ``first[j]`` to the next
        (tip linear, axis normalized-linear); at each of its ``fractions[j]`` the point
        ``lift_mm`` up the axis from the tip is projected by ``search`` (:meth:`search`,
        as :meth:`project` does) from the ends' parameters interpolated alike (the short
        way across the seam of closed sections). The points are made :data:`MOVES_CHUNK`
        moves at a time (:func:`move_points`) and projected by :func:`project_points`.
        Returns ``t, s`` of the feet and the distances, shape (m, k).
        """
        u = _writable(moves.fractions, float)
        m, k = u.shape
        t_out, s_out, dist = np.empty(m * k), np.empty(m * k), np.empty(m * k)
        moves = Moves(_writable(moves.tips_mm, float), _writable(moves.axes, float),
                      _writable(moves.t, float), _writable(moves.s, float),
                      _writable(moves.first, np.int64), u, float(moves.lift_mm))
        points = np.empty((min(m, MOVES_CHUNK) * k, 3))
        for lo in range(0, m, MOVES_CHUNK):
            hi = min(lo + MOVES_CHUNK, m)
            rows, chunk = slice(lo * k, hi * k), moves._replace(first=moves.first[lo:hi],
                                                                 fractions=u[lo:hi])
            move_points(chunk, search.closed, MoveStarts(points, t_out[rows], s_out[rows]))
            project_points(points[:(hi - lo) * k], self.arrays, search, t_out[rows],
                           s_out[rows], dist[rows])
        dist -= moves.lift_mm
        return t_out.reshape(m, k), s_out.reshape(m, k), dist.reshape(m, k)


#: Moves whose points :meth:`StreamlineKernel.project_moves` makes at a time (the
#: points are kept only for their projection: 24 bytes each).
MOVES_CHUNK = 1 << 16


def _writable(a: ArrayLike, dtype: type) -> NDArray:
    """``a`` as a C-contiguous, writable array of ``dtype`` (copied only where it is not).

    What the compiled loops are compiled for: numba types a read-only array (a broadcast
    view, a memory-mapped file) apart and would compile a kernel again for it (3 to 10 s).
    """
    return np.require(a, dtype=dtype, requirements=("C", "W"))


class SurfaceArrays(NamedTuple):
    """A streamline surface as the compiled loops take it (from :class:`StreamlineKernel`).

    ``M = R T^-1`` and ``off = d - R c`` fold the placement into the last step:
    ``X = M W + off``.
    """

    breaks_t: NDArray[np.float64]
    breaks_s: NDArray[np.float64]
    g_poly: NDArray[np.float64]
    x0_breaks: NDArray[np.float64]
    x0_poly: NDArray[np.float64]
    T: NDArray[np.float64]
    c: NDArray[np.float64]
    M: NDArray[np.float64]
    off: NDArray[np.float64]


class NewtonSearch(NamedTuple):
    """How a projection searches (:func:`project_points`).

    ``iterations`` steps for every point, then up to ``extra`` more while a step moves the
    foot by more than ``converged_mm``; ``orientation`` 0 for the distance ``|p - X|``,
    the surface's +-1 for the signed one; ``closed`` the surface's ``closed_t``.
    """

    closed: bool
    iterations: int
    extra: int
    converged_mm: float
    orientation: float


class Scratch(NamedTuple):
    """One thread's working arrays for :func:`_point_partials` (overwritten at each point).

    ``mu, mv``: the monomials of ``u`` and ``v`` and their derivatives, (3, 4); ``g``:
    ``G``'s partials, (6, 3); ``z``: ``T X_0^(a)``, (3, 3); ``w``: ``W``'s partials, (6, 3).
    """

    mu: NDArray[np.float64]
    mv: NDArray[np.float64]
    g: NDArray[np.float64]
    z: NDArray[np.float64]
    w: NDArray[np.float64]


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _scratch():
    """A fresh :class:`Scratch`.

    A call, so that each row slice (:mod:`toolpath.row_threads`) has its own scratch.
    """
    return Scratch(np.empty((3, 4)), np.empty((3, 4)), np.empty((6, 3)), np.empty((3, 3)),
                   np.empty((6, 3)))


class Moves(NamedTuple):
    """Moves between cutter locations, for :func:`move_points`.

    Move ``j`` from location ``first[j]`` to the next (of ``tips_mm, axes, t, s``), at its
    ``fractions[j]`` (shape (m, k)); the point projected is ``lift_mm`` up the axis.
    """

    tips_mm: NDArray[np.float64]
    axes: NDArray[np.float64]
    t: NDArray[np.float64]
    s: NDArray[np.float64]
    first: NDArray[np.int64]
    fractions: NDArray[np.float64]
    lift_mm: float


class MoveStarts(NamedTuple):
    """What :func:`move_points` makes for the points inside moves.

    Row ``i``: the point to project (mm) and the parameters ``t, s`` its search starts
    from (then its foot's, written in place by :func:`project_points`).
    """

    points: NDArray[np.float64]
    t: NDArray[np.float64]
    s: NDArray[np.float64]


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _locate(breaks, x):
    """Interval index of ``x`` (clamped to the domain) and the offset from its left end."""
    n = breaks.size
    if x < breaks[0]:
        x = breaks[0]
    elif x > breaks[n - 1]:
        x = breaks[n - 1]
    lo, hi = 0, n - 1
    while hi - lo > 1:  # breaks[lo] <= x < breaks[hi], the last interval closed
        mid = (lo + hi) // 2
        if breaks[mid] <= x:
            lo = mid
        else:
            hi = mid
    return lo, x - breaks[lo]


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _monomials(u, out):
    """``out[a, p] = d^a u^p / du^a`` for ``a = 0, 1, 2``."""
    out[0, 0], out[0, 1], out[0, 2], out[0, 3] = 1.0, u, u * u, u * u * u
    out[1, 0], out[1, 1], out[1, 2], out[1, 3] = 0.0, 1.0, 2.0 * u, 3.0 * u * u
    out[2, 0], out[2, 1], out[2, 2], out[2, 3] = 0.0, 0.0, 2.0, 6.0 * u


@numba.njit(cache=True)
def n_partials(order):
    """How many partials of total order up to ``order`` (the first of :data:`ORDERS`)."""
    return (order + 1) * (order + 2) // 2


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _point_partials(t, s, sf, order, out, i, work):
    """Write X (and partials up to ``order``) at ``(t, s)`` into ``out[:, i]``.

    ``sf`` the surface (:class:`SurfaceArrays`), ``work`` a :class:`Scratch`.
    """
    bt, bs, g_poly, x0b, x0p, T, c, M, off = sf
    mu, mv, g, z, w = work
    lt, u = _locate(bt, t)
    ls, v = _locate(bs, s)
    _monomials(u, mu)
    _monomials(v, mv)
    patch = lt * (bs.size - 1) + ls
    # g[j, k]: G's partials in the order of ORDERS, as far as ``order`` needs
    for k in range(3):
        for j in range(6):
            g[j, k] = 0.0
        for p in range(4):
            a0 = 0.0
            a1 = 0.0
            a2 = 0.0
            for q in range(4):
                coef = g_poly[patch, p, k, q]
                a0 += coef * mv[0, q]
                if order >= 1:
                    a1 += coef * mv[1, q]
                    if order == 2:
                        a2 += coef * mv[2, q]
            g[0, k] += mu[0, p] * a0
            if order >= 1:
                g[1, k] += mu[1, p] * a0
                g[2, k] += mu[0, p] * a1
                if order == 2:
                    g[3, k] += mu[2, p] * a0
                    g[4, k] += mu[1, p] * a1
                    g[5, k] += mu[0, p] * a2
    lx, vx = _locate(x0b, s)
    _monomials(vx, mv)
    # z[a]: T X_0^(a)(s) (+ T c for a = 0)
    for a in range(order + 1):
        x00 = c[0] if a == 0 else 0.0
        x01 = c[1] if a == 0 else 0.0
        x02 = c[2] if a == 0 else 0.0
        for p in range(4):
            x00 += mv[a, p] * x0p[lx, p, 0]
            x01 += mv[a, p] * x0p[lx, p, 1]
            x02 += mv[a, p] * x0p[lx, p, 2]
        for k in range(3):
            z[a, k] = T[k, 0] * x00 + T[k, 1] * x01 + T[k, 2] * x02
    for k in range(3):
        e = math.exp(g[0, k])
        wk = z[0, k] * e
        w[0, k] = wk
        if order >= 1:
            w[1, k] = wk * g[1, k]
            ws = e * (z[1, k] + z[0, k] * g[2, k])
            w[2, k] = ws
            if order == 2:
                w[3, k] = wk * (g[3, k] + g[1, k] * g[1, k])
                w[4, k] = ws * g[1, k] + wk * g[4, k]
                w[5, k] = e * (z[2, k] + 2.0 * z[1, k] * g[2, k]
                               + z[0, k] * (g[5, k] + g[2, k] * g[2, k]))
    for j in range(n_partials(order)):  # placed: M W + off (off for X alone)
        for k in range(3):
            acc = M[k, 0] * w[j, 0] + M[k, 1] * w[j, 1] + M[k, 2] * w[j, 2]
            out[j, i, k] = acc + off[k] if j == 0 else acc


#: The kernels' call of :func:`_point_partials`: a call, not inlined: the Newton search calls it
#: from five places, and inlining it there (10 % faster) made the first compile take a
#: minute. Its integer arguments are passed as ``np.int64(k)``: a bare constant is typed
#: ``Literal[int](k)`` and numba compiled one specialisation per constant (four, some 5 s
#: each on a cold start). :func:`_partials_block` calls it too, with the same argument
#: types: the one compile serves both (inlined there it cost 2.5 s more of compiling on a
#: cold start, issue 27).
_partials_at = _point_partials


#: A Newton step predicted to move the foot by less than this share of ``converged_mm``
#: ends the search without a check of its point (the signed distance there comes from the
#: partials already at hand, to second order: :func:`_taylor_signed`).
SMALL_STEP_SHARE = 0.1


def streamline_partials(t, s, sf, order, out):
    """Fill ``out[j, i]`` with the ``j``-th partial (order of :data:`ORDERS`) at point ``i``.

    ``sf``: the surface's :class:`SurfaceArrays`. Slices of the points in threads
    (:func:`~toolpath.row_threads.run_in_threads`, :func:`_partials_block`).
    """
    run_in_threads(_partials_block, t.size, t, s, sf, order, out)


@numba.njit(cache=True, nogil=True)
def _partials_block(t, s, sf, order, out, lo, hi):
    """:func:`streamline_partials` for points ``lo .. hi - 1``."""
    work = _scratch()
    for i in range(lo, hi):
        _partials_at(t[i], s[i], sf, order, out, i, work)


def project_points(p, sf, search, t, s, dist):
    """Newton projection of points ``p[i]`` from ``(t[i], s[i])``, in place; ``dist[i]``.

    ``sf`` the surface (:class:`SurfaceArrays`), ``search`` a :class:`NewtonSearch`. With
    ``orientation`` 0 the distance ``|p - X|``; with ``+-1`` the signed distance
    ``(p - X) . n`` along the outward normal ``n = orientation X_t x X_s / |X_t x X_s|`` at
    the foot (one more evaluation of the first partials there). The search
    (:func:`_project_one`, the steps of :mod:`toolpath.projection_kernel`) is called
    by :func:`_project_block`, the one compiled loop that runs it (points inside moves
    come here too: :meth:`StreamlineKernel.project_moves`); then the corner rule at a
    closed surface's seam (:func:`_seam_signed`). Slices of the points in threads
    (:func:`~toolpath.row_threads.run_in_threads`).
    """
    run_in_threads(_project_block, p.shape[0], p, sf, search, t, s, dist)


@numba.njit(cache=True, nogil=True)
def _project_block(p, sf, search, t, s, dist, lo, hi):
    """:func:`project_points` for points ``lo .. hi - 1``."""
    work = _scratch()
    fr = np.empty((6, 1, 3))
    pt = np.empty((6, 1, 3))
    for k in range(6):  # (the second partials, 0 or a trial point's, are read only times
        for c in range(3):  # a zero step; a loop, as np.zeros compiled three more kernels)
            pt[k, 0, c] = 0.0
    # each point is copied into a one-row array of this thread's, searched as row 0:
    # faster than searching p[j] where it lies (measured 10-15 %); row 1 takes the search
    # from the seam's other face (_seam_signed)
    q1 = np.empty((2, 3))
    t1, s1, d1 = np.empty(2), np.empty(2), np.empty(2)
    for j in range(lo, hi):
        for c in range(3):
            q1[0, c] = q1[1, c] = p[j, c]
        t1[0], s1[0] = t[j], s[j]
        _project_one(q1, 0, t1, s1, sf, search, d1, work, fr, pt)
        if search.closed and search.orientation != 0.0:
            _seam_signed(q1, t1, s1, sf, search, d1, work, fr, pt)
        t[j], s[j], dist[j] = t1[0], s1[0], d1[0]


@numba.njit(cache=True)
def move_points(moves, closed, out):
    """The points of :meth:`StreamlineKernel.project_moves` and where their search starts.

    ``moves`` (:class:`Moves`), ``out`` (:class:`MoveStarts`): its row ``j k + q`` is the
    point ``lift_mm`` up the interpolated axis a fraction ``u[j, q]`` along move ``j``
    (from location ``first[j]`` to the next: :func:`_move_point`) and the ends' parameters
    interpolated alike (``closed``: the short way across the seam).
    """
    first, u = moves.first, moves.fractions
    k = u.shape[1]
    for j in range(u.shape[0]):
        for q in range(k):
            _move_point(moves, first[j], u[j, q], closed, out, j * k + q)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _seam_normal(t, s, sf, orientation, work, pt, x, n):
    """Point and outward unit normal at ``(t, s)``: into ``x`` and ``n``."""
    _partials_at(t, s, sf, np.int64(1), pt, np.int64(0), work)
    a0, a1, a2 = pt[1, 0, 0], pt[1, 0, 1], pt[1, 0, 2]
    b0, b1, b2 = pt[2, 0, 0], pt[2, 0, 1], pt[2, 0, 2]
    n[0], n[1], n[2] = a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0
    size = math.sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2])
    scale = orientation / size if size > 0.0 else 0.0
    for k in range(3):
        n[k] *= scale
        x[k] = pt[0, 0, k]


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _seam_signed(p, t, s, sf, search, dist, work, fr, pt):
    """The seam rules of :mod:`toolpath.projection_kernel` for the point ``p[0]``, in place.

    For a foot (``t[0], s[0]``, signed distance ``dist[0]``) :func:`near_seam`, or farther
    out with ``p[0]`` :func:`~toolpath.projection_kernel.mirror_nearer` (read deeper than it
    lies from the foot's mirror ``X(1 - t, s)``, evaluated for points read inside): the search
    again from the other face (:func:`~toolpath.projection_kernel.other_face_t`, as row 1:
    ``p[1]`` the same point), the nearer foot kept
    (:func:`~toolpath.projection_kernel.other_face_nearer`); then the seam point ``X(0, s)``
    and the one-sided normals there, and the corner rule
    :func:`~toolpath.projection_kernel.seam_corner` (which states the math).
    """
    if not near_seam(t[0]):
        if dist[0] >= 0.0:
            return
        _partials_at(other_face_t(t[0]), s[0], sf, np.int64(0), pt, np.int64(0), work)
        if not mirror_nearer(p[0], pt[0, 0], dist[0]):
            return
    t[1], s[1] = other_face_t(t[0]), s[0]
    _project_one(p, 1, t, s, sf, search, dist, work, fr, pt)
    _partials_at(t[0], s[0], sf, np.int64(0), pt, np.int64(0), work)
    foot = pt[0, 0].copy()
    _partials_at(t[1], s[1], sf, np.int64(0), pt, np.int64(0), work)
    other = pt[0, 0].copy()
    if other_face_nearer(p[0], foot, other):
        t[0], s[0], dist[0] = t[1], s[1], dist[1]
        foot = other
    orientation = search.orientation
    seam_x, n_after = np.empty(3), np.empty(3)
    before_x, n_before = np.empty(3), np.empty(3)
    _seam_normal(0.0, s[0], sf, orientation, work, pt, seam_x, n_after)
    _seam_normal(SEAM_BEFORE_T, s[0], sf, orientation, work, pt, before_x, n_before)
    at_seam, signed = seam_corner(p[0], foot, seam_x, n_before, n_after)
    if at_seam:
        t[0], dist[0] = 0.0, signed


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _move_point(moves, a, f, closed, out, i):
    """The point ``lift_mm`` up the axis a fraction ``f`` along the move ``a -> a + 1``.

    Of ``moves`` (:class:`Moves`), into row ``i`` of ``out`` (:class:`MoveStarts`): the
    point (tip linear, axis normalized-linear) and the parameters to start from (the ends'
    interpolated, the short way across the seam:
    :func:`~toolpath.projection_kernel.seam_lerp`).
    """
    tips, axes, tt, ss, lift = moves.tips_mm, moves.axes, moves.t, moves.s, moves.lift_mm
    p, t1, s1 = out
    b = a + 1
    size2 = 0.0
    for col in range(3):
        v = axes[a, col] + f * (axes[b, col] - axes[a, col])
        p[i, col] = v
        size2 += v * v
    size = math.sqrt(size2)
    for col in range(3):
        p[i, col] = tips[a, col] + f * (tips[b, col] - tips[a, col]) + lift * (p[i, col] / size)
    t1[i] = seam_lerp(tt[a], tt[b], f, closed)
    s1[i] = ss[a] * (1.0 - f) + ss[b] * f


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _second_order(fr, k, dt, ds):
    """Component ``k`` of ``X(t + dt, s + ds)`` to second order from the partials ``fr``."""
    return (fr[0, 0, k] + fr[1, 0, k] * dt + fr[2, 0, k] * ds
            + 0.5 * (fr[3, 0, k] * dt * dt + 2.0 * fr[4, 0, k] * dt * ds
                     + fr[5, 0, k] * ds * ds))


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _taylor_signed(p, i, fr, dt, ds, orientation):
    """Signed distance ``(p - X) . n`` at ``(t + dt, s + ds)`` from the partials at ``(t, s)``.

    With ``dt = ds = 0`` the signed distance at ``(t, s)`` itself.

    ``X`` to second order, the tangents ``X_t, X_s`` to first: for a step moving the foot
    by ``h`` the distance is off by ``O(h^3)`` (the foot) plus ``|p - X| O(h^2 k')`` (the
    normal), far below a nanometre for the steps :data:`SMALL_STEP_SHARE` admits.
    """
    # (np.int64: a bare constant is typed as a literal, one compile of _second_order each)
    x0 = _second_order(fr, np.int64(0), dt, ds)
    x1 = _second_order(fr, np.int64(1), dt, ds)
    x2 = _second_order(fr, np.int64(2), dt, ds)
    a0 = fr[1, 0, 0] + fr[3, 0, 0] * dt + fr[4, 0, 0] * ds
    a1 = fr[1, 0, 1] + fr[3, 0, 1] * dt + fr[4, 0, 1] * ds
    a2 = fr[1, 0, 2] + fr[3, 0, 2] * dt + fr[4, 0, 2] * ds
    b0 = fr[2, 0, 0] + fr[4, 0, 0] * dt + fr[5, 0, 0] * ds
    b1 = fr[2, 0, 1] + fr[4, 0, 1] * dt + fr[5, 0, 1] * ds
    b2 = fr[2, 0, 2] + fr[4, 0, 2] * dt + fr[5, 0, 2] * ds
    n0 = a1 * b2 - a2 * b1
    n1 = a2 * b0 - a0 * b2
    n2 = a0 * b1 - a1 * b0
    size = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    scale = orientation / size if size > 0.0 else 0.0
    return scale * ((p[i, 0] - x0) * n0 + (p[i, 1] - x1) * n1 + (p[i, 2] - x2) * n2)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _project_one(p, i, t, s, sf, search, dist, work, fr, pt):
    """The foot of ``p[i]`` from ``(t[i], s[i])`` and its distance ``dist[i]``, in place.

    ``sf`` the surface (:class:`SurfaceArrays`), ``search`` the :class:`NewtonSearch`,
    ``work`` a :class:`Scratch`; ``fr`` and ``pt`` take the partials (up to the second at
    the point the step starts from; at its trial points X, its first partials on a last
    step, up to the second where another step follows).
    ``iterations`` steps, then up to ``extra`` more while a step moves the foot by more
    than ``converged_mm``; each step from :func:`~toolpath.projection_kernel.newton_step`,
    halved (up to :data:`~toolpath.projection_kernel.HALVINGS` times) while its point is
    farther from ``p`` (:func:`~toolpath.projection_kernel.no_farther`). For a signed
    distance, a last step predicted (to first order) to move the foot by under
    :data:`SMALL_STEP_SHARE` of ``converged_mm`` is taken without evaluating its point,
    and the distance there is the second-order expansion from the partials at hand
    (:func:`_taylor_signed`; the numpy path evaluates both: the same foot to within that
    distance, the same distance to a nanometre). (The kernels then apply the corner rule
    at a closed surface's seam: :func:`_seam_signed`.) Called by :func:`_project_block`
    alone (points inside moves come there too). A trial point that another step surely
    starts from is evaluated to the second partials at once, and that step takes them
    (the same numbers as evaluating them there again: one evaluation a step, not two).
    """
    closed, iterations, extra, converged_mm, orientation = search
    ti, si = t[i], s[i]
    moved = np.inf
    have_tangents = False  # pt holds the first partials at (ti, si)
    have_second = False  # fr holds the partials up to the second at (ti, si)
    for k in range(iterations + extra):
        if k >= iterations and moved <= converged_mm:
            break
        if not have_second:
            _partials_at(ti, si, sf, np.int64(2), fr, np.int64(0), work)
        have_second = False
        step_t, step_s, here = newton_step(fr, 0, p, i)
        new_t, new_s = trial(ti, si, step_t, step_s, closed)
        xt0, xt1, xt2 = fr[1, 0, 0], fr[1, 0, 1], fr[1, 0, 2]
        xs0, xs1, xs2 = fr[2, 0, 0], fr[2, 0, 1], fr[2, 0, 2]
        # a last step that moves the foot by far less than converged_mm (to first order)
        # cannot overshoot: taken without evaluating the surface there first (unless it
        # wrapped round the seam: t then moves by most of a turn, more than any step)
        lin0 = xt0 * (new_t - ti) + xs0 * (new_s - si)
        lin1 = xt1 * (new_t - ti) + xs1 * (new_s - si)
        lin2 = xt2 * (new_t - ti) + xs2 * (new_s - si)
        if (orientation != 0.0 and k + 1 >= iterations and abs(new_t - ti) < STEP_CLIP
                and lin0 * lin0 + lin1 * lin1 + lin2 * lin2
                < (SMALL_STEP_SHARE * converged_mm) ** 2):
            t[i], s[i] = new_t, new_s
            dist[i] = _taylor_signed(p, i, fr, new_t - ti, new_s - si, orientation)
            return
        closer = False
        # where this may be the last step, the first partials there too: the signed
        # distance at the foot needs no other evaluation
        tangents = 1 if orientation != 0.0 and k + 1 >= iterations else 0
        # where another step surely follows, it starts from the point taken: the partials
        # it needs there at once (X and its first partials are the same numbers at every
        # order, :func:`_point_partials`), not X now and all of them again next step
        ahead = np.int64(2) if k + 1 < iterations else np.int64(tangents)
        for _ in range(HALVINGS):
            _partials_at(new_t, new_s, sf, ahead, pt, np.int64(0), work)
            e0 = pt[0, 0, 0] - p[i, 0]
            e1 = pt[0, 0, 1] - p[i, 1]
            e2 = pt[0, 0, 2] - p[i, 2]
            if no_farther(e0 * e0 + e1 * e1 + e2 * e2, here):
                closer = True
                break
            step_t *= 0.5
            step_s *= 0.5
            new_t, new_s = trial(ti, si, step_t, step_s, closed)
        if not closer:  # still farther after the last halving: the last step's point
            _partials_at(new_t, new_s, sf, ahead, pt, np.int64(0), work)
        m0 = pt[0, 0, 0] - fr[0, 0, 0]
        m1 = pt[0, 0, 1] - fr[0, 0, 1]
        m2 = pt[0, 0, 2] - fr[0, 0, 2]
        moved = math.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
        ti, si = new_t, new_s
        have_tangents = tangents == 1
        if ahead == 2:
            for r in range(6):  # (a loop: the slice copy fr[:, 0, :] = pt[:, 0, :] took
                for c in range(3):  # a cold job's chords stage 3-4 s more to compile)
                    fr[r, 0, c] = pt[r, 0, c]
            have_second = True
    if iterations + extra == 0:  # no step: the foot is the start
        _partials_at(ti, si, sf, np.int64(0), pt, np.int64(0), work)
    t[i], s[i] = ti, si
    if orientation == 0.0:  # pt holds the last foot
        e0, e1, e2 = pt[0, 0, 0] - p[i, 0], pt[0, 0, 1] - p[i, 1], pt[0, 0, 2] - p[i, 2]
        dist[i] = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        return
    if not have_tangents:
        _partials_at(ti, si, sf, np.int64(1), pt, np.int64(0), work)
    dist[i] = _taylor_signed(p, i, pt, 0.0, 0.0, orientation)  # at the foot itself
