"""Matching blade sections before a surface is built: like with like along every section.

In real exports point ``i`` of one section is not at the same chordwise place as point ``i``
of the next (nose point counts vary, the start point shifts), and measured sections often
have different point counts. A surface interpolating column ``i`` across the sections then
joins a nose point of one section to a flank point of the next. So each section's points
get a parameter ``t`` that pairs like with like, from **landmarks** found in the geometry:

- the leading and trailing edges are the two ends of the section's **longest chord** (its
  diameter), each refined on the section's interpolating cubic (in arc length) to the point
  farthest from the other end; of the two, the **trailing edge is the thinner end**: the
  section's width across that chord, 5 % of the chord in from each end, summed over all
  sections with the ends followed from section to section (a rule that holds for round,
  elliptic, wedge and blunt edges, whichever end the export starts at);
- an **open** section's ends are its trailing-edge corners already, so its one interior
  landmark is the leading edge: the point farthest from the midpoint of its two ends;
- a **closed** section (first point repeated at the end) is cyclically shifted so that its
  seam lies at its trailing edge, the seam point taken from the section's periodic
  interpolating cubic (the data points stay data points).

Between landmarks ``t`` is the section's own parameter (chord length by default) mapped
linearly onto **common landmark parameters**, the mean over the sections of each landmark's
fraction of the section's length. Points at the same ``t`` are then at the same place
relative to the edges on every section.

The surface grid needs every section at every column. When the sections already
correspond (same point counts, the edges within :data:`CORRESPOND_SPREAD` points of each
other, closed seams left where they are) the columns are the mean of the sections' own
parameters per index, as before matching existed. Otherwise the columns
are the union of all sections' matched parameters, and a section's entries at the other
sections' columns come from its Akima cubic in the matched parametrization (local: no
ring after a nose meets its flank, :func:`_entries`). A
mask marks the entries that are data. Near-duplicate parameters are *not* merged: moving a
point's parameter by even 0.1 % of its spacing puts it beside interpolated entries of its
own section that disagree with it, and the fit ripples between them (DCA rotor, tol 0.03:
0.044 mm off the truth between sections with such merging, 0.025 without). Refitting each
section's cubic to its merged parameters does not save it: the data then carry the
merge's jitter along ``t``, which a fit measured at the same parameter must follow (DCA
rotor, tol 0.01, parameters within 5 % of the local spacing merged: 1985 columns fall to
1275, but the fits need 82-92 control points instead of 17-21, take 1.5-3x as long and are
0.0064-0.0077 mm off the truth instead of 0.0038-0.0052).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.interpolate
from numpy.typing import NDArray

from .errors import InvalidPointsError
from .knots import DEFAULT_CORNER_ANGLE_DEG, seam_multiplicity
from .parametrize import cumulative_parameters

__all__ = ["MatchedGrid", "SectionLandmarks", "match_sections", "section_landmarks"]

#: Width of a section across its longest chord is compared this far in from each end
#: (fraction of the chord) to tell the trailing edge (thinner) from the leading edge.
EDGE_WIDTH_AT = 0.05
#: A closed section is blade-like (elongated, with edges to find) when its length is at most
#: this many times its longest chord (a thin blade: about 2; a circle: pi).
MAX_PERIMETER_PER_CHORD = 2.6
#: A closed section's trailing edge within this fraction of the local spacing of a data
#: point is that point (the seam is then a data point, not an interpolated one).
SNAP_FRACTION = 0.25
#: Sections whose edges lie within this many points of each other (by fractional index),
#: with the same counts, correspond by index.
CORRESPOND_SPREAD = 1.0
#: A section whose vector area is below this fraction of its squared length is next to
#: straight: its direction round is not judged (a thin blade: about 1e-2).
FLAT_AREA_FRACTION = 1e-4
#: Matched parameters this close are one grid column: equal to rounding (sections sampled
#: alike give columns 1e-17 apart). Not more: the DCA rotor's closest columns, 6e-10 apart,
#: merged, move its open fits from 0.0040 to 0.0060 mm at the data (the knot search starts
#: elsewhere) and from 0.0038 to 0.0054 mm off the truth file.
SAME_PARAMETER = 1e-12
#: Floor of an edge width (mm) in the log of the two ends' width ratio: a section pinched
#: to a point at one end gives width 0, and its log would be -inf.
_LEAST_WIDTH_MM = 1e-12
#: Samples of a local window when a landmark is refined on the interpolating cubic.
REFINE_SAMPLES = 41
#: Dense samples per section for the edge-width rule.
DENSE_SAMPLES = 2048


@dataclass(frozen=True)
class SectionLandmarks:
    """Landmarks of one section, as positions ``u`` along its own parameter.

    ``u`` is the section's cumulative parameter (chord length by default,
    :func:`toolpath.parametrize.cumulative_parameters`); for a closed
    section it runs once around, ``length`` is its period.
    """

    u_le: float
    u_te: float  # closed: the seam; open: the first point (u = 0)
    length: float


def _interpolant(u: NDArray[np.float64], points: NDArray[np.float64], closed: bool
                 ) -> scipy.interpolate.CubicSpline:
    """The section's interpolating cubic in ``u`` (periodic for a closed section)."""
    return scipy.interpolate.CubicSpline(u, points, bc_type="periodic" if closed else
                                         "not-a-knot")


