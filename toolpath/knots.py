"""Knot placement for cubic curve fits: corners, density equidistribution, dominant points.

Three ideas, shared by the streamline and B-spline fitters so both can run on the same
knots:

- **Corners** (C0 points of the data) get a knot of multiplicity ``DEGREE`` at the corner's
  parameter, so the spline may turn there. A corner is a sample (or a pair of samples,
  when the true corner falls between them) whose turning angle stands far above its
  neighbours'. A corner between samples is placed at the intersection of the chords on
  either side.
- **Density** inside smooth pieces: for a cubic spline the local error on a span of length
  ``h`` is about ``c h^4 |f''''|``, so knots equidistributing ``|f''''|^{1/4}`` are
  asymptotically optimal (de Boor, *A Practical Guide to Splines*, ch. XII). The smooth
  pieces between corners share the knots by their mass ``∫ |f''''|^{1/4}``. The first
  density comes from the jumps of ``S'''`` of preliminary fits; later sweeps use the
  measured error per span, ``ρ_j = e_j^{1/4} / h_j`` (``e_j`` the span's RMS error).
- **Dominant points** (Park & Lee 2007, the paper's Algorithm 3): curvature maxima plus
  points added in the worst segment; knots are averages of ``DEGREE`` consecutive
  dominant-point parameters.

Every knot vector produced here satisfies the Schoenberg–Whitney condition: each span holds
data.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .scatter import point_wobble_mm, scatter_turn_rad
from .splinefit import (
    DEGREE,
    admissible_knots,
    clamped_knots,
    n_coefficients,
    schoenberg_whitney_violation,
)

__all__ = [
    "DEFAULT_CORNER_ANGLE_DEG",
    "Corner",
    "detect_corners",
    "dominant_point_knots",
    "equidistribute",
    "error_density",
    "fourth_derivative_density",
    "initial_dominant_points",
    "place_knots",
    "refill_knots",
    "refine_dominant_points",
    "seam_multiplicity",
    "turning_angles",
]

#: Turning angle (deg) from which a sharp turn may be a corner (Ex 5's corner is 20°).
DEFAULT_CORNER_ANGLE_DEG = 8.0

#: A turning angle this many times larger than the largest nearby turn marks a corner.
CORNER_CONTRAST = 4.0
#: A corner's neighbour continues its arc (a round nose sampled coarsely, not a corner) when
#: it turns, beyond its side's own turning, at least this fraction of what the arc would
#: make it turn (:func:`_continues_arc`; ~0 beside a corner, the same again on a circle,
#: less towards an ellipse's vertex, which ramps). An elliptic LE (vertex radius 0.1-0.3 mm,
#: axes 2.5-4 : 1) sampled 10-20 points round turns 6, 14, 55, 55, 14, 6 deg: 0.4-0.5 of
#: its arc; Ex 4's and Ex 5's corners' neighbours turn under 1/40 of theirs.
ARC_FRACTION = 0.25
#: A thin nose's turns ramp up towards its vertex along both sides (a 4:1 elliptic LE
#: sampled 6 points round turns 0, 3, 9, 78, 78, 9, 3, 0 deg); a corner's sides turn at
#: their own level up to it. Each side's ramp beside a corner candidate, held to at most
#: this ratio per sample (a steeper step is itself a jump), predicts the candidate's turn
#: (:func:`_follows_trend`).
RAMP_LIMIT = CORNER_CONTRAST
#: A candidate whose sides both ramp is a corner only when it turns this many times more
#: than their ramps predict. An elliptic nose's curvature climbs faster than geometrically
#: near its vertex, so the prediction falls short: by up to 4.1x on half ellipses of vertex
#: radius 0.05-0.3 mm, axes 1-4 : 1, 6-20 points round (8 points round a 4:1 ellipse turn
#: 2.3, 5.2, 9.7, 72.9 deg); twice that is the margin (``benchmarks/corner_sweep.py``).
TREND_CONTRAST = 2.0 * CORNER_CONTRAST
#: A corner turns at least this many times what the points' scatter may turn it
#: (:func:`_scatter_turns`): 3 um of scatter on a blade's clustered open end read as
#: corners of 13-26 deg at 1.1-1.3 times that, real ones turn tens of times more.
SCATTER_CONTRAST = 3.0
#: The share of what the scatter may turn a corner's neighbour that :func:`_continues_arc`
#: sets aside (its arc must show beyond it). ``benchmarks/corner_sweep.py --noise-um 3``
#: (the scatter set aside not at all / by this share): real corners missed 166 / 129 of
#: 405, wedges 20 / 12 of 162, noses read as corners 29 / 36 of 1728 (the whole of it:
#: 113, 8 and 48); without noise nothing changes.
SCATTER_SHARE = 0.5
#: Error sweeps take a span's ``e^{1/4}`` within this factor of the median span's (so its
#: length changes at most about this much relative to the others per sweep). Without it, on
#: the 71-point half profile at 20 control points, spans the fit interpolated were emptied
#: and the next sweep's error rose from 0.001 to 0.019 mm.
SWEEP_REACH = 3.0
#: A unit chord whose component across the turn's chord is shorter than this runs along it
#: (no doubling back to judge by): the next chord is tried.
_ALONG = 1e-6


@dataclass(frozen=True)
class Corner:
    """A C0 point of the data: parameter ``t`` (mm-free, in [0, 1]) and turning angle."""

    t: float
    angle_deg: float
    index: int  # the sample at or just before the corner


def turning_angles(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angle (rad) between consecutive chords at each interior sample, shape (n − 2,)."""
    chords = np.diff(points, axis=0)
    unit = chords / np.linalg.norm(chords, axis=1)[:, None]
    cosine = np.clip(np.einsum("ij,ij->i", unit[:-1], unit[1:]), -1.0, 1.0)
    return np.arccos(cosine)


