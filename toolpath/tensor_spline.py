"""Bicubic tensor-product B-splines ``F(t, s) = Σ_a Σ_b C_ab N_a(t) M_b(s)`` (eq. 29).

Partial derivatives ``∂^(a+b) F / ∂t^a ∂s^b = Σ C_ij N_i^(a)(t) M_j^(b)(s)`` use the basis
derivatives (scipy's de Boor recursion), evaluated once per order and direction for all the
partials asked together (a surface frame needs six), chunked, so a million scattered pairs
cost about as much memory as the answer.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.interpolate
from numpy.typing import NDArray

from .splinefit import DEGREE

__all__ = ["TensorSpline", "interpolate_across"]

#: Pairs evaluated per chunk (bounds the dense intermediate to a few tens of MB).
CHUNK = 65536


def _basis(identity: scipy.interpolate.BSpline, x: NDArray[np.float64], nu: int):
    """Basis values at ``x`` (sparse, 4 non-zeros a row) or their ``nu``-th derivatives.

    The derivatives are the spline with identity coefficients, evaluated (dense).
    """
    if nu == 0:
        return scipy.interpolate.BSpline.design_matrix(x, identity.t, DEGREE)
    return identity(x, nu=nu)


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

    def partial(self, t: NDArray[np.float64], s: NDArray[np.float64], dt: int = 0,
                ds: int = 0) -> NDArray[np.float64]:
        """``∂^(dt+ds) F / ∂t^dt ∂s^ds`` at flat arrays ``t``, ``s`` -> ``(n, k)``."""
        return self.partials(t, s, ((dt, ds),))[dt, ds]

    def partials(self, t: NDArray[np.float64], s: NDArray[np.float64],
                 orders: tuple[tuple[int, int], ...]) -> dict[tuple[int, int], NDArray[np.float64]]:
        """Several partials at once, sharing the basis values: ``{(dt, ds): (n, k)}``.

        ``F_(a,b)(t, s) = Σ_i Σ_j C_ij N_i^(a)(t) M_j^(b)(s)``: the basis derivatives are
        evaluated once per order and direction, then contracted with the coefficients.
        """
        n_t, n_s, k = self.coef.shape
        flat = self.coef.reshape(n_t, n_s * k)
        basis_t = scipy.interpolate.BSpline(self.knots_t, np.eye(n_t), DEGREE)
        basis_s = scipy.interpolate.BSpline(self.knots_s, np.eye(n_s), DEGREE)
        t = np.clip(t, self.knots_t[0], self.knots_t[-1])
        s = np.clip(s, self.knots_s[0], self.knots_s[-1])
        out = {order: np.empty((t.size, k)) for order in orders}
        by_t: dict[int, list[int]] = {}
        for dt, ds in orders:
            by_t.setdefault(dt, []).append(ds)
        s_orders = sorted({ds for _, ds in orders})
        for lo in range(0, t.size, CHUNK):
            hi = min(lo + CHUNK, t.size)
            across = {ds: _basis(basis_s, s[lo:hi], ds).toarray() if ds == 0
                      else _basis(basis_s, s[lo:hi], ds) for ds in s_orders}
            for dt, s_list in by_t.items():
                along_t = (_basis(basis_t, t[lo:hi], dt) @ flat).reshape(hi - lo, n_s, k)
                for ds in s_list:
                    out[dt, ds][lo:hi] = np.einsum("nb,nbk->nk", across[ds], along_t)
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
    ``paper.md`` §3), and give as many control points as sections.
    """
    spline = scipy.interpolate.make_interp_spline(s, rows, k=DEGREE)
    return np.asarray(spline.t), np.asarray(spline.c)
