"""Z-level roughing of a blade with contour-parallel offsets (shapely), 3-axis.

The part is sliced by planes ``p . up = z`` (section levels). At each level the tool must
stay out of the *shadow* of the part at and above the level (a 3-axis tool cannot reach
under an overhang): the union of the sections from the level up, grown by the finishing
allowance and the cutter radius, is the island the tool centre must avoid. The stock
outline is then offset inwards by ``R - stepover``, ``R - 2 stepover``, ... (contour
parallel), each offset ring clipped outside the island, until the offsets vanish; a last
ring follows the island itself, leaving exactly the allowance on the part.

A section is found by slicing a triangulated grid of the surface (spacing half the
allowance, so the facets' sag is far below it) and polygonizing the cut segments;
an open section (a blade fitted without its blunt trailing edge) is closed by thickening
the segments by ``eps = min(allowance / 2, 0.5 mm)`` and filling the hole, and ``eps`` is
taken off the offset so the allowance stays exact.

Moves within a level link straight when the link stays clear of the island; otherwise
the tool retracts to the clearance plane, traverses, rapids down to ``approach_mm`` above
the next start and plunges (a centre-cutting end mill is assumed). Rings run
counter-clockwise seen from ``up``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely
from numpy.typing import ArrayLike, NDArray
from shapely.geometry import LineString, MultiLineString, Polygon
from shapely.ops import unary_union

from ..errors import InvalidParameterError
from ..path import MoveKind, Toolpath
from ..surface import ParametricSurface, as_surface
from ..tolerances import LENGTH_SLACK_MM, LIMIT_SLACK, NULL_VECTOR, SAME_POINT_MM
from .cutters import Cutter, parse_cutter
from .errors import PlanningError
from .options import DEFAULT_FEED_MM_PER_MIN

__all__ = ["RoughingReport", "plan_roughing", "section_polygons"]

#: Vertices of the offset rings closer than this to the simplified path are dropped (mm);
#: the island is grown by as much, so the allowance is kept.
_SIMPLIFY_MM = 0.002


@dataclass(frozen=True)
class RoughingReport:
    """What a roughing plan does (mm, mm^2, mm^3, s).

    Attributes
    ----------
    levels_mm : tuple of float
        Heights (along ``up``) of the levels, top down.
    n_rings, n_points : int
        Offset rings cut and toolpath points.
    stepover_mm, step_down_mm, allowance_mm : float
        As planned.
    min_wall_clearance_mm : float
        Smallest distance measured from the tool-centre path to the sliced walls at or
        above each level, minus the cutter radius: the allowance left (>= the requested
        allowance up to the slicing tolerance).
    removed_volume_mm3 : float
        Stock minus island area per level times the step down (an estimate).
    length_mm : float
    seconds : float
    """

    levels_mm: tuple[float, ...]
    n_rings: int
    n_points: int
    stepover_mm: float
    step_down_mm: float
    allowance_mm: float
    min_wall_clearance_mm: float
    removed_volume_mm3: float
    length_mm: float
    seconds: float

    def lines(self) -> list[str]:
        """The report as text lines."""
        return [
            f"levels            {len(self.levels_mm)} (step down {self.step_down_mm:g} mm)",
            f"rings             {self.n_rings} (stepover {self.stepover_mm:g} mm)",
            f"points            {self.n_points}",
            f"allowance         {self.allowance_mm:g} mm requested, "
            f"{self.min_wall_clearance_mm:.4f} mm measured (smallest)",
            f"removed           {self.removed_volume_mm3 / 1000.0:.1f} cm^3 (estimate)",
            f"length            {self.length_mm:.1f} mm",
            f"planning time     {self.seconds:.2f} s",
        ]


def _frame(up: ArrayLike) -> NDArray[np.float64]:
    """Rows ``e_a, e_b, up``: an orthonormal frame with ``up`` last."""
    u = np.asarray(up, dtype=float)
    if u.shape != (3,) or not np.isfinite(u).all() or np.linalg.norm(u) < NULL_VECTOR:
        raise InvalidParameterError(f"up must be a non-zero 3-vector, got {up!r}")
    u = u / np.linalg.norm(u)
    helper = np.array([1.0, 0.0, 0.0]) if abs(u[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    a = np.cross(helper, u)
    a /= np.linalg.norm(a)
    return np.stack([a, np.cross(u, a), u])


def section_polygons(points: NDArray[np.float64], heights: ArrayLike, *, eps_mm: float
                     ) -> list[tuple[Polygon, MultiLineString] | None]:
    """Sections of a triangulated grid at each height: filled polygon and cut segments.

    ``points`` is ``(n_t, n_s, 3)`` in the level frame (height last). Each grid cell is
    split into two triangles; a triangle whose vertices straddle the height contributes the
    segment between its two edge crossings (linear interpolation). The segments, thickened
    by ``eps_mm`` and with their holes filled, give the polygon (``None``: no section).
    """
    p = np.asarray(points, dtype=float)
    a, b, c, d = p[:-1, :-1], p[1:, :-1], p[1:, 1:], p[:-1, 1:]
    tris = np.concatenate([np.stack([a, b, c], -2).reshape(-1, 3, 3),
                           np.stack([a, c, d], -2).reshape(-1, 3, 3)])
    z_lo, z_hi = tris[:, :, 2].min(axis=1), tris[:, :, 2].max(axis=1)
    order = np.argsort(z_lo)
    tris, z_lo, z_hi = tris[order], z_lo[order], z_hi[order]
    out: list[tuple[Polygon, MultiLineString] | None] = []
    for h in np.atleast_1d(heights):
        # only triangles starting below the height can reach it
        cand = np.arange(np.searchsorted(z_lo, h, side="right"))
        cand = cand[z_hi[cand] > h]
        if not cand.size:
            out.append(None)
            continue
        t, zc = tris[cand], tris[cand, :, 2] - h
        ends = []
        for i, j in ((0, 1), (1, 2), (2, 0)):
            crosses = (zc[:, i] > 0.0) != (zc[:, j] > 0.0)
            w = zc[:, i] / np.where(crosses, zc[:, i] - zc[:, j], 1.0)
            pt = t[:, i, :2] + w[:, None] * (t[:, j, :2] - t[:, i, :2])
            ends.append(np.where(crosses[:, None], pt, np.nan))
        e = np.stack(ends, 1)  # (m, 3, 2) with one NaN row per triangle
        ok = ~np.isnan(e[:, :, 0])
        pick = np.argsort(~ok, axis=1, kind="stable")[:, :2]
        seg = np.take_along_axis(e, pick[:, :, None], axis=1)
        seg = seg[np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1) > SAME_POINT_MM]
        lines = MultiLineString(list(shapely.linestrings(seg)))
        thick = shapely.line_merge(unary_union(lines)).buffer(eps_mm)
        filled = unary_union([Polygon(g.exterior) for g in getattr(thick, "geoms", [thick])
                              if not g.is_empty])
        out.append((filled, lines) if not filled.is_empty else None)
    return out


def _rings(geom: Any) -> list[LineString]:
    """Line pieces of a (multi)line geometry, as LineStrings."""
    if geom.is_empty:
        return []
    if isinstance(geom, LineString):
        return [geom]
    return [g for g in getattr(geom, "geoms", []) if isinstance(g, LineString) and
            g.length > 0.0]


def plan_roughing(surface: ParametricSurface, cutter: Cutter | str, *, step_down_mm: float,
                  allowance_mm: float = 0.5, stepover_mm: float | None = None,
                  stock: Any = None, stock_margin_mm: float = 3.0,
                  top_mm: float | None = None, bottom_mm: float | None = None,
                  up: ArrayLike = (0.0, 0.0, 1.0),
                  feed_mm_per_min: float = DEFAULT_FEED_MM_PER_MIN,
                  plunge_feed_mm_per_min: float | None = None, clearance_mm: float = 5.0,
                  approach_mm: float = 2.0, grid_mm: float | None = None
                  ) -> tuple[Toolpath, RoughingReport]:
    """Z-level contour-parallel roughing of ``surface`` from a stock outline (3-axis).

    Parameters
    ----------
    surface : ParametricSurface
        The part (a blade standing along ``up``).
    cutter : Cutter or str
        Usually a flat or bull-nose end mill (``"bull:10:1"``).
    step_down_mm : float
        Distance between levels.
    allowance_mm : float
        Material left on the part for finishing (0.5 mm).
    stepover_mm : float, optional
        Between offset rings (default 40 % of the diameter; at most the radius, so each
        plunge lands within the previous ring's cut).
    stock : shapely Polygon or (n, 2) array_like, optional
        Stock outline in the level plane's coordinates ``(p . e_a, p . e_b)``; default the
        part's outline grown by ``stock_margin_mm``.
    top_mm, bottom_mm : float, optional
        Height of the stock top and of the last level (default: the part's top plus the
        allowance, and its bottom).
    up : 3 floats
        Tool axis and level normal (default +Z).
    feed_mm_per_min, plunge_feed_mm_per_min, clearance_mm, approach_mm
        Feeds and the retract geometry (clearance above the stock top).
    grid_mm : float, optional
        Surface sampling for the sections (default half the allowance, within 0.1-1 mm;
        a facet ``c`` long sags ``c^2 / (8 rho)`` on a radius ``rho``: 0.03 mm for 0.25 mm
        facets on a 0.25 mm leading edge, within a 0.5 mm allowance).
    """
    t0 = time.perf_counter()
    surface = as_surface(surface)
    cutter = parse_cutter(cutter) if isinstance(cutter, str) else cutter
    big = cutter.radius_mm
    stepover = _checked_stepover(cutter, stepover_mm, step_down_mm=step_down_mm,
                                 allowance_mm=allowance_mm, feed_mm_per_min=feed_mm_per_min,
                                 clearance_mm=clearance_mm)
    frame = _frame(up)
    eps = min(allowance_mm / 2.0, 0.5)
    pts = _part_grid(surface, frame, grid_mm or float(np.clip(allowance_mm / 2.0, 0.1, 1.0)))
    part_top, part_bottom = float(pts[..., 2].max()), float(pts[..., 2].min())
    top = part_top + allowance_mm if top_mm is None else float(top_mm)
    bottom = part_bottom if bottom_mm is None else float(bottom_mm)
    levels = _levels(top, bottom, step_down_mm)
    sections, walls = _sections(pts, levels, bottom, part_top, step_down_mm, eps)
    stock_poly = _stock_outline(sections, stock, stock_margin_mm)
    moves = _Moves(frame, safe_mm=top + clearance_mm, approach_mm=approach_mm,
                   link_mm=2.0 * stepover + big)
    removed = 0.0
    min_clear = np.inf
    for level in levels:
        shadow, wall = _shadow(sections, walls, float(level))
        island = (shadow.buffer(allowance_mm + big - eps + _SIMPLIFY_MM)
                  if not shadow.is_empty else shadow)
        removed += (stock_poly.difference(shadow.buffer(allowance_mm - eps))
                    .area if not shadow.is_empty else stock_poly.area) * step_down_mm
        pieces = _offset_rings(stock_poly, island, big, stepover)
        clear = moves.cut_level(pieces, float(level), island,
                                None if shadow.is_empty else wall, big)
        min_clear = min(min_clear, clear)
    path = moves.toolpath(feed_mm_per_min, plunge_feed_mm_per_min or feed_mm_per_min / 4.0,
                          {"planner": "toolpath.planning.plan_roughing", "cutter": cutter.spec,
                           "allowance_mm": f"{allowance_mm:g}",
                           "step_down_mm": f"{step_down_mm:g}"})
    report = RoughingReport(
        levels_mm=tuple(float(v) for v in levels), n_rings=moves.n_rings, n_points=len(path),
        stepover_mm=stepover, step_down_mm=float(step_down_mm), allowance_mm=allowance_mm,
        min_wall_clearance_mm=float(min_clear), removed_volume_mm3=float(removed),
        length_mm=path.length_mm, seconds=time.perf_counter() - t0)
    return path, report


def _checked_stepover(cutter: Cutter, stepover_mm: float | None, **positive: float) -> float:
    """The stepover (default 40 % of the diameter), after checking ``positive`` are > 0.

    Raises :class:`InvalidParameterError` naming the first value out of range.
    """
    for name, value in positive.items():
        if not (np.isfinite(value) and value > 0.0):
            raise InvalidParameterError(f"{name} must be > 0, got {value!r}")
    big = cutter.radius_mm
    stepover = 0.4 * cutter.diameter_mm if stepover_mm is None else float(stepover_mm)
    if not (np.isfinite(stepover) and 0.0 < stepover <= big):
        raise InvalidParameterError(
            f"stepover_mm must be in (0, cutter radius {big:g}] mm, got {stepover_mm!r}")
    return stepover


def _part_grid(surface: ParametricSurface, frame: NDArray[np.float64], spacing_mm: float
               ) -> NDArray[np.float64]:
    """The surface sampled about ``spacing_mm`` apart, in the level frame (height last).

    The spacing along each parameter from the longest grid line of a 33 x 33 probe (at
    most 4000 samples a side).
    """
    g = np.linspace(0.0, 1.0, 33)
    probe = surface(g, g, grid=True)
    len_t = np.linalg.norm(np.diff(probe, axis=0), axis=2).sum(axis=0).max()
    len_s = np.linalg.norm(np.diff(probe, axis=1), axis=2).sum(axis=1).max()
    n_t = int(min(np.ceil(len_t / spacing_mm) + 1, 4000))
    n_s = int(min(np.ceil(len_s / spacing_mm) + 1, 4000))
    return surface(np.linspace(0, 1, n_t), np.linspace(0, 1, n_s), grid=True) @ frame.T


def _levels(top: float, bottom: float, step_down_mm: float) -> NDArray[np.float64]:
    """Heights of the levels, ``step_down_mm`` apart from ``top`` down, the last at ``bottom``."""
    if not top > bottom:
        raise InvalidParameterError(f"top_mm={top!r} must be above bottom_mm={bottom!r}")
    n_levels = int(np.ceil((top - bottom) / step_down_mm - LIMIT_SLACK))
    levels = top - step_down_mm * np.arange(1, n_levels + 1)
    levels[-1] = max(levels[-1], bottom)
    return levels


#: How far below the part's top (mm) its highest section is taken: the top itself cuts the
#: surface in a point or an edge, a micrometre lower in the top's outline (far below any
#: step down).
_BELOW_TOP_MM = 1e-6


def _sections(points: NDArray[np.float64], levels: NDArray[np.float64], bottom: float,
              part_top: float, step_down_mm: float, eps_mm: float
              ) -> tuple[dict[float, Polygon], dict[float, MultiLineString]]:
    """Sections (filled polygons) and walls (cut segments) by height.

    At the levels and, for the shadow, on a finer set of heights (every half step down
    from ``bottom`` and just below the part's top) (:func:`section_polygons`).
    """
    fine = np.unique(np.r_[levels, np.arange(bottom, part_top + LENGTH_SLACK_MM,
                                             step_down_mm / 2.0),
                           part_top - _BELOW_TOP_MM])
    cut = dict(zip(fine.tolist(), section_polygons(points, fine, eps_mm=eps_mm), strict=True))
    sections = {h: v[0] for h, v in cut.items() if v is not None}
    walls = {h: v[1] for h, v in cut.items() if v is not None}
    return sections, walls


def _stock_outline(sections: dict[float, Polygon], stock: Any, margin_mm: float) -> Polygon:
    """The stock outline given, or the sections' bounding box grown by ``margin_mm``."""
    outline = unary_union(list(sections.values()))
    if outline.is_empty:
        raise PlanningError("the surface has no section between the top and the bottom")
    if stock is None:
        return shapely.box(*outline.bounds).buffer(margin_mm, join_style="mitre")
    stock_poly = stock if isinstance(stock, Polygon) else Polygon(np.asarray(stock, float))
    if not stock_poly.is_valid or stock_poly.is_empty:
        raise InvalidParameterError("stock must be a valid, non-empty polygon")
    return stock_poly


def _shadow(sections: dict[float, Polygon], walls: dict[float, MultiLineString], level: float
            ) -> tuple[Any, Any]:
    """The union of the sections at and above ``level``, and of their walls."""
    above = [p for h, p in sections.items() if h >= level - LENGTH_SLACK_MM]
    shadow = unary_union(above) if above else Polygon()
    wall = unary_union([w for h, w in walls.items() if h >= level - LENGTH_SLACK_MM])
    return shadow, wall


def _offset_rings(stock: Polygon, island: Any, big: float, stepover: float
                  ) -> list[LineString]:
    """A level's rings, outside in: the stock's offsets clipped outside ``island``, then it.

    The stock outline offset inwards by ``R - stepover``, ``R - 2 stepover``, ... until
    the offsets vanish, counter-clockwise; then the island's own outlines within reach of
    the stock.
    """
    pieces: list[LineString] = []
    k = 1
    while True:
        ring = stock.buffer(big - k * stepover, join_style="round")
        if ring.is_empty:
            break
        for poly in getattr(ring, "geoms", [ring]):
            poly = shapely.geometry.polygon.orient(poly, 1.0)
            pieces.extend(_rings(poly.exterior.difference(island)))
        k += 1
    for poly in getattr(island, "geoms", [island]):
        if not poly.is_empty and stock.buffer(big).contains(poly):
            pieces.append(shapely.geometry.polygon.orient(poly, 1.0).exterior)
    return pieces


class _Moves:
    """The roughing toolpath's points as they are planned: positions, kinds, rings.

    Within a level a ring links straight from the last when the link stays clear of the
    island and within ``link_mm``; otherwise the tool retracts to ``safe_mm``, traverses,
    rapids down to ``approach_mm`` above the ring's start and plunges.
    """

    def __init__(self, frame: NDArray[np.float64], *, safe_mm: float, approach_mm: float,
                 link_mm: float) -> None:
        self.frame = frame
        self.safe_mm, self.approach_mm, self.link_mm = safe_mm, approach_mm, link_mm
        self.pos: list[NDArray[np.float64]] = []
        self.kinds: list[int] = []
        self.passes: list[int] = []
        self.n_rings = 0

    def at(self, xy: NDArray[np.float64], h: float) -> NDArray[np.float64]:
        """Points ``xy`` of the level plane at height ``h``, in part coordinates."""
        return xy[:, 0:1] * self.frame[0] + xy[:, 1:2] * self.frame[1] + h * self.frame[2]

    def add(self, points: NDArray[np.float64], kinds: list[int], passes: list[int]) -> None:
        """Append points with the kinds of the moves to them and their rings (-1: none)."""
        self.pos.append(points)
        self.kinds.extend(kinds)
        self.passes.extend(passes)

    def cut_level(self, pieces: list[LineString], level: float, island: Any, wall: Any,
                  big: float) -> float:
        """Cut ``pieces`` at ``level``, then retract; the smallest allowance left, mm.

        Measured from the tool-centre path to the sliced ``wall`` (not the thickened
        polygons) less the cutter radius ``big`` (``inf``: no wall).
        """
        last = None
        clear = np.inf
        for piece in pieces:
            # arcs from the offsets carry far more vertices than the cut needs
            piece = piece.simplify(_SIMPLIFY_MM)
            xy = np.asarray(piece.coords)
            if wall is not None:
                clear = min(clear, float(shapely.distance(piece, wall)) - big)
            path3 = self.at(xy, level)
            self._enter(xy, path3, level, island, last)
            self.add(path3[1:], [MoveKind.CUT] * (len(path3) - 1),
                     [self.n_rings] * (len(path3) - 1))
            last = xy[-1]
            self.n_rings += 1
        if last is not None:
            self.add(self.at(last[None], self.safe_mm), [MoveKind.RAPID], [-1])
        return clear

    def _enter(self, xy: NDArray[np.float64], path3: NDArray[np.float64], level: float,
               island: Any, last: NDArray[np.float64] | None) -> None:
        """Reach the start of the ring ``xy`` from the last ring's end ``last``."""
        if (last is not None and not LineString([last, xy[0]]).crosses(island)
                and np.linalg.norm(last - xy[0]) <= self.link_mm):
            self.add(path3[:1], [MoveKind.LINK], [self.n_rings])
            return
        if last is not None:
            self.add(self.at(last[None], self.safe_mm), [MoveKind.RAPID], [-1])
        self.add(self.at(xy[:1], self.safe_mm), [MoveKind.RAPID], [-1])
        self.add(self.at(xy[:1], level + self.approach_mm), [MoveKind.RAPID], [-1])
        self.add(path3[:1], [MoveKind.PLUNGE], [self.n_rings])

    def toolpath(self, feed_mm_per_min: float, plunge_feed_mm_per_min: float,
                 metadata: dict[str, str]) -> Toolpath:
        """The points as a :class:`Toolpath` (rapids at feed 0, plunges at the plunge feed)."""
        if not self.pos:
            raise PlanningError(
                "nothing to rough: the stock lies inside the island at every level")
        kinds = np.asarray(self.kinds, dtype=np.uint8)
        feeds = np.where(kinds == MoveKind.RAPID, 0.0,
                         np.where(kinds == MoveKind.PLUNGE, plunge_feed_mm_per_min,
                                  feed_mm_per_min))
        return Toolpath(np.concatenate(self.pos), self.frame[2], kinds, feeds,
                        np.asarray(self.passes, np.int32), metadata)