def _entries(t: NDArray[np.float64], points: NDArray[np.float64], closed: bool
             ) -> scipy.interpolate.Akima1DInterpolator:
    """The section between its points, for its entries at the other sections' columns.

    Akima's local cubic (its slope at a point from the two chords either side, weighted by
    how much the chords' slopes change further out), not the interpolating C2 cubic: where
    a nose circle meets its flank (the curvature jumps, G1 only) the C2 cubic rings for
    several intervals, bending concave where the section is convex (DCA rotor: 0.7° of
    concave turn after the TE nose), and the fit on the grid follows it. Akima's slopes
    settle on the flank's chords at once. A closed section is wrapped by three points each
    side so the seam is read like any other point, unless the seam is a corner of its data
    (a sharp trailing edge, :func:`toolpath.knots.seam_multiplicity`): each flank then
    runs to it on its own side. Wrapped, the slopes at a wedge's neighbours took in the
    other flank's chords: the entries of a propeller section sampled at half the stations
    of its neighbours rounded the wedge they ran to, and the fit, a corner at the seam,
    folded between them (a ball cutter 3 mm into it).
    """
    if not closed or seam_multiplicity(points, DEFAULT_CORNER_ANGLE_DEG) > 1:
        return scipy.interpolate.Akima1DInterpolator(t, points, axis=0)
    ring, period = points[:-1], t[-1] - t[0]
    wrap_t = np.concatenate((t[-4:-1] - period, t, t[1:4] + period))
    wrap = np.vstack((ring[-3:], points, ring[1:4]))
    return scipy.interpolate.Akima1DInterpolator(wrap_t, wrap, axis=0)


def _farthest_near(curve, u: NDArray[np.float64], i: int, target: NDArray[np.float64],
                   closed: bool) -> float:
    """``u`` maximizing ``|curve(u) - target|`` within two samples of point ``i``."""
    n, period = len(u) - 1, u[-1]
    if closed:
        lo = u[i] - (u[i] - u[(i - 2) % n]) % period
        hi = u[i] + (u[(i + 2) % n] - u[i]) % period
    else:
        lo, hi = u[max(i - 2, 0)], u[min(i + 2, n)]
    grid = np.linspace(lo, hi, REFINE_SAMPLES)
    dist = np.linalg.norm(curve(np.mod(grid, period) if closed else grid) - target, axis=1)
    k = int(np.argmax(dist))
    best = grid[k]
    if 0 < k < REFINE_SAMPLES - 1:  # the parabola's vertex through the three samples
        d0, d1, d2 = dist[k - 1:k + 2]
        den = d0 - 2.0 * d1 + d2
        if den < 0.0:
            best += 0.5 * (d0 - d2) / den * (grid[1] - grid[0])
    return float(np.mod(best, period)) if closed else float(np.clip(best, u[0], u[-1]))


