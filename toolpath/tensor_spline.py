"""Bicubic tensor-product B-splines ``F(t, s) = Σ_a Σ_b C_ab N_a(t) M_b(s)`` (eq. 29).

Partial derivatives use the B-spline derivative rule on the coefficients (de Boor, *A
Practical Guide to Splines*, X(12)): differentiating along one direction turns the degree-p
spline with coefficients ``c_a`` on knots ``u`` into the degree p-1 spline with coefficients
``p (c_{a+1} − c_a) / (u_{a+p+1} − u_{a+1})`` on ``u[1:-1]``. Evaluation then uses sparse
design matrices (4 non-zeros per row), chunked, so a million scattered pairs cost about as
much memory as the answer.
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


def _differentiate(knots: NDArray[np.float64], coef: NDArray[np.float64], degree: int,
                   axis: int) -> tuple[NDArray[np.float64], NDArray[np.float64], int]:
    """Coefficients of the derivative along ``axis`` (de Boor's rule)."""
    c = np.moveaxis(coef, axis, 0)
    span = knots[degree + 1:degree + c.shape[0]] - knots[1:c.shape[0]]
    scale = np.divide(degree, span, out=np.zeros_like(span), where=span > 0)
    diff = (c[1:] - c[:-1]) * scale.reshape((-1,) + (1,) * (c.ndim - 1))
    return knots[1:-1], np.moveaxis(diff, 0, axis), degree - 1


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
        kt, coef, pt = self.knots_t, self.coef, DEGREE
        for _ in range(dt):
            kt, coef, pt = _differentiate(kt, coef, pt, 0)
        ks, ps = self.knots_s, DEGREE
        for _ in range(ds):
            ks, coef, ps = _differentiate(ks, coef, ps, 1)
        n_t, n_s, k = coef.shape
        flat = coef.reshape(n_t, n_s * k)
        t = np.clip(t, kt[0], kt[-1])
        s = np.clip(s, ks[0], ks[-1])
        out = np.empty((t.size, k))
        for lo in range(0, t.size, CHUNK):
            hi = min(lo + CHUNK, t.size)
            basis_t = scipy.interpolate.BSpline.design_matrix(t[lo:hi], kt, pt)
            basis_s = scipy.interpolate.BSpline.design_matrix(s[lo:hi], ks, ps).toarray()
            along_t = (basis_t @ flat).reshape(hi - lo, n_s, k)
            out[lo:hi] = np.einsum("nb,nbk->nk", basis_s, along_t)
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