def detect_corners(points: NDArray[np.float64], t: NDArray[np.float64], *,
                   min_angle_deg: float = 8.0) -> list[Corner]:
    """Find C0 corners in ordered points.

    A sample (or two adjacent samples whose turns add up, when the true corner lies
    between them) is a corner when its turn is at least ``min_angle_deg`` and at least
    ``CORNER_CONTRAST`` times the largest turn at the samples two to five steps away and
    at the samples just beside it (or beside the pair): a round nose sampled at steps near
    its radius turns most at one or two samples too, but its turns ramp up to them. Nor is
    it a corner where a neighbour continues its arc (:func:`_continues_arc`): the turning
    is concentrated in the sample(s), not spread the way the sampled arc would spread it;
    nor where the turns on both sides ramp up to it about as steeply as it stands above
    them (:func:`_follows_trend`): a thin elliptic nose sampled with few points, whose
    curvature climbs along both sides to its vertex.
    A closed loop (the last point equal to the first, as closed curves and sections are
    stored) is read round its seam: the samples beside the seam have neighbours on both
    sides (a corner *at* the seam is :func:`seam_multiplicity`'s).

    Measured points scatter about the true curve, and where they stand close together
    (an edge's clustered stations) the scatter alone turns them by degrees: 3 um of scatter
    turns samples 30 um apart at a blade's open end by up to 25 deg. What the scatter may
    turn each sample (:func:`_scatter_turns`) is left out of the evidence both ways: a
    candidate turning less than :data:`SCATTER_CONTRAST` times it is no corner, and a
    neighbour's turn shows an arc only beyond :data:`SCATTER_SHARE` of it (a trailing-edge
    wedge's neighbours, 0.17 mm apart, turned 10 deg by 3 um of scatter, read as its arc).
    Points without scatter (exact, synthetic) are judged as before.
    """
    turn = turning_angles(points)  # turn[i] is at sample i + 1
    n = turn.size
    if n < 5:
        return []
    ring = None  # closed: the turns round the loop, ring[n] at the seam
    if np.array_equal(points[0], points[-1]):
        ring = np.append(turn, turning_angles(points[[-2, 0, 1]]))
    chords = np.diff(points, axis=0)  # chord k: sample k to k + 1
    steps = np.linalg.norm(chords, axis=1)
    unit = chords / steps[:, None]  # closed: unit[n] then unit[0] round the seam
    corners: list[Corner] = []
    threshold = np.radians(min_angle_deg)
    scatter = _scatter_turns(points, steps, n if ring is None else n + 1)
    i = 0
    while i < n:
        pair = turn[i] + (turn[i + 1] if i + 1 < n else 0.0)
        if turn[i] < 0.25 * threshold or pair < threshold:
            i += 1
            continue
        if ring is None:
            around = np.concatenate((turn[max(0, i - 5):max(0, i - 1)], turn[i + 3:i + 7]))
        else:
            around = ring[np.r_[i - 5:i - 1, i + 3:i + 7] % ring.size]
        background = float(around.max()) if around.size else 0.0
        single = turn[i] >= threshold and turn[i] >= 0.85 * pair
        # the turns beside it: a round nose sampled coarsely ramps up to its largest turns
        # (propeller LE: 14, 25, 38, 32, 16 deg), a corner's sides do not
        beside = (ring[np.r_[i - 1, i + (1 if single else 2)] % ring.size] if ring is not None
                  else turn[[k for k in (i - 1, i + (1 if single else 2)) if 0 <= k < n]])
        background = max(background, float(beside.max()) if beside.size else 0.0)
        turns = turn if ring is None else ring
        if (_continues_arc(turns, steps, i, ring is not None, SCATTER_SHARE * scatter)
                or _follows_trend(turns, unit, i, single, ring is not None)):
            i += 1
            continue
        if (turn[i] if single else pair) < SCATTER_CONTRAST * (
                scatter[i] if single else scatter[i] + scatter[(i + 1) % scatter.size]):
            i += 1  # the points' scatter may turn it that much
            continue
        if single and turn[i] >= CORNER_CONTRAST * background:
            corners.append(Corner(float(t[i + 1]), float(np.degrees(turn[i])), i + 1))
            i += 3
            continue
        if not single and pair >= CORNER_CONTRAST * background and i + 1 < n:
            corners.append(Corner(_between(points, t, i + 1), float(np.degrees(pair)), i + 1))
            i += 4
            continue
        i += 1
    return corners


