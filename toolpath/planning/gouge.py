"""Gouge checks: local (curvature) and global (the cutter solid against surface samples).

**Local.** At a contact the cutter and the surface share the tangent plane; the cutter
stays out of the surface to second order iff its curvature exceeds the surface's in every
tangent direction, i.e. iff the 2x2 matrix ``D = C - S`` is positive semi-definite
(``C`` the cutter's second fundamental form, ``S`` the surface's, both positive when
curving towards the cutter side). The margin is its smaller eigenvalue
``(d11 + d22)/2 - sqrt(((d11 - d22)/2)^2 + d12^2)`` (1/mm); for a ball it is
``1/R - k_max``, negative where a concave radius ``1/k_max`` is smaller than the ball.

**Global.** The surface is sampled on a grid no coarser than ``sample_mm`` in either
direction; for every cutter location the samples near the cutter are found in a grid of
cells (those within ``R + horizon`` of the axis from ``r`` to ``H - r`` above the tip: a
capsule holding the whole cutter, :func:`query_capsule`) and the exact signed distance of
the cutter solid (:meth:`~toolpath.planning.cutters.Cutter.signed_distance`) is taken at
each, compiled (:mod:`.clearance_kernel`). The clearance of a location is the smallest
value (negative: the depth of a gouge); values above ``horizon_mm`` are not resolved and
reported as ``inf``. Samples closer than the cutter diameter to the location's own contact
point are the contact itself; they are kept apart so the report can tell a curvature gouge
near the contact from a collision with another part of the surface (the far clearance).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Final

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from ..surface import ParametricSurface
from .clearance_kernel import SampleCells, bin_samples, clearances, nearest_within
from .cutters import Cutter
from .local import PassFrame
from .resolution import GOUGE_TOL_MM

__all__ = [
    "CLEARANCE_HORIZON_MM",
    "GOUGE_TOL_MM",
    "Clearance",
    "SurfaceSamples",
    "global_clearance",
    "local_margin",
    "query_capsule",
    "sample_surface",
]

CLEARANCE_HORIZON_MM: Final[float] = 0.1
"""Clearances are resolved up to this distance, mm; larger ones read ``inf``. It keeps the
neighbour search small (a disc of radius ``sqrt(2 R h)`` around each contact)."""


def local_margin(frame: PassFrame, cutter: Cutter, axes: NDArray[np.float64]
                 ) -> NDArray[np.float64]:
    """Smallest eigenvalue of ``C - S`` at each contact, 1/mm (< 0: local gouge)."""
    c11, c12, c22 = cutter.curvature_tensor(frame.normal, axes, frame.e1, frame.e2)
    d11, d12, d22 = c11 - frame.s11, c12 - frame.s12, c22 - frame.s22
    return 0.5 * (d11 + d22) - np.sqrt(0.25 * (d11 - d22) ** 2 + d12 * d12)


@dataclass(frozen=True, eq=False)
class SurfaceSamples:
    """A grid of surface points with their parameters (binned and a k-d tree on demand)."""

    points: NDArray[np.float64]
    t: NDArray[np.float64]
    s: NDArray[np.float64]
    spacing_mm: float
    _cells: dict[float, SampleCells] = field(default_factory=dict, repr=False)

    @cached_property
    def tree(self) -> cKDTree:
        """A k-d tree over the points (built on first use: only the measurement asks).

        Split at the midpoints, nodes not shrunk to their points: on the grid's evenly
        spread points built in 0.4 times the time of a balanced, compact tree, and
        queried in 0.6 to 0.7 times (the same nearest points).
        """
        return cKDTree(self.points, balanced_tree=False, compact_nodes=False)

    def cells(self, reach_mm: float) -> SampleCells:
        """The samples binned for queries of radius up to ``reach_mm`` (kept for reuse)."""
        if reach_mm not in self._cells:
            self._cells[reach_mm] = bin_samples(self.points, reach_mm)
        return self._cells[reach_mm]

    def nearest(self, points_mm: NDArray[np.float64], reach_mm: float) -> NDArray[np.int64]:
        """The index of the sample nearest to each point, sought within ``reach_mm``.

        -1 where no sample lies within it. In the samples' cells binned already (the
        global gouge check's), else binned for ``reach_mm``: the k-d tree (:attr:`tree`)
        is not built for a search that the cells answer (a sample as near as the tree's;
        of two as near, the lower index, where the tree may take either: the two copies
        of a closed surface's seam).
        """
        cells = next(iter(self._cells.values())) if self._cells else self.cells(reach_mm)
        return nearest_within(cells, points_mm, reach_mm)


#: Largest turn of the normal between neighbouring sample columns (deg): a ``t`` interval
#: where the normal turns more (at any of the probe's ``s`` levels) is divided evenly, into
#: at most :data:`SAMPLE_MAX_SPLIT` parts, so a sharp edge (a nose of a few hundredths of
#: a mm, thinner than ``sample_mm``) is sampled round its turn, not stepped over.
SAMPLE_TURN_DEG = 10.0
SAMPLE_MAX_SPLIT = 64


def sample_surface(surface: ParametricSurface, sample_mm: float, *,
                   probe: int = 33, max_samples: int = 4_000_000) -> SurfaceSamples:
    """Grid samples with 3-D spacing at most ``sample_mm`` along ``t`` and ``s``.

    The counts come from the longest iso-curves measured on a ``probe x probe`` grid
    (polyline length, then 1.02 margin for the chords' shortfall); columns (``t``) are
    added where the normal turns faster (:data:`SAMPLE_TURN_DEG`).
    """
    g = np.linspace(0.0, 1.0, probe)
    pts = surface(g, g, grid=True)
    len_t = np.linalg.norm(np.diff(pts, axis=0), axis=2).sum(axis=0).max() * 1.02
    len_s = np.linalg.norm(np.diff(pts, axis=1), axis=2).sum(axis=1).max() * 1.02
    n_t = max(int(np.ceil(len_t / sample_mm)) + 1, 2)
    n_s = max(int(np.ceil(len_s / sample_mm)) + 1, 2)
    if n_t * n_s > max_samples:
        scale = np.sqrt(n_t * n_s / max_samples)
        n_t, n_s = int(n_t / scale) + 1, int(n_s / scale) + 1
    columns = np.linspace(0.0, 1.0, n_t)
    normals = surface.normal(columns, g, grid=True)
    cos_turn = np.einsum("ijk,ijk->ij", normals[1:], normals[:-1]).min(axis=1)
    turn = np.degrees(np.arccos(np.clip(cos_turn, -1.0, 1.0)))
    parts = np.clip(np.ceil(turn / SAMPLE_TURN_DEG), 1, SAMPLE_MAX_SPLIT).astype(np.int64)
    if (parts > 1).any() and (n_t + int((parts - 1).sum())) * n_s <= max_samples:
        pieces = [columns[:1]] + [np.linspace(a, b, k + 1)[1:] for a, b, k in
                                  zip(columns[:-1], columns[1:], parts, strict=True)]
        coarse = columns
        columns = np.concatenate(pieces)
        # (only the divided intervals' parts can still turn that much)
        divided = parts[np.clip(np.searchsorted(coarse, columns[:-1], side="right") - 1, 0,
                                parts.size - 1)] > 1
        columns = _fold_columns(surface, columns, divided, g,
                                max(max_samples // n_s, columns.size))
    t, s = np.meshgrid(columns, np.linspace(0.0, 1.0, n_s), indexing="ij")
    t, s = t.ravel(), s.ravel()
    points = surface(t, s)
    spacing = float(max(len_t / (n_t - 1), len_s / (n_s - 1)))
    return SurfaceSamples(points=points, t=t, s=s, spacing_mm=spacing)


#: A ``t`` interval where the normal still turns over :data:`SAMPLE_TURN_DEG` once divided
#: (a fold: a sharp edge, a crease, the normal turning at a point) is halved again until
#: its samples lie within this of each other, so the fold's own line is sampled to about
#: this (a cutter rolling round a ridge sits on its top, which samples either side of it
#: would miss by the slope times their distance); at most :data:`FOLD_HALVINGS` times.
FOLD_SAMPLE_MM = 2e-6
FOLD_HALVINGS = 32


def _fold_columns(surface: ParametricSurface, columns: NDArray[np.float64],
                  divided: NDArray[np.bool_], g: NDArray[np.float64], max_columns: int
                  ) -> NDArray[np.float64]:
    """``columns`` with the intervals across a fold halved (:data:`FOLD_SAMPLE_MM`).

    Of the intervals ``divided`` (``columns[i], columns[i + 1]``), each round evaluates
    the midpoints of those still turning over
    :data:`SAMPLE_TURN_DEG` (at any of the ``g`` levels of ``s``) and wider than
    :data:`FOLD_SAMPLE_MM`: a smooth turn stops once divided, a fold's interval halves
    each round (one or two new columns a fold a round).
    """
    def at(t: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return surface(t, g, grid=True), surface.normal(t, g, grid=True)

    def turning(a: tuple[NDArray[np.float64], NDArray[np.float64]],
                b: tuple[NDArray[np.float64], NDArray[np.float64]]) -> NDArray[np.bool_]:
        cos = np.einsum("ijk,ijk->ij", a[1], b[1]).min(axis=1)
        width = np.linalg.norm(b[0] - a[0], axis=2).max(axis=1)
        return (np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))) > SAMPLE_TURN_DEG) & (
            width > FOLD_SAMPLE_MM)

    lo, hi = columns[:-1][divided], columns[1:][divided]
    ends = at(np.r_[lo, hi])  # (one evaluation for both ends)
    lo_at = (ends[0][:lo.size], ends[1][:lo.size])
    hi_at = (ends[0][lo.size:], ends[1][lo.size:])
    todo = turning(lo_at, hi_at)
    lo, hi = lo[todo], hi[todo]
    lo_at, hi_at = (lo_at[0][todo], lo_at[1][todo]), (hi_at[0][todo], hi_at[1][todo])
    added: list[NDArray[np.float64]] = []
    for _ in range(FOLD_HALVINGS):
        if not lo.size or columns.size + sum(a.size for a in added) + lo.size > max_columns:
            break
        mid = 0.5 * (lo + hi)
        added.append(mid)
        mid_at = at(mid)
        left, right = turning(lo_at, mid_at), turning(mid_at, hi_at)
        lo, hi = np.r_[lo[left], mid[right]], np.r_[mid[left], hi[right]]
        lo_at = tuple(np.concatenate((x[left], y[right])) for x, y in zip(lo_at, mid_at,
                                                                          strict=True))
        hi_at = tuple(np.concatenate((x[left], y[right])) for x, y in zip(mid_at, hi_at,
                                                                          strict=True))
    if not added:
        return columns
    return np.unique(np.concatenate([columns, *added]))


@dataclass(frozen=True, eq=False)
class Clearance:
    """Per cutter location: the smallest signed distance to the surface samples.

    Attributes
    ----------
    near_mm : ndarray, shape (n,)
        Over samples within a cutter diameter of the location's contact point (all
        samples when no contact is given), mm; ``inf`` beyond the horizon.
    far_mm : ndarray, shape (n,)
        Over the other samples, mm.
    near_sample, far_sample : ndarray of int, shape (n,)
        Index of the sample giving each value (``-1`` when ``inf``).
    """

    near_mm: NDArray[np.float64]
    far_mm: NDArray[np.float64]
    near_sample: NDArray[np.int64]
    far_sample: NDArray[np.int64]

    @property
    def min_mm(self) -> NDArray[np.float64]:
        """``min(near, far)``."""
        return np.minimum(self.near_mm, self.far_mm)


def query_capsule(cutter: Cutter, horizon_mm: float, flutes: bool = True
                  ) -> tuple[float, float, float]:
    """The axis segment (``low, high`` mm up from the tip) and reach (mm) of the query.

    Their capsule holds every point within ``horizon_mm`` of the cutter. The solid is the
    points within ``r`` of the core cylinder ``rho <= R - r``, ``r <= z <= H - r``, so
    within ``R`` of its axis segment; without ``flutes``, the cutting end only: the ball
    round the corner circle's centre.
    """
    big, r, h = cutter.radius_mm, cutter.corner_radius_mm, cutter.flute_length_mm
    return r, (max(h - r, r) if flutes else r), big + horizon_mm


def global_clearance(cutter: Cutter, tips_mm: NDArray[np.float64], axes: NDArray[np.float64],
                     samples: SurfaceSamples, *, contacts_mm: NDArray[np.float64] | None = None,
                     horizon_mm: float = CLEARANCE_HORIZON_MM, flutes: bool = True) -> Clearance:
    """Signed clearance of the cutter at each location against the surface samples.

    Parameters
    ----------
    cutter : Cutter
    tips_mm, axes : ndarray, shape (n, 3)
        Cutter locations (tool tips) and unit tool axes.
    samples : SurfaceSamples
        From :func:`sample_surface`.
    contacts_mm : ndarray, shape (n, 3), optional
        Intended contact points; samples within a cutter diameter of them count as
        *near*. Without them every sample is near.
    horizon_mm : float
        Clearances beyond this are not resolved (``inf``).
    flutes : bool
        Check the whole flute length (default), not only the cutting end.
    """
    low, high, reach = query_capsule(cutter, horizon_mm, flutes)
    near, far, near_i, far_i = clearances(
        samples.cells(reach), tips_mm, axes, contacts_mm, low, high, reach,
        cutter.corner_radius_mm, cutter.radius_mm, cutter.flute_length_mm,
        2.0 * cutter.radius_mm)
    near = np.where(near > horizon_mm, np.inf, near)
    far = np.where(far > horizon_mm, np.inf, far)
    return Clearance(near_mm=near, far_mm=far, near_sample=np.where(np.isinf(near), -1, near_i),
                     far_sample=np.where(np.isinf(far), -1, far_i))
