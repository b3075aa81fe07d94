"""The frame ``(T, c)`` that puts the data in the positive cone (paper Algorithms 1 and 2).

The streamline solution ``X(t) = −c + T^{-1} exp(diag G(t)) T (X_0 + c)`` needs every
component of ``Z_i = T (X_i + c)`` to keep the sign of ``Z_0``; we make them all positive.

- Algorithm 1 (2-D): with ``θ`` the arguments of the (shifted) points measured from their
  mean direction, if ``θ_max − θ_min + 2η < π`` then
  ``T = [[cos(θ_min−η), cos(θ_max+η)], [sin(θ_min−η), sin(θ_max+η)]]^{-1}``.
  Angles are measured from the mean direction, so sectors across ±π need no special case.
- Algorithm 2 (3-D): barycenter ``Q``, enclosing radius ``r``, ``d = |OQ| > r`` (the paper
  prints ``<``), three points ``ξ_k`` on the circle of radius ``ρ`` about ``Q`` normal to
  ``OQ`` and ``T = [ξ_1/|ξ_1|, ξ_2/|ξ_2|, ξ_3/|ξ_3|]^{-1}``. ``ρ = 2dr/sqrt(d² − r²)`` makes
  the inscribed circular cone contain the sphere (the paper's ``ρ = 2r`` may not); a
  margin factor ≥ 1 widens it.
- Translation ``c`` (not in the paper, needed for curves through or around the origin,
  such as Examples 4 and 5): the shifted barycenter is put at ``κ r`` from the origin along
  a chosen direction ``u``, ``c = κ r u − Q``.

Candidates over ``u``, ``κ`` and the margin are scored by the caller (by fit error): the
margin is a tuned parameter, not the paper's fixed ``η < 0.1``.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .errors import FitError
from .vectors import unit

__all__ = ["ConeFrame", "algorithm1", "algorithm2", "candidate_frames"]

#: Paper's sector margin (Algorithm 1 asks 0 < η < 0.1 rad); used by the paper-faithful mode.
PAPER_ETA_RAD = 0.05
#: Distances of the shifted barycenter from the origin, in enclosing radii, tried for c.
KAPPAS = (1.5, 3.0, 10.0, 100.0)
#: Fractions of the free angle (2-D) or radius factors (3-D) used as cone margins.
MARGINS = (0.15, 0.6)
#: A point is inside the cone when each component of ``T (X + c)`` exceeds this share of the
#: largest: a component at round-off of zero is on the cone's face, and ``log Z`` blows up.
_CONE_MARGIN = 1e-9
#: Algorithm 2 needs the origin outside the points' ball (``d > r``): within this relative
#: margin of its surface the cone's half-angle ``sqrt(d^2 - r^2)`` is round-off.
_BALL_MARGIN = 1e-9


@dataclass(frozen=True)
class ConeFrame:
    """``T`` (d×d) and translation ``c`` (mm) with ``T (X + c) > 0`` for all data."""

    T: NDArray[np.float64]
    c: NDArray[np.float64]
    label: str = ""

    def to_cone(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """``Z = T (X + c)`` for points ``x`` of shape (n, d)."""
        return (x + self.c) @ self.T.T

    def contains(self, x: NDArray[np.float64]) -> bool:
        """Whether every component of ``T (X + c)`` is positive (with a relative margin)."""
        z = self.to_cone(x)
        return bool(np.all(z > _CONE_MARGIN * np.abs(z).max()))


def algorithm1(x: NDArray[np.float64], c: NDArray[np.float64], *, eta: float | None = None,
               margin: float = MARGINS[0], label: str = "") -> ConeFrame | None:
    """Algorithm 1 on the shifted 2-D points ``x + c``; None if the sector is too wide.

    ``eta`` (rad) is the paper's fixed margin; otherwise ``η = margin × (π − spread) / 2``.
    """
    y = x + c
    if np.any(np.linalg.norm(y, axis=1) == 0):
        return None
    ref = np.arctan2(*unit(np.mean(unit(y), axis=0))[::-1])
    theta = np.angle(np.exp(1j * (np.arctan2(y[:, 1], y[:, 0]) - ref)))
    spread = theta.max() - theta.min()
    if eta is None:
        eta = margin * (np.pi - spread) / 2.0
    if spread + 2 * eta >= np.pi or eta <= 0:
        return None
    a, b = ref + theta.min() - eta, ref + theta.max() + eta
    T = np.linalg.inv(np.array([[np.cos(a), np.cos(b)], [np.sin(a), np.sin(b)]]))
    frame = ConeFrame(T / np.linalg.norm(T, 2), np.asarray(c, float), label)
    return frame if frame.contains(x) else None


def algorithm2(x: NDArray[np.float64], c: NDArray[np.float64], *, margin: float = 1.1,
               label: str = "") -> ConeFrame | None:
    """Algorithm 2 on the shifted 3-D points ``x + c``; None if the origin is too close.

    ``ρ = margin × 2dr / sqrt(d² − r²)`` (``margin ≥ 1``).
    """
    y = x + c
    q = y.mean(axis=0)
    r = float(np.linalg.norm(y - q, axis=1).max())
    d = float(np.linalg.norm(q))
    if d <= r * (1 + _BALL_MARGIN):
        return None
    rho = margin * 2.0 * d * r / np.sqrt(d * d - r * r)
    axis = q / d
    e1 = unit(np.cross(axis, np.eye(3)[int(np.argmin(np.abs(axis)))]))
    e2 = np.cross(axis, e1)
    phis = 2.0 * np.pi * np.arange(3) / 3.0
    xi = q[None] + rho * (np.cos(phis)[:, None] * e1 + np.sin(phis)[:, None] * e2)
    T = np.linalg.inv(unit(xi).T)
    frame = ConeFrame(T / np.linalg.norm(T, 2), np.asarray(c, float), label)
    return frame if frame.contains(x) else None


def _directions(x: NDArray[np.float64]) -> list[NDArray[np.float64]]:
    """Principal axes of the data, both senses: where the origin may be put."""
    _, _, vt = np.linalg.svd(x - x.mean(axis=0), full_matrices=False)
    return [s * v for v in vt for s in (1.0, -1.0)]


def candidate_frames(x: NDArray[np.float64], *, margins: tuple[float, ...] = MARGINS,
                     kappas: tuple[float, ...] = KAPPAS) -> Iterator[ConeFrame]:
    """Frames to try: the paper's untranslated one when it exists, then translations.

    Translations put the shifted barycenter at ``κ r`` along each principal axis (both
    senses) for ``κ`` in ``kappas``, with each cone margin in ``margins``.
    """
    d = x.shape[1]
    zero = np.zeros(d)
    q = x.mean(axis=0)
    r = float(np.linalg.norm(x - q, axis=1).max())
    for margin in margins:
        frame = (algorithm1(x, zero, margin=margin, label=f"c=0 margin={margin}") if d == 2
                 else algorithm2(x, zero, margin=1 + margin, label=f"c=0 margin={margin}"))
        if frame is not None:
            yield frame
    for k, u in enumerate(_directions(x)):
        for kappa in kappas:
            c = kappa * r * u - q
            for margin in margins:
                label = f"axis {k} kappa={kappa} margin={margin}"
                frame = (algorithm1(x, c, margin=margin, label=label) if d == 2
                         else algorithm2(x, c, margin=1 + margin, label=label))
                if frame is not None:
                    yield frame


def paper_frame(x: NDArray[np.float64]) -> ConeFrame:
    """The paper's choice: T = I in one octant (Remark 2), else Algorithm 1 (η = 0.05) or 2.

    Translates (with κ = 3 along the first principal axis) only when the paper's
    algorithm has no answer.
    """
    d = x.shape[1]
    zero = np.zeros(d)
    if np.all(x[1:] * np.sign(x[0]) > 0) and np.all(x[0] != 0):
        return ConeFrame(np.diag(np.sign(x[0])), zero, "paper: one octant, T = I")
    frame = (algorithm1(x, zero, eta=PAPER_ETA_RAD, label="paper: Algorithm 1") if d == 2
             else algorithm2(x, zero, margin=1.0, label="paper: Algorithm 2"))
    if frame is not None:
        return frame
    q = x.mean(axis=0)
    r = float(np.linalg.norm(x - q, axis=1).max())
    c = 3.0 * r * _directions(x)[0] - q
    frame = (algorithm1(x, c, eta=PAPER_ETA_RAD, label="paper + translation") if d == 2
             else algorithm2(x, c, margin=1.0, label="paper + translation"))
    if frame is None:
        raise FitError("no cone frame found for the data")
    return frame