def _scatter_turns(points: NDArray[np.float64], steps: NDArray[np.float64], count: int
                   ) -> NDArray[np.float64]:
    """What the points' scatter may turn each of the first ``count`` samples (rad).

    (:func:`toolpath.scatter.scatter_turn_rad` of the points' wobble,
    :func:`toolpath.scatter.point_wobble_mm`, ~0 on exact points.)
    ``steps[k]`` runs from sample ``k`` to ``k + 1``; turn ``k`` sits between steps ``k``
    and ``k + 1`` (round the loop where ``count`` reaches the last).
    """
    k = np.arange(count)
    return scatter_turn_rad(point_wobble_mm(points, steps), steps[k % steps.size],
                            steps[(k + 1) % steps.size])


def seam_multiplicity(closed_points: NDArray[np.float64], corner_angle_deg: float | None
                      ) -> int:
    """``DEGREE`` when the data have a corner at the seam, else 1.

    ``closed_points`` ``(n + 1, d)`` end with the first point again. The polygon is rolled
    so the seam sits mid-way and :func:`detect_corners` judges it with the
    same rule as any other sample (turn and contrast with its neighbours); a corner found
    just beside the seam, between it and the next sample, is put on the seam.
    """
    if corner_angle_deg is None:
        return 1
    loop = np.asarray(closed_points[:-1], dtype=float)
    half = len(loop) // 2
    rolled = np.roll(loop, half, axis=0)
    t = np.linspace(0.0, 1.0, len(rolled))
    corners = detect_corners(rolled, t, min_angle_deg=corner_angle_deg)
    # a corner at the seam sample, or between it and a neighbour (the pair reading of two
    # sharp turns side by side, e.g. the two ends of a blunt base closed by ``--closed``)
    at_seam = any(c.index == half or (c.index == half - 1 and c.t > t[half - 1])
                  for c in corners)
    return DEGREE if at_seam else 1