def _nearest_index(u: NDArray[np.float64], value: float) -> int:
    return int(np.argmin(np.abs(u[:-1] - value)) if len(u) > 1 else 0)


def _diameter(points: NDArray[np.float64], u: NDArray[np.float64], curve
              ) -> tuple[float, float]:
    """The ends ``(u_a, u_b)`` of the closed section's longest chord, refined."""
    ring = points[:-1]
    a = int(np.argmax(np.linalg.norm(ring - ring.mean(axis=0), axis=1)))
    b = a
    for _ in range(4):  # alternate farthest points: the diameter of a blade-like loop
        b_new = int(np.argmax(np.linalg.norm(ring - ring[a], axis=1)))
        a_new = int(np.argmax(np.linalg.norm(ring - ring[b_new], axis=1)))
        if (a_new, b_new) == (a, b):
            break
        a, b = a_new, b_new
    u_a, u_b = u[a], u[b]
    for _ in range(3):
        u_b = _farthest_near(curve, u, _nearest_index(u, u_b), curve(u_a), True)
        u_a = _farthest_near(curve, u, _nearest_index(u, u_a), curve(u_b), True)
    return float(u_a), float(u_b)


def _edge_width(curve, u_end: float, u_other: float, period: float) -> float:
    """Width (mm) of a closed section across its chord, :data:`EDGE_WIDTH_AT` in from an end."""
    end, other = curve(u_end), curve(u_other)
    axis = other - end
    chord = float(np.linalg.norm(axis))
    axis /= chord
    depth = EDGE_WIDTH_AT * chord
    crossings = []
    for direction in (1.0, -1.0):  # both sides, walking away from the end
        walk = np.mod(u_end + direction * np.linspace(0.0, (u_other - u_end) * direction
                                                      % period, DENSE_SAMPLES), period)
        x = (curve(walk) - end) @ axis
        k = int(np.argmax(x >= depth))
        if x[k] < depth or k == 0:
            return chord  # no crossing: no thin end here
        w = (depth - x[k - 1]) / (x[k] - x[k - 1])
        crossings.append(curve(walk[k - 1]) * (1.0 - w) + curve(walk[k]) * w)
    return float(np.linalg.norm(crossings[0] - crossings[1]))


