"""Compiled pieces of the cutter solid shared by the compiled checks.

The solid of :meth:`~toolpath.planning.cutters.Cutter.signed_distance`: the points within
the corner radius ``r`` of the core cylinder ``{rho <= R - r, r <= z <= H - r}`` (``z``
along the axis from the tip, ``rho`` from the axis, ``H`` the flute length). Compiled
loops cannot call the numpy method; a test keeps the two equal. And the cutting end's
section swept along a direction (:class:`~toolpath.planning.cutters.CutterShadow`).
"""

from __future__ import annotations

import math

import numba

__all__ = ["cutter_distance", "shadow_point"]

#: Floor of ``|A^T nu|`` in :func:`shadow_point`: zero only for a core disc seen edge on,
#: where any disc point is as good; the floor keeps the division finite.
_LEAST_NORM = 1e-15


@numba.njit(cache=True, inline="always")
def cutter_distance(p0, p1, p2, a0, a1, a2, r, big, h):
    """Signed distance (mm, < 0 inside) of the point ``p - tip`` to the cutter with axis ``a``."""
    z = p0 * a0 + p1 * a1 + p2 * a2
    rho = math.sqrt(max(p0 * p0 + p1 * p1 + p2 * p2 - z * z, 0.0))
    dx = rho - (big - r)
    dz = max(r - z, z - (h - r))
    outside = math.hypot(max(dx, 0.0), max(dz, 0.0))
    return outside + min(max(dx, dz), 0.0) - r


@numba.njit(cache=True, inline="always")
def shadow_point(a11, a12, a21, a22, d1, d2, r, theta):
    """:class:`~toolpath.planning.cutters.CutterShadow`'s boundary point ``theta``.

    With the core disc's projection ``A = [[a11, a12], [a21, a22]]`` and its depth
    coefficients ``(d1, d2)`` (centre at the origin): the point with outward normal
    ``nu = (sin th, -cos th)`` is ``A u + r nu`` with the disc point ``u = A^T nu / |A^T nu|``,
    and the torus point casting it lies ``d1 u1 + d2 u2`` along the view direction (only
    the disc point moves it that way). Returns ``(x, z, depth)``.
    """
    nx, nz = math.sin(theta), -math.cos(theta)
    w1, w2 = a11 * nx + a21 * nz, a12 * nx + a22 * nz  # A^T nu
    size = max(math.hypot(w1, w2), _LEAST_NORM)
    u1, u2 = w1 / size, w2 / size
    return (a11 * u1 + a12 * u2 + r * nx, a21 * u1 + a22 * u2 + r * nz,
            d1 * u1 + d2 * u2)
