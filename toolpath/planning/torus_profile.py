"""Where two passes of a flat or bull-nose cutter meet across the passes: the profile ridge.

The cutter (radius ``R``, corner radius ``r``, flute length ``L``, axis ``a``) is the union
of the balls of radius ``r`` round its ring circle ``{C + (R - r)(cos phi e1 + sin phi
e2)}`` (``e1, e2`` unit, across ``a``; ``C`` the ring centre, ``r`` up the axis from the
tip), the disk they bound, and that lifted along ``a`` up to ``L - r``. A straight move
along ``u`` sweeps it into a prism whose section in the plane across ``u`` is the solid's
projection along ``u``: with ``x, y`` the plane's axes (``y`` the surface normal's part
across ``u``, away from the surface) and ``P`` the projection onto them, the ring circle
projects to the ellipse ``E = {C + M (cos phi, sin phi)}``, ``M = (R - r) [P e1, P e2]``
(semi-axes ``R - r`` and ``(R - r) |a . u|``), and the section is ``E`` filled, widened
by ``r``, lifted by up to ``L - r`` along ``P a``: convex, with the boundary point of
outward normal ``m`` (unit, 2-D)

    ``b(m) = C + S m / sqrt(m' S m) + r m + (L - r) P a [m . P a > 0]``,  ``S = M M'``

(the support point; its radius of curvature ``det(M)^2 / (m' S m)^(3/2) + r``, at the
ellipse's minor axis ``(R - r) / |a . u| + r``: the cutter's effective radius across the
pass). :func:`profile_ridges` meets two such sections, the seed's own pass's and the next
pass's, where their sides facing each other cross nearest the surface: the bottom of the
cusp's ridge, as two tubes' circles meet for a ball.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..tolerances import TINY
from ..vectors import unit

__all__ = ["PROFILE_SAMPLES", "profile_ridges"]

#: Boundary points per section side. Their normals turn from ``0.25 pi/2`` past straight
#: down to horizontal, spaced as the square of an even step (dense near the contact,
#: where a large effective radius puts the ridge a few hundredths of a radian round):
#: the chords between them lie inside the convex section, so the ridge reads at most
#: their sag high, under a per cent of the cusp on the sweep's cutters and requests.
PROFILE_SAMPLES = 64


def _section_side(centre: NDArray[np.float64], axis: NDArray[np.float64],
                  along: NDArray[np.float64], x: NDArray[np.float64], y: NDArray[np.float64],
                  psi: NDArray[np.float64], ring_mm: float, corner_mm: float, lift_mm: float
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Boundary points ``b(m)`` (module docstring) at normals ``m = (sin psi, -cos psi)``.

    ``centre`` (m, 2) in the plane's axes ``x, y`` (m, 3); ``psi`` (m, k) or (k,).
    Returns their ``x`` and ``y``, (m, k).
    """
    e1 = np.cross(axis, along)
    side = np.linalg.norm(e1, axis=1)
    # the axis along the move: the ring projects to a circle, any e1 across a will do
    e1 = np.where((side > 1e-9)[:, None], e1, x - np.einsum("ij,ij->i", x, axis)[:, None] * axis)
    e1 = unit(e1)
    e2 = np.cross(axis, e1)
    p1 = np.stack([np.einsum("ij,ij->i", e1, x), np.einsum("ij,ij->i", e1, y)], axis=1)
    p2 = np.stack([np.einsum("ij,ij->i", e2, x), np.einsum("ij,ij->i", e2, y)], axis=1)
    s = ring_mm**2 * (p1[:, :, None] * p1[:, None, :] + p2[:, :, None] * p2[:, None, :])
    pa = np.stack([np.einsum("ij,ij->i", axis, x), np.einsum("ij,ij->i", axis, y)], axis=1)
    mx, my = np.sin(psi), -np.cos(psi)
    smx = s[:, 0, 0, None] * mx + s[:, 0, 1, None] * my
    smy = s[:, 1, 0, None] * mx + s[:, 1, 1, None] * my
    norm = np.sqrt(np.maximum(mx * smx + my * smy, TINY))
    up = (mx * pa[:, 0, None] + my * pa[:, 1, None]) > 0.0
    bx = centre[:, 0, None] + smx / norm + corner_mm * mx + lift_mm * up * pa[:, 0, None]
    by = centre[:, 1, None] + smy / norm + corner_mm * my + lift_mm * up * pa[:, 1, None]
    return np.maximum.accumulate(bx, axis=1), by  # x never falls along a lower side


def _on_merged(x: NDArray[np.float64], before: NDArray[np.int64], xp: NDArray[np.float64],
               yp: NDArray[np.float64], left: NDArray[np.float64] | float,
               right: NDArray[np.float64] | float) -> NDArray[np.float64]:
    """Polyline ``(xp, yp)`` (rows, ``xp`` rising) at ``x`` (rows).

    ``before`` counts its points at or left of each ``x``; ``left`` and ``right`` (rows
    or one value) stand beyond its ends.
    """
    k = xp.shape[1]
    i = np.clip(before, 1, k - 1)
    x0, x1 = np.take_along_axis(xp, i - 1, 1), np.take_along_axis(xp, i, 1)
    y0, y1 = np.take_along_axis(yp, i - 1, 1), np.take_along_axis(yp, i, 1)
    out = y0 + np.clip((x - x0) / np.maximum(x1 - x0, TINY), 0.0, 1.0) * (y1 - y0)
    out = np.where(before == 0, left, out)
    return np.where((before == k) & (x > xp[:, -1:]), right, out)