def section_landmarks(sections: list[NDArray[np.float64]], closed: bool, params: str = "chord",
                      *, cumulative: list[NDArray[np.float64]] | None = None
                      ) -> list[SectionLandmarks] | None:
    """Leading and trailing edges of every section, by the rules of this module.

    ``sections`` are validated ``(n_j, 3)`` arrays; closed ones repeat their first point at
    the end. ``None`` when the sections are not blade-like: an open section with no point
    between its ends farther from their midpoint than they are (an arc, a ramp), or a closed
    one longer than :data:`MAX_PERIMETER_PER_CHORD` times its longest chord (a round tube):
    their own parameters from their first points are used then. ``cumulative``: the
    sections' :func:`toolpath.parametrize.cumulative_parameters`, if the caller has them.
    """
    us = cumulative if cumulative is not None else [cumulative_parameters(p, params)
                                                    for p in sections]
    curves = [_interpolant(u, p, closed) for u, p in zip(us, sections, strict=True)]
    if not closed:
        out = []
        for p, u, curve in zip(sections, us, curves, strict=True):
            middle = 0.5 * (p[0] + p[-1])
            far = np.linalg.norm(p - middle, axis=1)
            i = int(np.argmax(far))
            if not 0 < i < len(p) - 1 or far[i] <= max(far[0], far[-1]):
                return None  # no nose between the ends: not a blade section
            out.append(SectionLandmarks(_farthest_near(curve, u, i, middle, False), 0.0,
                                        float(u[-1])))
        return out
    ends = [_diameter(p, u, c) for p, u, c in zip(sections, us, curves, strict=True)]
    for (u_a, u_b), curve, u in zip(ends, curves, us, strict=True):
        if u[-1] > MAX_PERIMETER_PER_CHORD * np.linalg.norm(curve(u_a) - curve(u_b)):
            return None  # not elongated: no edges to find
    # follow end "a" from section to section (the nearer end of the next section)
    for j in range(1, len(ends)):
        a_prev, b_prev = (curves[j - 1](v) for v in ends[j - 1])
        a, b = (curves[j](v) for v in ends[j])
        if np.linalg.norm(a - a_prev) + np.linalg.norm(b - b_prev) > \
                np.linalg.norm(b - a_prev) + np.linalg.norm(a - b_prev):
            ends[j] = ends[j][::-1]
    log_ratio = 0.0  # > 0: end "a" is the wider one, the leading edge
    for (u_a, u_b), u, curve in zip(ends, us, curves, strict=True):
        wa, wb = (_edge_width(curve, x, y, u[-1]) for x, y in ((u_a, u_b), (u_b, u_a)))
        log_ratio += np.log(max(wa, _LEAST_WIDTH_MM) / max(wb, _LEAST_WIDTH_MM))
    return [SectionLandmarks(u_a, u_b, float(u[-1])) if log_ratio > 0.0
            else SectionLandmarks(u_b, u_a, float(u[-1]))
            for (u_a, u_b), u in zip(ends, us, strict=True)]


@dataclass(frozen=True)
class _MatchedSection:
    points: NDArray[np.float64]  # (k, 3): data, plus the seam point(s) when closed
    t: NDArray[np.float64]  # (k,) matched parameters, 0 to 1
    is_data: NDArray[np.bool_]  # (k,)
    curve: scipy.interpolate.Akima1DInterpolator  # in t (:func:`_entries`)


@dataclass(frozen=True)
class MatchedGrid:
    """Sections matched and put on one grid.

    Attributes
    ----------
    points : ndarray, shape (m, N, 3)
        Every section at every column (mm).
    t : ndarray, shape (N,)
        Column parameters, 0 to 1.
    mask : ndarray of bool, shape (m, N)
        True where the entry is a data point (else interpolated, or a closed seam point).
    t_le : float
        The common parameter of the leading edges.
    """

    points: NDArray[np.float64]
    t: NDArray[np.float64]
    mask: NDArray[np.bool_]
    t_le: float


def _matched(points: NDArray[np.float64], u: NDArray[np.float64], marks: SectionLandmarks,
             t_le: float, closed: bool) -> _MatchedSection:
    """One section's points (seam at its trailing edge when closed) and matched ``t``."""
    n = len(points)
    if closed:
        period = marks.length
        rel = np.mod(u[:-1] - marks.u_te, period)  # distance after the seam, [0, period)
        steps = np.diff(u)
        spacing = np.minimum(steps, np.roll(steps, 1))  # around each data point
        near = np.minimum(rel, period - rel) <= SNAP_FRACTION * spacing
        near &= np.minimum(rel, period - rel) <= np.min(np.minimum(rel, period - rel))
        order = np.argsort(rel)
        ring, rel = points[:-1][order], rel[order]
        if near.any():  # a data point is the trailing edge: it is the seam
            k = int(np.argmax(near[order]))
            ring, rel = np.roll(ring, -k, axis=0), np.mod(np.roll(rel, -k) - rel[k], period)
            rel[0] = 0.0
            is_data = np.r_[np.ones(len(ring), bool), False]  # the seam's copy at t = 1
            seam = ring[0]
        else:
            seam = _interpolant(u, points, True)(marks.u_te)
            ring, rel = np.vstack((seam, ring)), np.concatenate(([0.0], rel))
            is_data = np.r_[False, np.ones(n - 1, bool), False]
        pts = np.vstack((ring, seam))
        rel = np.append(rel, period)
        le = np.mod(marks.u_le - marks.u_te, period)
        t = np.interp(rel, [0.0, le, period], [0.0, t_le, 1.0])
    else:
        pts, is_data = points, np.ones(n, bool)
        t = np.interp(u, [0.0, marks.u_le, marks.length], [0.0, t_le, 1.0])
    t[0], t[-1] = 0.0, 1.0
    return _MatchedSection(pts, t, is_data, _entries(t, pts, closed))


