"""Compiled pieces of the cutter solid shared by the compiled checks.

The solid of :meth:`~toolpath.planning.cutters.Cutter.signed_distance`: the points within
the corner radius ``r`` of the core cylinder ``{rho <= R - r, r <= z <= H - r}`` (``z``
along the axis from the tip, ``rho`` from the axis, ``H`` the flute length). Compiled
loops cannot call the numpy method; a test keeps the two equal.
"""

from __future__ import annotations

import math

import numba

__all__ = ["cutter_distance"]


@numba.njit(cache=True, inline="always")
def cutter_distance(p0, p1, p2, a0, a1, a2, r, big, h):
    """Signed distance (mm, < 0 inside) of the point ``p - tip`` to the cutter with axis ``a``."""
    z = p0 * a0 + p1 * a1 + p2 * a2
    rho = math.sqrt(max(p0 * p0 + p1 * p1 + p2 * p2 - z * z, 0.0))
    dx = rho - (big - r)
    dz = max(r - z, z - (h - r))
    outside = math.hypot(max(dx, 0.0), max(dz, 0.0))
    return outside + min(max(dx, dz), 0.0) - r
