"""Verification options: one frozen, validated record; every default with its reason.

All lengths in mm. Errors name the keyword and show the value with ``!r``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, Final

from .errors import VerificationError

__all__ = [
    "DEFAULT_GOUGE_TOL_MM",
    "DEFAULT_HORIZON_MM",
    "DexelMethod",
    "VerifyOptions",
    "stepover_for_scallop_mm",
]

DEFAULT_GOUGE_TOL_MM: Final[float] = 0.002
"""Material missing below the design counted as a gouge, mm: twice the 1 um resolution of
the coordinates in the G-code text (a correct program rounded to it can dip by about half
of that per axis), well above the replay and sampling errors (0.2 um)."""

DEFAULT_HORIZON_MM: Final[float] = 0.2
"""Remaining material resolved up to this height, mm; more is reported as *not cut*.
Forty times a typical 0.005 mm finishing scallop, and about what a roughing pass leaves."""

DEFAULT_STOCK_MM: Final[float] = 0.5
"""Material on the design surface before the program, mm (a typical semi-finish
allowance); what a sample the cutter never reached keeps."""


class DexelMethod(StrEnum):
    """Direction of the dexels through the design samples."""

    AUTO = "auto"  #: the normal (the more accurate; see ``Z``)
    NORMAL = "normal"  #: along the outward surface normal (measures normal deviation)
    #: along +Z: a Z-map (height map) whose nodes are the design samples; the normal
    #: deviation is taken as ``dz n_z``, first order, so it overstates gouges on steep
    #: walls (on the dev blade: 0.0155 mm where the normal dexels measure 0.0105 mm)
    Z = "z"


def stepover_for_scallop_mm(scallop_mm: float, radius_mm: float) -> float:
    """Flat-surface stepover ``w = 2 sqrt(h (2R - h))`` leaving cusps of height ``h``, mm.

    Parameters
    ----------
    scallop_mm : float
        Cusp height ``h``, mm.
    radius_mm : float
        Ball radius ``R``, mm.

    Returns
    -------
    float
        The stepover, mm.
    """
    h = min(scallop_mm, radius_mm)
    return 2.0 * math.sqrt(h * (2.0 * radius_mm - h))


def _length(value: Any, name: str, *, allow_none: bool = False) -> float | None:
    if value is None and allow_none:
        return None
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise VerificationError(f"{name} must be a length in mm, got {value!r}") from None
    if not (math.isfinite(out) and out > 0.0):
        raise VerificationError(f"{name} must be a finite length > 0 mm, got {value!r}")
    return out


@dataclass(frozen=True, kw_only=True)
class VerifyOptions:
    """How finely and how far the cut is compared with the design.

    Attributes
    ----------
    scallop_mm : float or None
        The scallop height the program was planned for, mm. Sets the default sample
        spacing (a sixth of the flat stepover it implies) and is reported next to the
        measured excess.
    spacing_mm : float or None
        Largest distance between design samples along ``t`` and ``s``, mm. Default: from
        ``scallop_mm``, else ``R / 20`` (0.15 mm for a 6 mm ball; bull-nose ``r / 20``;
        see :meth:`resolved`).
    spacing_s_mm : float or None
        Spacing across the passes (along ``s``) when it should differ from ``spacing_mm``.
    max_samples : int
        Largest sample grid; both spacings grow together beyond it (one million: cusp
        tops are found by the refinement anyway, and a million samples of a fitted blade
        evaluate in about 5 s).
    method : DexelMethod
        ``normal`` (``auto``) or ``z`` (a height map; first order on steep walls).
    horizon_mm : float
        Excess resolved up to this, mm (:data:`DEFAULT_HORIZON_MM`); capped at the stock.
    stock_mm : float
        Material on the design before the program, mm (:data:`DEFAULT_STOCK_MM`).
    gouge_tol_mm : float
        Depth counted as a gouge, mm (:data:`DEFAULT_GOUGE_TOL_MM`).
    gouge_search_mm : float or None
        Depth below the design the near search is sized for, mm (default: the first
        search level). Deeper gouges are found too: at their deepest point by the near
        search whenever the depth is below its radius, and by the collision search, such
        gouges being wider than its spacing; the deepest is then re-measured with both.
    replay_tol_mm : float
        Chord tolerance of the replayed tip and ball-centre paths and of arcs, mm (0.5 um:
        a quarter of the gouge tolerance; the swept capsules stand inside the true sweep
        by at most this).
    merge_tol_mm : float
        Consecutive ball-centre chords are merged while every centre stays within this of
        the merged chord, mm (1 um: the resolution of millimetre G-code, whose rounding
        noise would otherwise stop merging; measured deviations move by at most this).
        0 keeps every chord.
    extremes_tol_mm : float or None
        Chord tolerance of the fine model the reported extremes (deepest gouge, largest
        excess and scallop) are measured with, mm (20 nm: 0.4 % of a 5 um scallop at most, as a
        bound; under 0.15 % measured, against 10 nm, on the blade and propeller programs). The
        whole program is searched with the coarser model above, whose figures depend on
        how the path is cut into moves by up to ``replay_tol_mm + merge_tol_mm``; the
        stretches of path around the extremes' candidates are then replayed to this,
        every chord kept (:mod:`verification.fine_model`), so the reported extremes are
        the same whether a path is written as few long moves or many short ones. None:
        the coarse model's figures.
    max_piece_mm : float or None
        Longest ball piece, mm (default: the first near-search radius, so a piece reaches
        at most half of it past the search; the shank is cut into ``R / 2`` pieces).
    first_level_mm : float or None
        First level of the near search's iterative deepening, mm (default twice the
        scallop asked, else the horizon / 64). Levels grow 8x up to the horizon; a dexel
        whose remaining material is within a level is exact at that level.
    collision : bool
        Run the collision search (shank, ball from behind, rapids through the part).
    collision_spacing_mm : float or None
        Spacing of the samples the collision search starts from, mm (default ``R / 2``:
        anything touching the part over a wider patch is found, then searched around at
        full resolution; a ball gouge deeper than the near search radius ``r`` is
        ``2 sqrt(2 R r)`` wide, more than ``R`` for any ``r > R / 8``).
    shank_spacing_mm : float or None
        Path distance between shank instances, mm (default ``R``: the union of shank
        capsules then dips at most ``0.13 R`` below the swept shank).
    refine : int
        Local extremes (largest excesses, deepest gouges) re-measured on finer grids
        around them (64). The largest cusp is a kink, so a grid misses its top by about
        ``spacing x slope``; three levels of 9 x 9 samples cut the spacing by 64.
    max_pairs : int
        Candidate (dexel, piece) pairs per batch: bounds memory (2 million pairs: about
        0.5 GB of temporaries).
    """

    scallop_mm: float | None = None
    spacing_mm: float | None = None
    spacing_s_mm: float | None = None
    max_samples: int = 1_000_000
    method: DexelMethod = DexelMethod.AUTO
    horizon_mm: float = DEFAULT_HORIZON_MM
    stock_mm: float = DEFAULT_STOCK_MM
    gouge_tol_mm: float = DEFAULT_GOUGE_TOL_MM
    gouge_search_mm: float | None = None
    replay_tol_mm: float = 5e-4
    merge_tol_mm: float = 1e-3
    extremes_tol_mm: float | None = 2e-5
    max_piece_mm: float | None = None
    first_level_mm: float | None = None
    collision: bool = True
    collision_spacing_mm: float | None = None
    shank_spacing_mm: float | None = None
    refine: int = 64
    max_pairs: int = 2_000_000

    def __post_init__(self) -> None:
        put = object.__setattr__
        for name in ("scallop_mm", "spacing_mm", "spacing_s_mm", "max_piece_mm",
                     "collision_spacing_mm", "shank_spacing_mm", "gouge_search_mm",
                     "first_level_mm", "extremes_tol_mm"):
            put(self, name, _length(getattr(self, name), name, allow_none=True))
        for name in ("horizon_mm", "stock_mm", "gouge_tol_mm", "replay_tol_mm"):
            put(self, name, _length(getattr(self, name), name))
        try:
            put(self, "method", DexelMethod(str(self.method).lower()))
        except ValueError:
            raise VerificationError(
                f"method must be one of {[m.value for m in DexelMethod]}, "
                f"got {self.method!r}") from None
        if not (math.isfinite(self.merge_tol_mm) and self.merge_tol_mm >= 0.0):
            raise VerificationError(
                f"merge_tol_mm must be a finite length >= 0 mm, got {self.merge_tol_mm!r}")
        for name, low in (("max_samples", 4), ("refine", 0), ("max_pairs", 1000)):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < low:
                raise VerificationError(f"{name} must be an integer >= {low}, got {value!r}")

    def levels(self) -> tuple[float, ...]:
        """Near-search levels, mm: from the first level up by 8x to the horizon."""
        horizon = min(self.horizon_mm, self.stock_mm)
        if self.first_level_mm is not None:
            first = self.first_level_mm
        elif self.scallop_mm is not None:
            first = 2.0 * self.scallop_mm
        else:
            first = horizon / 64.0
        out = [min(first, horizon)]
        while out[-1] * 8.0 < horizon:
            out.append(out[-1] * 8.0)
        if out[-1] < horizon:
            out.append(horizon)
        return tuple(out)

    def resolved(self, radius_mm: float, corner_radius_mm: float | None = None
                 ) -> dict[str, float]:
        """Defaults that depend on the cutter, all in mm.

        Parameters
        ----------
        radius_mm : float
            Cutter radius ``R``, mm.
        corner_radius_mm : float, optional
            Corner radius ``r``, mm (default ``R``: a ball). A bull-nose's cusps are those
            of a ball of radius ``r`` (its flat bottoms leave none), so ``r`` sets the
            default spacing and the near search; a flat end mill (``r = 0``) leaves no
            cusp on a plane, and is sampled at ``R / 20``. Pieces may be ``(R - r) / 2``
            longer: the core disc widens the near search by ``R - r`` anyway.
        """
        corner = radius_mm if corner_radius_mm is None else corner_radius_mm
        shape = corner if corner > 0.0 else radius_mm
        if self.spacing_mm is not None:
            spacing = self.spacing_mm
        elif self.scallop_mm is not None and corner > 0.0:
            spacing = stepover_for_scallop_mm(self.scallop_mm, corner) / 6.0
        else:
            spacing = shape / 20.0
        first = self.levels()[0]
        depth = self.gouge_search_mm if self.gouge_search_mm is not None else first
        near = (1.1 * math.sqrt(2.0 * corner * (first + depth)) + depth
                + 0.5 * (radius_mm - corner))
        return {
            "spacing_t_mm": spacing,
            "spacing_s_mm": self.spacing_s_mm if self.spacing_s_mm is not None else spacing,
            "horizon_mm": min(self.horizon_mm, self.stock_mm),
            "gouge_search_mm": depth,
            "max_piece_mm": self.max_piece_mm or near,
            "shank_piece_mm": max(self.max_piece_mm or 0.0, radius_mm / 2.0),
            "collision_spacing_mm": self.collision_spacing_mm or radius_mm / 2.0,
            "shank_spacing_mm": self.shank_spacing_mm or radius_mm,
        }