def _vector_area(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """``1/2 sum (p_i - c) x (p_{i+1} - c)`` round the loop closed by its last step (mm^2)."""
    rel = points - points.mean(axis=0)
    return 0.5 * np.cross(rel, np.roll(rel, -1, axis=0)).sum(axis=0)


def _check_direction(sections: list[NDArray[np.float64]]) -> None:
    """Every section must run the same way round: its vector area along the previous one's.

    The vector area of a loop turns over when the loop is run backwards, whatever the
    sections' offsets and twist; loops of next to no area (straight sections) are not
    judged.
    """
    areas = [_vector_area(p) for p in sections]
    for j in range(1, len(sections)):
        a, b = areas[j - 1], areas[j]
        length = np.linalg.norm(np.diff(sections[j], axis=0), axis=1).sum()
        scale = FLAT_AREA_FRACTION * length**2
        if min(np.linalg.norm(a), np.linalg.norm(b)) > scale and float(a @ b) < 0.0:
            raise InvalidPointsError(
                f"section {j} runs the other way round the profile from section {j - 1}: "
                "give every section's points in the same direction (e.g. suction side "
                "first)", index=j)


def _correspond(sections: list[NDArray[np.float64]], us: list[NDArray[np.float64]],
                marks: list[SectionLandmarks], closed: bool) -> bool:
    """Whether point ``i`` is already at the same place on every section.

    Same point counts, and every leading edge (and a closed section's trailing edge, round
    the loop) within :data:`CORRESPOND_SPREAD` points (by fractional index) of the others:
    the points and the seams stay where they are.
    """
    if len({len(p) for p in sections}) != 1:
        return False
    index = np.arange(len(sections[0]), dtype=float)
    at_le = [np.interp(mk.u_le, u, index) for u, mk in zip(us, marks, strict=True)]
    if max(at_le) - min(at_le) > CORRESPOND_SPREAD:
        return False
    if closed:  # the trailing edges at one place too (round the loop): the seams stay
        ring = len(sections[0]) - 1
        at_te = np.array([np.interp(mk.u_te, u, index) for u, mk in zip(us, marks, strict=True)])
        off = np.mod(at_te - at_te[0] + 0.5 * ring, ring) - 0.5 * ring
        if np.ptp(off) > CORRESPOND_SPREAD:
            return False
    return True


def _seam_shift(us: list[NDArray[np.float64]], marks: list[SectionLandmarks]) -> int:
    """The data index every corresponding closed section's trailing edge is (0: none or the seam).

    Where each section's trailing edge lies on its point ``k`` (within
    :data:`SNAP_FRACTION` of the spacing there, the same ``k`` on every section), the
    sections are rolled so that ``k`` starts them: the seam then lies on the trailing edge,
    as on sections that do not correspond (:func:`_matched`). A sharp edge is a corner
    of the data, which the fit keeps only at the seam (C0 there,
    :func:`toolpath.knots.seam_multiplicity`) and the planner's passes meet only
    there: one point off the seam (the export running the other way round, or starting
    one point past the edge), the fit's knots at the corner and at the seam stood one
    point apart and the propeller's fit bent 0.05 mm round the hub's trailing edge (a
    ball cutter cut 0.24 mm into it); starting at the leading edge, the corner stood in
    the passes' way.
    """
    shift = None
    for u, mk in zip(us, marks, strict=True):
        steps = np.diff(u)
        rel = np.mod(u[:-1] - mk.u_te, mk.length)
        off = np.minimum(rel, mk.length - rel)  # round the loop
        k = int(np.argmin(off))
        spacing = min(steps[k], steps[k - 1])  # (k - 1 wraps round for k = 0)
        if off[k] > SNAP_FRACTION * spacing or shift not in (None, k):
            return 0
        shift = k
    return shift or 0


def _columns(matched: list[_MatchedSection]) -> NDArray[np.float64]:
    """The union of the sections' matched parameters, values equal to rounding once.

    Shared values are the ends, and the stations of sections sampled alike (the same
    relative stations from another start point: their matched parameters agree to within
    a few ulp, and two such columns would repeat every section's point).
    """
    t = np.unique(np.concatenate([sec.t for sec in matched]))
    t = t[np.r_[True, np.diff(t) > SAME_PARAMETER]]
    t[-1] = 1.0  # the last column's values end at the seam/end, 1
    return t


def _column_of(t_cols: NDArray[np.float64], values: NDArray[np.float64]) -> NDArray[np.int64]:
    """Index of the column nearest each of ``values`` (each one is a column, to rounding)."""
    at = np.clip(np.searchsorted(t_cols, values), 1, t_cols.size - 1)
    return np.where(np.abs(t_cols[at - 1] - values) <= np.abs(t_cols[at] - values), at - 1, at)


def match_sections(sections: list[NDArray[np.float64]], closed: bool, params: str = "chord"
                   ) -> MatchedGrid:
    """Match the sections (module docstring) and put them on one grid.

    ``sections``: validated ``(n_j, 3)`` arrays, hub to tip; closed ones repeat their
    first point at the end.

    Raises
    ------
    InvalidPointsError
        A section running the other way round from its neighbour.
    """
    _check_direction(sections)
    us = [cumulative_parameters(p, params) for p in sections]
    marks = section_landmarks(sections, closed, params, cumulative=us)
    blade_like = marks is not None
    if marks is None:  # each section's own parameter, from its first point
        marks = [SectionLandmarks(0.5 * u[-1], 0.0, float(u[-1])) for u in us]
    fractions = [np.mod(mk.u_le - mk.u_te, mk.length) / mk.length for mk in marks]
    t_le = float(np.mean(fractions))
    m = len(sections)
    if len({len(p) for p in sections}) == 1 and (
            not blade_like or _correspond(sections, us, marks, closed)):
        shift = _seam_shift(us, marks) if closed and blade_like else 0
        if shift:  # the seam onto the trailing edge's point, every section alike (each
            # loop the same, only started elsewhere: its edges' fractions, t_le, stay)
            sections = [np.vstack((np.roll(p[:-1], -shift, axis=0), p[shift])) for p in sections]
            us = [cumulative_parameters(p, params) for p in sections]
        # one column per point index, as given
        t = np.mean([u / u[-1] for u in us], axis=0)
        return MatchedGrid(np.stack(sections), t, np.ones((m, len(t)), bool), t_le)
    matched = [_matched(p, u, mk, t_le, closed)
               for p, u, mk in zip(sections, us, marks, strict=True)]
    t_cols = _columns(matched)
    grid = np.stack([sec.curve(t_cols) for sec in matched])
    mask = np.zeros((m, len(t_cols)), bool)
    for j, sec in enumerate(matched):
        at = _column_of(t_cols, sec.t)  # every value of sec.t is a column, to rounding
        grid[j, at] = sec.points
        mask[j, at] = sec.is_data
    return MatchedGrid(grid, t_cols, mask, t_le)