def _continues_arc(turns: NDArray[np.float64], steps: NDArray[np.float64], i: int,
                   closed: bool, scatter: NDArray[np.float64] | None = None) -> bool:
    """Whether a neighbour of a corner at turn ``i`` continues its arc.

    ``turns[k]`` is the turn between chords ``steps[k]`` and ``steps[k + 1]``. A corner at or
    next to turn ``i`` turns ``Θ = turns[i] + turns[i + 1]`` (with ``i`` moved back one when
    the turn before is the larger neighbour; the second turn is the chord cutting across
    a corner between the samples, or the flank's own turn). Spread over an
    arc instead, from the middle of the chord ``a`` before ``i`` to the middle of the chord
    ``d`` after ``i + 1`` (``c`` between them), the neighbour across ``a`` turns about
    ``Θ (a/2) / (a/2 + c + d/2)`` more than the side's own turning (the least turn two to
    five samples out on that side); likewise across ``d``. A neighbour continues the arc
    when its excess, less what ``scatter[k]`` allows turn ``k`` (rad), reaches
    :data:`ARC_FRACTION` of that. ``closed``: indices wrap.
    """
    n = turns.size
    if (closed or i > 0) and turns[(i - 1) % n] > turns[(i + 1) % n]:
        i = (i - 1) % n if closed else i - 1  # the corner's other sample is before it
    if not closed and i + 1 >= n:
        return False
    total = turns[i] + turns[(i + 1) % n]
    a, c, d = (steps[k % steps.size] for k in (i, i + 1, i + 2))
    length = 0.5 * a + c + 0.5 * d
    if length <= 0.0:
        return False
    for beside, half, outward in ((i - 1, 0.5 * a, -1), (i + 2, 0.5 * d, 1)):
        far = [beside + outward * k for k in range(1, 5)]
        if not closed:
            if not 0 <= beside < n:
                continue
            far = [k for k in far if 0 <= k < n]
        own = float(turns[np.array(far) % n].min()) if far else 0.0
        allowed = 0.0 if scatter is None else float(scatter[beside % n])
        if turns[beside % n] - own - allowed >= ARC_FRACTION * total * half / length:
            return True
    return False


def _follows_trend(turns: NDArray[np.float64], unit: NDArray[np.float64], i: int,
                   single: bool, closed: bool) -> bool:
    """Whether a corner candidate's turn continues the ramp of the turns on both its sides.

    ``turns[k]`` is the angle between unit chords ``unit[k]`` and ``unit[k + 1]``; the
    candidate turns at ``i`` (``single``) or at ``i`` and ``i + 1``, from chord ``a`` to
    chord ``b``. On each side, turns are signed by the sense of rotation: positive when the
    bend ``unit[k + 1] − unit[k]`` has a positive component along ``J unit[k]``, ``J`` the
    quarter turn from ``a`` towards ``b`` in their plane (so in any dimension, and a flank
    bending away from the turn counts negative). They are measured above the side's level,
    the median turn three to six samples out: ``e₁`` beside the candidate, ``e₂`` next. A
    curvature rising along the side grows the turns about geometrically, so the candidate's
    end on that side should turn about ``e₁ q`` above the level, ``q = e₁ / e₂`` held to at
    most :data:`RAMP_LIMIT`. It follows the trend, a nose and no corner, when both sides
    ramp (``e₁ > 0`` and ``e₂`` above half the largest second difference of the turns from
    ``e₂`` outwards, so measurement noise on a flank makes no ramp) and on neither is its
    end's excess turn :data:`TREND_CONTRAST` or more times the prediction. A corner's sides
    turn at their own level up to it (``e₁ ≈ e₂ ≈ 0``). ``closed``: indices wrap round the
    loop.
    """
    n = turns.size
    last = i if single else i + 1
    if not closed and (i < 3 or last + 3 >= n):
        return False
    chords = unit.shape[0]
    across = unit[i % chords]
    for k in (last + 1, i + 1):  # the chord after the turn; the middle one if it doubles back
        quarter = unit[k % chords] - (unit[k % chords] @ across) * across
        if np.linalg.norm(quarter) > _ALONG:
            break
    else:
        return False
    quarter = quarter / np.linalg.norm(quarter)
    for end, outward in ((i, -1), (last, 1)):
        side = end + outward * np.arange(7)
        side = side % n if closed else side[(side >= 0) & (side < n)]
        before, after = unit[side % chords], unit[(side + 1) % chords]
        sense = (before @ across)[:, None] * quarter - (before @ quarter)[:, None] * across
        signed = turns[side] * np.sign(np.einsum("ij,ij->i", after - before, sense))
        level = float(np.median(signed[3:]))
        excess = signed[:3] - level  # the end, the sample beside it, the next one out
        scatter = 0.5 * float(np.abs(np.diff(signed[2:], 2)).max(initial=0.0))
        if excess[1] <= 0.0 or excess[2] <= scatter:
            return False
        ramp = min(excess[1] / excess[2], RAMP_LIMIT)
        if excess[0] >= TREND_CONTRAST * ramp * excess[1]:
            return False
    return True


