"""A flat or bull-nose disc hanging over an open edge of the surface.

The chord measure and the planner read how deep a cutter's corner-circle disc (radius
``rho`` at height ``r`` up the axis, :func:`~.sampling.cutter_gap`) reaches below the
surface from points ``K`` of the disc: ``(K - X) . n`` at the foot ``X`` of ``K`` (its
closest surface point), with ``n`` the outward normal there. Where ``K`` lies beyond an
open edge (``s = 0`` or ``1``; ``t = 0`` or ``1`` when the sections are open), its search
ends on the edge, and ``(K - X) . n`` reads the edge's tangent plane carried on into air:
the disc hanging 3 mm past a propeller tip read 1.6 mm "inside" from the tip section's
far side, where the verifier finds no gouge, and the planner split 199 moves that did not
need it.

Past the edge there is no surface to cut: what such a ``K`` can cut there is the edge
point ``X`` itself. So a reading of "inside" past the edge stands only as deep as ``X``
lies inside the cutter, read as a disc point whose foot is ``X`` would read it: the disc
point ``K* = X - lam n`` on ``X``'s normal line, ``lam = ((X - C) . a) / (n . a)`` (``C``
the disc's centre, ``a`` the tool axis), reads ``(K* - X) . n = -lam``, the depth of the
disc under ``X`` along ``X``'s normal (what the verifier's dexel through ``X``
measures). Where that line misses the disc (``|K* - C| > rho``, or ``n . a <= 0``: the
surface there faces away from the tool), ``X`` reads its signed distance to the solid the
disc bounds from below (the cutter less its corner radius,
:meth:`~.cutters.Cutter.signed_distance` plus ``r``): how far inside through the cutter's
side, or its clearance. The reading past the edge becomes the larger of the two (the
caller subtracts ``r`` from every reading alike). Readings of no gouge past the edge stand
as read: the tangent plane carried on is smooth through a contact on the edge (a pass
along it), where a disc sampled at 15 degrees finds the rim's lowest point by a
parabola.

``K`` lies past the edge where the offset ``K - X`` points out of the surface's domain:
along ``+X_s`` at ``s = 1``, ``-X_s`` at ``s = 0``, likewise ``X_t`` on open sections. A
foot on the edge whose offset points back in (a search stopped short) is left as read.
Only readings of a gouge (below ``r``) are looked at, the others stand: the cost is a
few partials at the few feet where a disc hangs past an edge into its tangent plane.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..surface import ParametricSurface, outward_normals
from ..vectors import row_lengths
from .cutters import Cutter

__all__ = ["beyond_open_edges", "edge_readings"]


def beyond_open_edges(surface: ParametricSurface, points_mm: NDArray[np.float64],
                      t: NDArray[np.float64], s: NDArray[np.float64],
                      among: NDArray[np.bool_] | None = None
                      ) -> tuple[NDArray[np.int64], dict[tuple[int, int], NDArray[np.float64]]]:
    """Rows whose foot ``(t, s)`` lies on an open edge, the point past it.

    Of the rows ``among`` (default all). Returns the rows and the partials ``X``, ``X_t``,
    ``X_s`` at their feet (``{(0, 0): ..., (1, 0): ..., (0, 1): ...}``, rows in that order).
    """
    on_edge = (s <= 0.0) | (s >= 1.0)
    if not surface.closed_t:
        on_edge |= (t <= 0.0) | (t >= 1.0)
    if among is not None:
        on_edge &= among
    rows = np.flatnonzero(on_edge)
    if not rows.size:
        return rows, {}
    t_e, s_e = t[rows], s[rows]
    parts = surface.partials_many(t_e, s_e, ((0, 0), (1, 0), (0, 1)))
    offset = points_mm[rows] - parts[0, 0]
    along_s = np.einsum("ij,ij->i", offset, parts[0, 1])
    past = ((s_e >= 1.0) & (along_s > 0.0)) | ((s_e <= 0.0) & (along_s < 0.0))
    if not surface.closed_t:
        along_t = np.einsum("ij,ij->i", offset, parts[1, 0])
        past |= ((t_e >= 1.0) & (along_t > 0.0)) | ((t_e <= 0.0) & (along_t < 0.0))
    return rows[past], {order: value[past] for order, value in parts.items()}


def edge_readings(surface: ParametricSurface, points_mm: NDArray[np.float64],
                  t: NDArray[np.float64], s: NDArray[np.float64],
                  signed_mm: NDArray[np.float64], cutter: Cutter, tips_mm: NDArray[np.float64],
                  axes: NDArray[np.float64]) -> NDArray[np.float64]:
    """The disc points' readings ``(K - X) . n``, those inside past an open edge capped.

    ``points_mm`` (rows ``K`` of the corner-circle discs of ``cutter``), their feet ``t``,
    ``s`` and readings ``signed_mm``; each point's cutter tip and unit axis (module
    docstring). Returns ``signed_mm`` itself when no point lies past an open edge, else a
    copy with those rows replaced.
    """
    rows, parts = beyond_open_edges(surface, points_mm, t, s,
                                    signed_mm < cutter.corner_radius_mm)
    if not rows.size:
        return signed_mm
    r = cutter.corner_radius_mm
    foot, a, tip = parts[0, 0], axes[rows], tips_mm[rows]
    normal = outward_normals(surface, parts[1, 0], parts[0, 1])
    centre = tip + r * a
    facing = np.einsum("ij,ij->i", normal, a)
    height = np.einsum("ij,ij->i", foot - centre, a)  # of X above the disc's plane
    depth = np.divide(height, facing, out=np.full(rows.size, np.inf), where=facing > 0.0)
    under = foot - depth[:, None] * normal  # K*, where the normal line meets the plane
    meets = (facing > 0.0) & (row_lengths(under - centre) <= cutter.radius_mm - r)
    out = signed_mm.copy()
    edge = np.where(meets, -depth, cutter.signed_distance(foot, tip, a) + r)
    out[rows] = np.maximum(signed_mm[rows], edge)
    return out
