"""The dev blade's exact surface, for measuring a fitted surface *between* the sections.

The bundled blade (``make_blades.py``, copied from ``shared/data/blades``) is analytic:
every section lies on the cylinder ``x^2 + y^2 = r^2`` with ``r`` linear in the span
fraction ``h``. So a fitted point's radius gives its ``h``, and its distance to the blade
is the distance, in the unrolled (axial, arc-length) plane, to the true profile at that
``h`` (densely sampled), together with nothing radial (sections are exact cylinders).
"""

from __future__ import annotations

import numpy as np
from make_blades import DR, N_SECTIONS, R_MID, contour_params, section_2d, span_laws, to_3d
from scipy.spatial import cKDTree

#: Chordwise stations of the dense reference profile (spacing well under 0.01 mm).
DENSE = 20001
HUB_R = R_MID - DR * (N_SECTIONS - 1) // 2
SPAN_R = DR * (N_SECTIONS - 1)


def _unrolled(points: np.ndarray, radius: float) -> np.ndarray:
    theta = np.arctan2(points[:, 1], points[:, 0])
    return np.column_stack([points[:, 2], radius * theta])


def _profile_distance(points: np.ndarray, h: float) -> np.ndarray:
    """Distance of points at span ``h`` to the true profile there (mm)."""
    r = HUB_R + SPAN_R * h
    xc, upper = contour_params((DENSE + 1) // 2)
    dense = to_3d(*section_2d(span_laws(h), xc, upper), span_laws(h), r)
    ref = _unrolled(dense, r)
    query = _unrolled(points, r)
    _, idx = cKDTree(ref).query(query)
    best = np.full(len(query), np.inf)
    for shift in (-1, 0):  # the segments either side of the nearest vertex
        a = ref[np.clip(idx + shift, 0, len(ref) - 2)]
        b = ref[np.clip(idx + shift + 1, 0, len(ref) - 1)]
        ab = b - a
        length2 = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
        u = np.clip(np.einsum("ij,ij->i", query - a, ab) / length2, 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(query - a - u[:, None] * ab, axis=1))
    return best


def between(surface, n_t: int = 400, n_s: int = 57, chunks: int = 8) -> float:
    """Largest distance (mm) from the fitted surface to the true blade on a dense grid.

    Each run of ``n_t / chunks`` neighbouring points of a streamline is measured against the
    true profile at the span fraction of its mean radius; this bounds the distance to the
    true surface from above.
    """
    t = np.linspace(0.0, 1.0, n_t)
    worst = 0.0
    for s in np.linspace(0.0, 1.0, n_s):
        points = surface(t, s)
        radius = np.linalg.norm(points[:, :2], axis=1)
        for chunk in np.array_split(np.arange(n_t), chunks):
            h = float(np.clip((radius[chunk].mean() - HUB_R) / SPAN_R, 0.0, 1.0))
            worst = max(worst, float(_profile_distance(points[chunk], h).max()))
    return worst