def _between(points: NDArray[np.float64], t: NDArray[np.float64], j: int) -> float:
    """Parameter of the corner between samples j and j+1: where the side chords meet."""
    p0, p1 = points[j - 1], points[j]  # incoming chord
    q0, q1 = points[j + 1], points[j + 2] if j + 2 < len(points) else points[j + 1]
    u, v = p1 - p0, q1 - q0
    # closest points of the lines p1 + a u and q0 + b v (least squares for a, b)
    lhs = np.stack((u, -v), axis=1)
    (a, b), *_ = np.linalg.lstsq(lhs, q0 - p1, rcond=None)
    corner = 0.5 * (p1 + a * u + q0 + b * v)
    d0 = np.linalg.norm(corner - p1)
    d1 = np.linalg.norm(q0 - corner)
    frac = 0.5 if d0 + d1 == 0 else float(np.clip(d0 / (d0 + d1), 0.05, 0.95))
    return float(t[j] + frac * (t[j + 1] - t[j]))


def _mass(edges: NDArray[np.float64], density: NDArray[np.float64]) -> NDArray[np.float64]:
    """``∫ density`` from ``edges[0]`` to each edge (``density`` constant between edges)."""
    return np.concatenate(([0.0], np.cumsum(density * np.diff(edges))))


def equidistribute(edges: NDArray[np.float64], density: NDArray[np.float64],
                   count: int, lo: float | None = None, hi: float | None = None
                   ) -> NDArray[np.float64]:
    """Place ``count`` interior points in ``[lo, hi]`` so each slice holds equal ``∫ density``.

    ``density`` is piecewise constant on the cells between ``edges``; ``lo`` and ``hi``
    default to the first and last edge.
    """
    mass = _mass(edges, density)
    m_lo, m_hi = np.interp([edges[0] if lo is None else lo, edges[-1] if hi is None else hi],
                           edges, mass)
    targets = m_lo + (m_hi - m_lo) * np.arange(1, count + 1) / (count + 1)
    return np.interp(targets, mass, edges)


def _respect_data(knots: NDArray[np.float64], t: NDArray[np.float64], lo_index: int,
                  hi_index: int) -> NDArray[np.float64]:
    """Move (or drop) knots so every span in ``(t[lo], t[hi])`` holds a data parameter."""
    out: list[float] = []
    last = lo_index  # index of the last data point left of the previous knot
    for knot in np.sort(knots):
        j = int(np.searchsorted(t, knot, side="right")) - 1  # t[j] <= knot < t[j+1]
        j = max(j, last + 1)  # at least one data point since the previous knot
        if j >= hi_index - 1:  # no room: the span to the piece end would be empty
            break
        if not t[j] < knot < t[j + 1]:
            knot = 0.5 * (t[j] + t[j + 1])
        out.append(float(knot))
        last = j
    return np.asarray(out)