def profile_ridges(own_centre: NDArray[np.float64], next_centre: NDArray[np.float64],
                   own_axis: NDArray[np.float64], next_axis: NDArray[np.float64],
                   along: NDArray[np.float64], normal: NDArray[np.float64], *,
                   radius_mm: float, corner_radius_mm: float, flute_length_mm: float,
                   samples: int = PROFILE_SAMPLES
                   ) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """The bottom of the ridge between two passes' sections across the own pass (module doc).

    The own section's side towards the next (normals from a little past straight down,
    ``-y``, to ``+x``, with ``x`` across towards the next centre) and the next's side
    towards the own, each a polyline through :data:`PROFILE_SAMPLES` boundary points, rise
    and fall across: where the own side first stands at or above the next's, they cross.

    Parameters
    ----------
    own_centre, next_centre : ndarray, shape (m, 3)
        Ring centres of the own pass's pose over the contact and of the next pass's
        pose nearest to it, mm.
    own_axis, next_axis, along, normal : ndarray, shape (m, 3)
        Their unit tool axes, the own pass's unit direction and the surface normal.
    radius_mm, corner_radius_mm, flute_length_mm : float
        ``R``, ``r`` and ``L``, mm.

    Returns
    -------
    point : ndarray, shape (m, 3)
        The ridge's bottom, mm (where ``found``).
    found : ndarray of bool, shape (m,)
        False where the sides do not cross nearest the surface (the next section below
        the own contact, or the two apart).
    """
    m = len(own_centre)
    u = unit(along)
    y = unit(normal - np.einsum("ij,ij->i", normal, u)[:, None] * u)
    x = np.cross(y, u)
    d = next_centre - own_centre
    x *= np.where(np.einsum("ij,ij->i", d, x) < 0.0, -1.0, 1.0)[:, None]
    t = np.linspace(-0.5, 1.0, samples)
    psi = 0.5 * np.pi * t * np.abs(t)
    ring, lift = radius_mm - corner_radius_mm, flute_length_mm - corner_radius_mm
    own_c = np.zeros((m, 2))
    next_c = np.stack([np.einsum("ij,ij->i", d, x), np.einsum("ij,ij->i", d, y)], axis=1)
    x1, y1 = _section_side(own_c, own_axis, u, x, y, psi, ring, corner_radius_mm, lift)
    x2, y2 = _section_side(next_c, next_axis, u, x, y, -psi[::-1], ring, corner_radius_mm,
                           lift)
    # both polylines at all their points (sorted together): linear between neighbours
    both = np.concatenate([x1, x2], axis=1)
    order = np.argsort(both, axis=1, kind="stable")
    xs = np.take_along_axis(both, order, 1)
    own_before = np.cumsum(order < samples, axis=1)
    # the own side left of its contact stands as there; nothing past either's edge
    g1 = _on_merged(xs, own_before, x1, y1, y1[:, :1], np.inf)
    g2 = _on_merged(xs, np.cumsum(order >= samples, axis=1), x2, y2, np.inf, y2[:, -1:])
    with np.errstate(invalid="ignore"):
        f = g1 - g2
    rise = f >= 0.0
    j = np.argmax(rise, axis=1)
    found = rise.any(axis=1) & (j > 0)
    j = np.maximum(j, 1)
    rows = np.arange(m)
    f0, f1 = f[rows, j - 1], f[rows, j]
    found &= ~np.isnan(f0) & ~np.isnan(f1)
    xa, xb = xs[rows, j - 1], xs[rows, j]
    with np.errstate(invalid="ignore", divide="ignore"):
        lam = np.where(np.isfinite(f0) & np.isfinite(f1), f0 / (f0 - f1), 0.0)
        ya = np.where(np.isfinite(g1[rows, j - 1]), g1[rows, j - 1], g2[rows, j - 1])
        yb = np.where(np.isfinite(g1[rows, j]), g1[rows, j], g2[rows, j])
    # -inf at the left: the next side starts at xb (its edge, the own side's height
    # there); +inf at the right: the own side ends at xa (the next side's height there)
    lam = np.where(np.isneginf(f0), 1.0, lam)
    x_r = xa + lam * (xb - xa)
    y_r = np.where(np.isposinf(f1) & np.isfinite(f0), g2[rows, j - 1], ya + lam * (yb - ya))
    y_r = np.where(np.isneginf(f0), g1[rows, j], y_r)
    found &= np.isfinite(x_r) & np.isfinite(y_r)
    point = own_centre + np.where(found, x_r, 0.0)[:, None] * x + np.where(
        found, y_r, 0.0)[:, None] * y
    return point, found
