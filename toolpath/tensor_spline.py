"""Bicubic tensor-product B-splines ``F(t, s) = Σ_a Σ_b C_ab N_a(t) M_b(s)`` (eq. 29).

Evaluation goes through the spline's piecewise-polynomial form, built once: on knot
interval ``l`` only the four B-splines ``N_(l-3) .. N_l`` are non-zero, each a cubic in
``u = t - t_l``, so on the patch ``[t_l, t_(l+1)) x [s_m, s_(m+1))``

    ``F(t, s) = Σ_p Σ_q P_lm,pq u^p v^q``,  ``P_lm,pq = Σ_i Σ_j A_l,ip B_m,jq C_(l-3+i)(m-3+j)``

with ``A``, ``B`` the power coefficients of the 1-D bases. A partial
``∂^(a+b) F / ∂t^a ∂s^b`` is then the patch's 16 coefficients contracted with the
differentiated monomials ``d^a u^p / du^a`` and ``d^b v^q / dv^b``: one interval lookup per
direction and a few dozen multiply-adds per pair, whatever the number of knots.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import scipy.interpolate
from numpy.typing import NDArray

from .splinefit import DEGREE

__all__ = ["PiecewiseCubic", "TensorSpline", "interpolate_across"]

#: Pairs evaluated per chunk (bounds the gathered patches to a few tens of MB).
CHUNK = 65536
_ORDER = DEGREE + 1


def _basis_table(knots: NDArray[np.float64]
                 ) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """The non-zero cubic B-splines of each knot interval in power form.

    Returns ``breaks`` (the distinct knots), ``first`` (index of the first non-zero basis
    function on each interval) and ``table`` of shape ``(n_intervals, 4, 4)``:
    ``table[l, i, p]`` is the coefficient of ``u^p`` (``u = x - breaks[l]``) in basis
    function ``first[l] + i``, from its derivatives at the interval's left end.
    """
    knots = np.asarray(knots, dtype=float)
    n_basis = len(knots) - _ORDER
    breaks = np.unique(knots[DEGREE:n_basis + 1])
    left = breaks[:-1]
    span = np.searchsorted(knots, left, side="right") - 1
    first = span - DEGREE
    identity = scipy.interpolate.BSpline(knots, np.eye(n_basis), DEGREE)
    rows = np.arange(len(left))[:, None]
    cols = first[:, None] + np.arange(_ORDER)
    table = np.empty((len(left), _ORDER, _ORDER))
    for p in range(_ORDER):
        table[:, :, p] = identity(left, nu=p)[rows, cols] / math.factorial(p)
    return breaks, first, table


def _locate(breaks: NDArray[np.float64], x: NDArray[np.float64]
            ) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Interval of each ``x`` (clamped to the domain) and the offset from its left end."""
    x = np.clip(x, breaks[0], breaks[-1])
    where = np.clip(np.searchsorted(breaks, x, side="right") - 1, 0, len(breaks) - 2)
    return where, x - breaks[where]


def _monomials(u: NDArray[np.float64], order: int) -> NDArray[np.float64]:
    """``d^order / du^order`` of ``(1, u, u^2, u^3)``, shape ``(n, 4)``."""
    out = np.zeros((u.size, _ORDER))
    for p in range(order, _ORDER):
        out[:, p] = math.perm(p, order) * u ** (p - order)
    return out