def _spans_per_piece(masses: NDArray[np.float64], total: int) -> NDArray[np.int64]:
    """Split ``total`` spans among pieces in proportion to their ``masses`` (at least one each).

    Each piece's share is rounded down, then spans go one at a time to the piece whose spans
    would otherwise carry the largest mass (so the per-span mass is as even as integers allow).
    """
    spans = np.ones(masses.size, dtype=np.int64)
    if total <= masses.size:
        return spans
    whole = masses.sum()
    if whole > 0:
        spans = np.maximum(np.floor(masses / whole * total).astype(np.int64), 1)
    while spans.sum() > total:  # the minimum of one span overdrew a thin piece
        cut = np.flatnonzero(spans > 1)
        spans[cut[np.argmin(masses[cut] / (spans[cut] - 1))]] -= 1
    while spans.sum() < total:
        spans[np.argmax(masses / spans)] += 1
    return spans


def place_knots(t: NDArray[np.float64], corners: list[Corner], edges: NDArray[np.float64],
                density: NDArray[np.float64], n_free: int) -> NDArray[np.float64]:
    """Clamped knot vector: corner knots (multiplicity ``DEGREE``) plus ``n_free`` knots.

    The smooth pieces between corners share the ``n_free + pieces`` spans in proportion to
    their mass ``∫ density`` (``density`` piecewise constant on ``edges``); inside each piece
    the knots equidistribute the density, so no span straddles a corner's knot and none is a
    sliver left beside it. Knots are moved (or dropped) so that every span holds data.
    """
    bounds = np.array([0.0] + [c.t for c in corners] + [1.0])
    at_bounds = np.interp(bounds, edges, _mass(edges, density))
    spans = _spans_per_piece(np.diff(at_bounds), max(n_free, 0) + bounds.size - 1)
    inner: list[float] = []
    for k, (lo, hi) in enumerate(itertools.pairwise(bounds)):
        lo_i = int(np.searchsorted(t, lo, side="left"))
        hi_i = int(np.searchsorted(t, hi, side="right")) - 1
        if t[lo_i] > lo:  # corner between samples: the piece starts at the sample before
            lo_i -= 1
        if t[hi_i] < hi:
            hi_i += 1
        mine = equidistribute(edges, density, spans[k] - 1, lo, hi)
        inner.extend(_respect_data(mine[(mine > lo) & (mine < hi)], t, lo_i, hi_i))
        if hi < 1.0:
            inner.extend([float(hi)] * DEGREE)
    asked = DEGREE + 1 + max(n_free, 0) + DEGREE * len(corners)
    return refill_knots(t, admissible_knots(t, clamped_knots(np.asarray(inner))), asked)


def refill_knots(t: NDArray[np.float64], knots: NDArray[np.float64], count: int
                 ) -> NDArray[np.float64]:
    """``knots`` with knots added back until they give ``count`` control points.

    Knots moved off empty spans or dropped for the Schoenberg-Whitney condition
    (:func:`admissible_knots`) leave fewer control points than asked; each one is given
    back in the span holding the most data parameters, between its middle two (the
    equidistributed density put fewer knots where the data are dense). Stops short when no
    span can take a knot without breaking the condition (too few data points).
    """
    while n_coefficients(knots) < count:
        edges = np.unique(knots)
        lo = np.searchsorted(t, edges[:-1], side="right")
        hi = np.searchsorted(t, edges[1:], side="left")
        k = int(np.argmax(hi - lo))
        if hi[k] - lo[k] < 2:
            break
        mid = (lo[k] + hi[k]) // 2
        grown = np.sort(np.append(knots, 0.5 * (t[mid - 1] + t[mid])))
        if schoenberg_whitney_violation(t, grown) is not None:
            break
        knots = grown
    return knots


#: Least density of :func:`fourth_derivative_density`, relative to its largest: a span whose
#: ``S'''`` does not jump (a straight or exactly cubic stretch) would get no knots at all.
_LEAST_DERIVATIVE_DENSITY = 1e-3
#: Least density of :func:`error_density`, relative to its least positive value: no span
#: is left at density 0 (equidistribution would give it no knots).
_LEAST_ERROR_DENSITY = 1e-2


