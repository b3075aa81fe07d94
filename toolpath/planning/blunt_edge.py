"""The blunt edge face an open blade leaves between its sections' last and first points.

A blade whose sections run TE -> suction side -> LE -> pressure side -> TE but stop short
of closing (a blunt trailing edge, its flat base not sampled) is fitted open: the surface
ends at ``t = 0`` and ``t = 1`` on either corner of the base, and the base itself, the
face between ``S(0, s)`` and ``S(1, s)``, is no part of the surface. Passes along t end at
its corners (or run past them by ``--extend``), so the face is not finished: planning
says so, with its width ``w(s) = |S(1, s) - S(0, s)|`` and its span, the arc length of the
mid-line ``(S(0, s) + S(1, s)) / 2`` over s.

It is a face, not an open sheet's two far edges, when its widest point is a small share
of the section's length (:data:`FACE_SHARE`); it matters when it is wider than
``min_width_mm`` (the chord tolerance: a gap the cutter bridges within it is closed).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..surface import ParametricSurface

__all__ = ["FACE_SHARE", "BluntFace", "blunt_face"]

#: A gap between the section's ends wider than this share of the section's length is
#: the far edges of an open sheet (a single blade side), not a blunt edge face.
FACE_SHARE = 0.05


@dataclass(frozen=True)
class BluntFace:
    """The unfitted face between the sections' last and first points (left uncut).

    Attributes
    ----------
    min_width_mm, max_width_mm : float
        Its narrowest and widest, ``|S(1, s) - S(0, s)|``, mm.
    span_mm : float
        Its length along the blade (mid-line arc length over s), mm.
    area_mm2 : float
        Its area (width integrated along the span), mm^2.
    """

    min_width_mm: float
    max_width_mm: float
    span_mm: float
    area_mm2: float

    def describe(self) -> str:
        """One line for the reports."""
        return (f"the blunt edge face between the sections' last and first points, "
                f"{self.min_width_mm:.3f}-{self.max_width_mm:.3f} mm wide over "
                f"{self.span_mm:.1f} mm of span ({self.area_mm2:.1f} mm^2), is not part of "
                f"the fitted surface and stays uncut (fit with --closed to cut round it)")


def blunt_face(surface: ParametricSurface, min_width_mm: float, n_s: int = 65,
               n_t: int = 129) -> BluntFace | None:
    """The face an open surface leaves between ``t = 1`` and ``t = 0``, or None.

    None for closed sections, for ends closer than ``min_width_mm`` everywhere, and for
    ends further apart than :data:`FACE_SHARE` of the section length (an open sheet).
    """
    if surface.closed_t:
        return None
    s = np.linspace(0.0, 1.0, n_s)
    first, last = surface(np.zeros(n_s), s), surface(np.ones(n_s), s)
    width = np.linalg.norm(last - first, axis=1)
    if width.max() <= min_width_mm:
        return None
    grid = surface(np.linspace(0.0, 1.0, n_t), s, grid=True).reshape(n_t, n_s, 3)
    section_mm = np.linalg.norm(np.diff(grid, axis=0), axis=2).sum(axis=0)
    if (width > FACE_SHARE * section_mm).any():
        return None
    step = np.linalg.norm(np.diff(0.5 * (first + last), axis=0), axis=1)
    return BluntFace(min_width_mm=float(width.min()), max_width_mm=float(width.max()),
                     span_mm=float(step.sum()),
                     area_mm2=float((0.5 * (width[1:] + width[:-1]) * step).sum()))