@dataclass(frozen=True, eq=False)
class PiecewiseCubic:
    """A clamped cubic B-spline curve with vector values, evaluated in power form.

    Attributes
    ----------
    knots : ndarray
        Cubic knot vector.
    coef : ndarray, shape (n, k)
        Control points.
    """

    knots: NDArray[np.float64]
    coef: NDArray[np.float64]

    @functools.cached_property
    def pieces(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(breaks, P)``, ``P[l, p, k]`` the coefficient of ``u^p`` on interval ``l``."""
        breaks, first, table = _basis_table(self.knots)
        blocks = self.coef[first[:, None] + np.arange(_ORDER)]  # (l, i, k)
        return breaks, np.einsum("lip,lik->lpk", table, blocks)

    def __call__(self, x: NDArray[np.float64], nu: int = 0) -> NDArray[np.float64]:
        """The ``nu``-th derivative at flat ``x`` -> ``(n, k)``."""
        breaks, poly = self.pieces
        where, u = _locate(breaks, np.asarray(x, dtype=float).ravel())
        return np.einsum("np,npk->nk", _monomials(u, nu), poly[where])


@dataclass(frozen=True, eq=False)
class TensorSpline:
    """A clamped bicubic tensor spline with vector values.

    Attributes
    ----------
    knots_t, knots_s : ndarray
        Clamped cubic knot vectors on [0, 1].
    coef : ndarray, shape (n_t, n_s, k)
        Control points.
    """

    knots_t: NDArray[np.float64]
    knots_s: NDArray[np.float64]
    coef: NDArray[np.float64]

    @functools.cached_property
    def patches(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """``(breaks_t, breaks_s, P)``, ``P[l * n_m + m, p, k, q]`` (ready for matmul)."""
        breaks_t, first_t, table_t = _basis_table(self.knots_t)
        breaks_s, first_s, table_s = _basis_table(self.knots_s)
        span = np.arange(_ORDER)
        blocks = self.coef[(first_t[:, None] + span)[:, None, :, None],
                           (first_s[:, None] + span)[None, :, None, :]]  # (l, m, i, j, k)
        poly = np.einsum("lip,mjq,lmijk->lmpqk", table_t, table_s, blocks)
        n_l, n_m = poly.shape[:2]
        return breaks_t, breaks_s, np.ascontiguousarray(
            poly.transpose(0, 1, 2, 4, 3).reshape(n_l * n_m, _ORDER, -1, _ORDER))

    def partial(self, t: NDArray[np.float64], s: NDArray[np.float64], dt: int = 0,
                ds: int = 0) -> NDArray[np.float64]:
        """``∂^(dt+ds) F / ∂t^dt ∂s^ds`` at flat arrays ``t``, ``s`` -> ``(n, k)``."""
        return self.partials(t, s, ((dt, ds),))[dt, ds]

    def partials(self, t: NDArray[np.float64], s: NDArray[np.float64],
                 orders: tuple[tuple[int, int], ...]) -> dict[tuple[int, int], NDArray[np.float64]]:
        """Several partials at once, sharing the patch lookup: ``{(dt, ds): (n, k)}``."""
        breaks_t, breaks_s, poly = self.patches
        t = np.asarray(t, dtype=float).ravel()
        s = np.asarray(s, dtype=float).ravel()
        k = poly.shape[2]
        n_m = len(breaks_s) - 1
        out = {order: np.empty((t.size, k)) for order in orders}
        most_dt = max(dt for dt, _ in orders)
        most_ds = max(ds for _, ds in orders)
        for lo in range(0, t.size, CHUNK):
            hi = min(lo + CHUNK, t.size)
            where_t, u = _locate(breaks_t, t[lo:hi])
            where_s, v = _locate(breaks_s, s[lo:hi])
            m = hi - lo
            patch = poly[where_t * n_m + where_s]  # (n, p, k, q)
            mono_s = np.stack([_monomials(v, b) for b in range(most_ds + 1)], axis=2)
            mono_t = np.stack([_monomials(u, a) for a in range(most_dt + 1)], axis=1)
            along = patch @ mono_s[:, None]  # (n, p, k, b): the s-derivatives
            values = (mono_t @ along.reshape(m, _ORDER, -1)).reshape(m, most_dt + 1, k, -1)
            for dt, ds in orders:
                out[dt, ds][lo:hi] = values[:, dt, :, ds]
        return out

    @property
    def shape(self) -> tuple[int, int]:
        """Control points ``(n_t, n_s)``."""
        return self.coef.shape[0], self.coef.shape[1]


def interpolate_across(s: NDArray[np.float64], rows: NDArray[np.float64]
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Not-a-knot cubic interpolation of ``rows[j]`` at ``s_j``: ``(knots, coefficients)``.

    Not-a-knot end conditions (knots at the interior ``s_j`` except the second and the
    last but one) follow a blade at hub and tip far better than natural ones (see
    ``paper.md`` §3), and give as many control points as sections. Three rows (the
    leave-one-out of a four-section surface) are too few for not-a-knot: a natural cubic
    through them is used.
    """
    bc_type = None if len(s) > DEGREE else "natural"
    spline = scipy.interpolate.make_interp_spline(s, rows, k=DEGREE, bc_type=bc_type)
    return np.asarray(spline.t), np.asarray(spline.c)