def fourth_derivative_density(spline_knots: NDArray[np.float64],
                              coefficients: NDArray[np.float64]
                              ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Density ``|f''''|^{1/4}`` on the spans of a fitted cubic ``S``, from the jumps of ``S'''``.

    ``S'''`` is constant on each span, so ``f''''`` at an interior knot is estimated as the
    jump of ``S'''`` divided by the mean of the two adjacent span lengths (de Boor, *A
    Practical Guide to Splines*, ch. XII); a span takes the larger estimate of its two ends.
    A multiple knot (a corner) is a break in the data, not a sample of ``f''''``: its jump
    is left out, so the spans beside a corner are not crowded on its account.

    Returns
    -------
    edges, density : ndarray
        Span edges (distinct knots) and the density on each span.
    """
    import scipy.interpolate  # local: scipy stays a toolpath dependency only

    spline = scipy.interpolate.BSpline(spline_knots, coefficients, DEGREE)
    edges, multiplicity = np.unique(spline_knots, return_counts=True)
    mids = 0.5 * (edges[:-1] + edges[1:])
    third = spline(mids, nu=3)  # constant on each span; nu= copes with corner knots
    third = third.reshape(len(mids), -1)
    h = np.diff(edges)
    jump = np.linalg.norm(np.diff(third, axis=0), axis=1) / (0.5 * (h[:-1] + h[1:]))
    jump[multiplicity[1:-1] > 1] = 0.0
    at_span = np.zeros(len(mids))
    at_span[:-1] = jump
    at_span[1:] = np.maximum(at_span[1:], jump)
    density = np.power(at_span, 0.25)
    floor = _LEAST_DERIVATIVE_DENSITY * density.max() if density.max() > 0 else 1.0
    return edges, np.maximum(density, floor)


def error_density(knots: NDArray[np.float64], t: NDArray[np.float64],
                  errors: NDArray[np.float64]
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Density ``e_j^{1/4} / h_j`` from the root-mean-square error ``e_j`` in each span.

    On a span of length ``h_j`` a cubic's error is about ``c h_j^4 |f''''|``, so
    ``e_j^{1/4} / h_j`` estimates ``|f''''|^{1/4}`` there, measured rather than derived.
    The span's RMS is used, not its max: the max of a few samples jumps as knots move past
    the error's zeros, and equidistributing it makes the sweeps wander (Ex 4, B-spline, 44
    control points, least squares: max-driven sweeps wandered between 0.021 and 0.025 mm,
    RMS-driven ones settled at 0.017 mm). Each sample weighs by its share of the parameter
    line, so the many samples of a dense nose do not outvote the sparse flank beside it.
    ``e_j^{1/4}`` is held within ``SWEEP_REACH`` of its median over the spans, so a span the
    fit happens to interpolate (error 0) is not emptied in one sweep.
    """
    finite = np.isfinite(errors)
    if not finite.all():  # an overflowed fit: its worst spans count as the worst finite one
        errors = np.where(finite, errors, errors[finite].max() if finite.any() else 1.0)
    edges = np.unique(knots)
    span = np.clip(np.searchsorted(edges, t, side="right") - 1, 0, len(edges) - 2)
    cells = len(edges) - 1
    share = np.gradient(t)
    square = np.bincount(span, weights=share * np.square(errors), minlength=cells)
    held = np.bincount(span, weights=share, minlength=cells)
    rms = np.sqrt(square / np.where(held > 0, held, 1.0))
    root = np.power(rms, 0.25)
    if root.max() > 0:
        typical = np.median(root[root > 0])
        root = np.clip(root, typical / SWEEP_REACH, typical * SWEEP_REACH)
    density = root / np.diff(edges)
    positive = density[density > 0]
    floor = _LEAST_ERROR_DENSITY * positive.min() if positive.size else 1.0
    return edges, np.maximum(density, floor)


def _discrete_curvature(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Curvature (1/mm) at each sample from the circle through it and its neighbours."""
    a, b, c = points[:-2], points[1:-1], points[2:]
    ab, bc, ca = (np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1),
                  np.linalg.norm(a - c, axis=1))
    u, v = b - a, c - b
    # |u x v| in any dimension (Lagrange's identity), so stacked sections work too
    gram = (u * u).sum(axis=1) * (v * v).sum(axis=1) - (u * v).sum(axis=1) ** 2
    cross = np.sqrt(np.maximum(gram, 0.0))
    kappa = 2.0 * cross / (ab * bc * ca)
    return np.concatenate(([kappa[0]], kappa, [kappa[-1]]))


def initial_dominant_points(points: NDArray[np.float64], corners: list[Corner]
                            ) -> NDArray[np.int64]:
    """Park & Lee's initial dominant points: the ends, corners and curvature maxima.

    A curvature maximum counts when it exceeds the mean curvature (Liu et al. 2002 use the
    same contrast test to skip flat wiggles).
    """
    kappa = _discrete_curvature(points)
    interior = np.arange(1, len(points) - 1)
    peaks = interior[(kappa[1:-1] >= kappa[:-2]) & (kappa[1:-1] > kappa[2:])
                     & (kappa[1:-1] > kappa.mean())]
    chosen = set(peaks.tolist()) | {0, len(points) - 1} | {c.index for c in corners}
    return np.asarray(sorted(chosen), dtype=np.int64)


def refine_dominant_points(points: NDArray[np.float64], dominant: NDArray[np.int64],
                           errors: NDArray[np.float64]) -> NDArray[np.int64]:
    """Add one dominant point in the segment holding the largest error (Algorithm 3, step 5).

    The new point halves the segment's combined turning angle and arc length (not simply
    the point of largest error, which piles points up beside corners).
    """
    worst = int(np.argmax(errors))
    k = int(np.searchsorted(dominant, worst, side="right")) - 1
    k = min(max(k, 0), len(dominant) - 2)
    lo, hi = int(dominant[k]), int(dominant[k + 1])
    if hi - lo < 2:
        # the worst point is a dominant point: split the neighbouring segment that is wider
        return dominant
    seg = points[lo:hi + 1]
    length = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(seg, axis=0), axis=1))))
    turn = np.concatenate(([0.0], np.cumsum(turning_angles(seg)), [0.0]))
    turn[-1] = turn[-2]
    score = length / length[-1] + (turn / turn[-1] if turn[-1] > 0 else 0.0)
    mid = lo + int(np.argmin(np.abs(score - 0.5 * score[-1])))
    mid = min(max(mid, lo + 1), hi - 1)
    return np.asarray(sorted(set(dominant.tolist()) | {mid}), dtype=np.int64)


def dominant_point_knots(t: NDArray[np.float64], dominant: NDArray[np.int64],
                         corners: list[Corner] = ()) -> NDArray[np.float64]:
    """Knots from dominant points: averages of ``DEGREE`` consecutive interior parameters.

    With ``m + 1`` dominant points this gives ``m + 1`` control points (Park & Lee 2007).
    With ``corners``, each smooth piece between corners is averaged on its own and the
    corners get knots of multiplicity ``DEGREE``.
    """
    td = t[dominant].copy()
    at = {c.index: c.t for c in corners}
    for k, index in enumerate(dominant):
        if index in at:
            td[k] = at[index]
    cuts = [k for k, index in enumerate(dominant) if index in at]
    pieces = np.split(np.arange(td.size), cuts)
    inner: list[float] = []
    for p, piece in enumerate(pieces):
        ends = td[np.r_[piece, piece[-1] + 1] if p < len(pieces) - 1 else piece]
        n_inner = ends.size - (DEGREE + 1)
        inner.extend(ends[j:j + DEGREE].mean() for j in range(1, n_inner + 1))
        if p < len(pieces) - 1:
            inner.extend([float(td[piece[-1] + 1])] * DEGREE)
    return admissible_knots(t, clamped_knots(np.asarray(inner)))
