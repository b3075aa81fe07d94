"""Fairness of a fit between its data points: concave ripples and nose deviation.

A fit within tolerance *at* the data may still swing between them. Where a section's nose
is a small circle sampled 0.01-0.04 mm apart beside flanks sampled 1-8 mm apart, a ripple
makes the fit turn concave where every data point turns convex; a cutter cannot follow it.
Two measures, on samples at least 20x denser than the data (:data:`SAMPLES_PER_INTERVAL`
in every data interval, so the dense nose is resolved too):

**Concave stretches.** Signs are taken against a unit *outward* normal ``N`` perpendicular
to the tangent: for a curve, ``N = −σ (n × X') / |n × X'|`` with ``n`` the normal of the
data's best-fit plane and ``σ`` the sign of the data polygon's net turning about ``n``
(so the data's dominant turning is convex); for a surface, its outward unit normal (the
sections' turning then reads as normal curvature along ``t``, what a cutter sees). The
fit is *concave* at a sample where ``X'' · N > 0`` (it curves towards the outside); a data
point ``P_i`` is *convex* where ``(e_i − e_{i−1}) · N(t_i)`` over the mean chord is below
``−``:data:`FLAT_CURVATURE_PER_MM`, with ``e`` the unit chords (the discrete turning of
the data polygon). A concave stretch is a maximal run of concave samples between two
convex data points. Its **depth** is the material a cutter following the convex data
would leave: the section is unrolled into the plane keeping only its normal curvature
(:func:`_development`; a plane curve stays itself), and the depth is the distance from it
to the bridge of its outer convex hull spanning the stretch (the hull over the samples
within :data:`WINDOW_TURN_DEG` of turn either side, and at most
:data:`WINDOW_STRETCHES` stretch lengths). Depth is zero for a convex fit and about
``κ L^2 / 8`` for a dent of curvature ``κ`` and length ``L``.

**Nose deviation.** On each nose (a local peak of the data's turning whose circle through
three consecutive points, ``P_{i−1} P_i P_{i+1}``, is under
:data:`NOSE_MAX_LENGTH_FRACTION` of the section's length, with the points around it whose
circle is within :data:`NOSE_RADIUS_FACTOR` of the peak's), the dense samples between
consecutive nose points are compared with the two data circles at the interval's ends; the
deviation is the distance outside the band between them (:func:`_nose_error`). An
interval where the step spans more than :data:`NOSE_STEP_ARC_DEG` of either circle is
not resolved by its data and is not checked. Dense nose data define the nose circle to
well under a micrometre, so this is the fit's error between the data there.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .surface import outward_normals
from .tolerances import TINY
from .vectors import unit

__all__ = [
    "CONCAVE_DEPTH_MM",
    "CONCAVE_TURN_DEG",
    "SAMPLES_PER_INTERVAL",
    "ConcaveStretch",
    "Fairness",
    "curve_fair_check",
    "curve_fairness",
    "dense_parameters",
    "surface_fair_check",
    "surface_fairness",
]

#: Samples per data interval: "at least 20x denser than the data" in every interval.
SAMPLES_PER_INTERVAL = 24
#: Concave stretches shallower than this (mm) are below what a finish cut can leave.
CONCAVE_DEPTH_MM = 1e-3
#: Concave stretches that cannot be this deep (mm) are not measured at all.
NEGLIGIBLE_DEPTH_MM = 1e-6
#: Squared doubled area (mm^4) of three consecutive points below which they are collinear:
#: their circle has no centre (a straight run of data has no curvature to measure).
_STRAIGHT_AREA2_MM4 = 1e-30
#: A concave stretch whose normal turns back more than this (deg) counts however shallow
#: its dent: a ring after a curvature jump (a nose circle meeting its flank G1) that
#: overshoots the turn and comes back within a micrometre of the data still swings the
#: normal, and a ball placed along the normal at its start cuts into the flank beyond by
#: about ``R θ² / 4`` (measured: 0.0042 mm for R = 3 mm, θ = 4.2° at the DCA rotor's
#: TE): 1.5° keeps that within :data:`CONCAVE_DEPTH_MM` for balls up to 12 mm across.
CONCAVE_TURN_DEG = 1.5
#: Data turning less than this (1/mm: a radius above 1 m) is flat, neither convex nor
#: concave: there the sign of the turning is the blade's twist and the stream surface's
#: cone as much as the profile (a tip pressure flank: 1e-4/mm), and a fit within 10 um
#: of such data can bend either way over a flank.
FLAT_CURVATURE_PER_MM = 1e-3
#: The hull bridging a concave stretch is taken over the samples whose tangent turns at
#: most this much (deg) from the stretch's: wide enough to reach the bridge's tangent
#: points of any ripple, narrow enough that the window stays a graph over the tangent ...
WINDOW_TURN_DEG = 45.0
#: ... and over at most this many stretch lengths either side (a ripple's bridge rests
#: within a ripple's length or two of it; a flat flank would make the window the flank).
WINDOW_STRETCHES = 4
#: A nose: a turning peak whose data circle's radius is below this fraction of the
#: section's length (blade noses are 0.2-2 % of the contour; flanks 50 % and more).
NOSE_MAX_LENGTH_FRACTION = 0.05
#: The nose extends over the convex points whose circle is within this factor of the peak's.
NOSE_RADIUS_FACTOR = 4.0
#: A data circle models the curve between two points only where the step spans at most
#: this arc of it (deg): dense nose samples span 4-15°; three points of a 60-point ellipse
#: 23° apart on its 2.1 mm vertex circle miss the ellipse between them by 0.008 mm, and the
#: two corners of a blunt base closed by ``--closed`` span about 90° over the base.
NOSE_STEP_ARC_DEG = 20.0


@dataclass(frozen=True)
class ConcaveStretch:
    """A concave stretch of a fit where its data turn convex.

    Attributes
    ----------
    section : float
        Section index ``j`` of a surface (``j + 0.5`` midway between ``j`` and ``j + 1``);
        0 for a curve.
    t : float
        Parameter of the deepest point.
    depth_mm : float
        Distance (mm) of the deepest point inside the bridge of the outer hull.
    t_start, t_end : float
        Parameters where the fit's turning is concave.
    turn_deg : float
        How far the normal turns back over the stretch (deg, in the development).
    """

    section: float
    t: float
    depth_mm: float
    t_start: float
    t_end: float
    turn_deg: float = 0.0

    def counts(self, min_depth_mm: float) -> bool:
        """Deeper than ``min_depth_mm``, or turning back over :data:`CONCAVE_TURN_DEG`."""
        return self.depth_mm > min_depth_mm or self.turn_deg > CONCAVE_TURN_DEG

    def describe(self, surface: bool) -> str:
        """``0.0021 mm concave at t=0.4961`` (and the turn where that is what counts)."""
        text = f"{self.depth_mm:.4f} mm concave"
        if self.turn_deg > CONCAVE_TURN_DEG:
            text += f", the normal turning back {self.turn_deg:.1f} deg,"
        return text + " at " + _where(self.section if surface else None, self.t)


def _where(section: float | None, t: float) -> str:
    if section is None:
        return f"t={t:.4f}"
    return f"section {section:g} t={t:.4f}"


@dataclass(frozen=True)
class Fairness:
    """Fairness figures of one fit.

    Attributes
    ----------
    stretches : tuple of ConcaveStretch
        Concave stretches deeper than ``min_depth_mm`` where the data turn convex.
    deepest : ConcaveStretch or None
        The deepest concave stretch of any depth (None when the fit has none).
    nose_error_mm : float
        Largest distance (mm) of the dense samples on the noses from the data's nose circles.
    nose_section, nose_t : float or None
        Where that distance is largest.
    min_depth_mm : float
        Depth (mm) from which a concave stretch counts.
    surface : bool
        Whether sections are named (surface fits).
    nose_intervals : tuple of (section, deviation_mm, t, t_start, t_end)
        Every nose interval the fit leaves the data's nose circles in, with its deviation
        and where it is largest (what a fitter mends, one place at a time).
    """

    stretches: tuple[ConcaveStretch, ...]
    deepest: ConcaveStretch | None
    nose_error_mm: float
    nose_section: float | None
    nose_t: float | None
    min_depth_mm: float = CONCAVE_DEPTH_MM
    surface: bool = False
    nose_intervals: tuple[tuple[float, float, float, float, float], ...] = ()

    @property
    def n_concave(self) -> int:
        """Concave stretches deeper than ``min_depth_mm``."""
        return len(self.stretches)

    @property
    def deepest_mm(self) -> float:
        """Depth (mm) of the deepest concave stretch, 0 if none."""
        return 0.0 if self.deepest is None else self.deepest.depth_mm

    def line(self) -> str:
        """``0 concave stretches > 1 um (deepest 0.0000 mm)``, with where when any."""
        um = self.min_depth_mm * 1000.0
        text = (f"{self.n_concave} concave stretch{'es' if self.n_concave != 1 else ''} "
                f"> {um:g} um (deepest {self.deepest_mm:.4f} mm")
        if self.deepest is not None and self.deepest_mm > 0.0:
            text += " at " + _where(self.deepest.section if self.surface else None,
                                    self.deepest.t)
        return text + ")"

    def nose_line(self) -> str:
        """``0.0012 mm from the data's nose circles between points (section 3 t=0.48)``."""
        text = f"{self.nose_error_mm:.4f} mm from the data's nose circles between points"
        if self.nose_t is not None:
            text += " (" + _where(self.nose_section if self.surface else None,
                                  self.nose_t) + ")"
        return text

    def warnings(self, tol_mm: float) -> list[str]:
        """What a user must hear: concave stretches left, noses off by more than ``tol_mm``."""
        out = []
        if self.stretches:
            deepest = max(self.stretches, key=lambda s: s.depth_mm)
            out.append(f"unfair: {self.n_concave} concave stretch"
                       f"{'es' if self.n_concave != 1 else ''} deeper than "
                       f"{self.min_depth_mm * 1000:g} um (or turning back over "
                       f"{CONCAVE_TURN_DEG:g} deg) where the data turn convex, deepest "
                       + deepest.describe(self.surface)
                       + " (more knots did not remove it; a cutter following the fit "
                       "leaves that much there)")
        if self.nose_t is not None and self.nose_error_mm > tol_mm:
            out.append(f"nose: the fit leaves the data's nose circles by "
                       f"{self.nose_error_mm:.4f} mm between points at "
                       + _where(self.nose_section if self.surface else None, self.nose_t)
                       + f", above the tolerance {tol_mm:g} mm")
        return out

    def unfair(self, tol_mm: float | None = None) -> list[tuple[float, float, float, str]]:
        """What a fitter must mend: ``(t_start, t_end, size_mm, what)``.

        One entry per concave stretch, and one per nose interval where the fit leaves the
        nose circles by more than ``tol_mm`` (worst first).
        """
        out = [(s.t_start, s.t_end, s.depth_mm, s.describe(self.surface))
               for s in self.stretches]
        if tol_mm is not None:
            over = sorted((n for n in self.nose_intervals if n[1] > tol_mm),
                          key=lambda n: -n[1])
            out += [(lo, hi, error, f"{error:.4f} mm off the nose circles at "
                     + _where(section if self.surface else None, t))
                    for section, error, t, lo, hi in over]
        return out

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        def stretch(s: ConcaveStretch) -> dict[str, float]:
            return {"section": s.section, "t": s.t, "depth_mm": s.depth_mm,
                    "t_start": s.t_start, "t_end": s.t_end, "turn_deg": s.turn_deg}

        return {
            "summary": self.line(),
            "noses": self.nose_line(),
            "concave_stretches": self.n_concave,
            "min_depth_mm": self.min_depth_mm,
            "deepest_mm": self.deepest_mm,
            "deepest": None if self.deepest is None else stretch(self.deepest),
            "stretches": [stretch(s) for s in self.stretches],
            "nose_error_mm": self.nose_error_mm,
            "nose_where": (None if self.nose_t is None
                           else {"section": self.nose_section, "t": self.nose_t}),
        }


def dense_parameters(t: NDArray[np.float64], per_interval: int = SAMPLES_PER_INTERVAL
                     ) -> NDArray[np.float64]:
    """``per_interval`` evenly spaced parameters in every data interval, plus the last one."""
    t = np.asarray(t, dtype=float)
    frac = np.arange(per_interval) / per_interval
    inner = (t[:-1, None] + np.diff(t)[:, None] * frac[None, :]).ravel()
    return np.append(inner, t[-1])


def _chords(points: NDArray[np.float64], closed: bool
            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Unit chords before and after each data point, shape (n, 3) each.

    Open ends repeat their one chord (no turn); closed sections (last point = first) wrap.
    """
    e = unit(np.diff(points, axis=0))
    if closed:
        before = np.vstack((e[-1:], e))
        after = np.vstack((e, e[:1]))
    else:
        before = np.vstack((e[:1], e))
        after = np.vstack((e, e[-1:]))
    return before, after


def _convex_points(points, normals_at_data, closed) -> NDArray[np.bool_]:
    """Whether the data polygon turns convex (away from ``N``) at each point.

    The turn counts when its curvature, ``(e_i − e_{i−1}) · N`` over the mean of the two
    chords, is beyond :data:`FLAT_CURVATURE_PER_MM`. Open ends take their neighbour's
    verdict.
    """
    before, after = _chords(points, closed)
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    step_before = np.concatenate(([steps[-1] if closed else steps[0]], steps))
    step_after = np.concatenate((steps, [steps[0] if closed else steps[-1]]))
    curvature = np.einsum("ij,ij->i", after - before, normals_at_data) / (
        0.5 * (step_before + step_after))
    convex = curvature < -FLAT_CURVATURE_PER_MM
    if not closed and convex.size > 2:
        convex[0], convex[-1] = convex[1], convex[-2]
    return convex


def _dense_mask(per_point: NDArray[np.bool_], per_interval: int) -> NDArray[np.bool_]:
    """Dense samples (of :func:`dense_parameters`) between two convex data points."""
    both = per_point[:-1] & per_point[1:]
    return np.append(np.repeat(both, per_interval), per_point[-1])


def _runs(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """Inclusive ``(start, end)`` of the runs of True."""
    padded = np.concatenate(([False], mask, [False])).astype(np.int8)
    change = np.flatnonzero(np.diff(padded))
    return list(zip(change[::2], change[1::2] - 1, strict=True))


def _upper_hull(u: NDArray[np.float64], v: NDArray[np.float64]) -> list[int]:
    """Indices of the upper convex hull of points sorted by ``u``, left to right.

    Qhull for many points (its 2-D vertices run counter-clockwise, so the upper chain runs
    from the rightmost vertex to the leftmost); a monotone chain for few or degenerate ones.
    """
    if u.size > 32:
        import scipy.spatial  # local: scipy stays a toolpath dependency only

        try:
            ring = scipy.spatial.ConvexHull(np.c_[u, v]).vertices
        except scipy.spatial.QhullError:
            pass
        else:
            start, stop = int(np.argmax(u[ring])), int(np.argmin(u[ring]))
            chain = np.roll(ring, -start)[:(stop - start) % ring.size + 1]
            return [int(k) for k in chain[::-1]]
    hull: list[int] = []
    for k in range(u.size):
        while len(hull) >= 2:
            a, b = hull[-2], hull[-1]
            cross = (u[b] - u[a]) * (v[k] - v[a]) - (v[b] - v[a]) * (u[k] - u[a])
            if cross < 0.0:
                break
            hull.pop()
        hull.append(k)
    return hull


def _bridge_depth(x, tangents, m, a, b, lo_region, hi_region
                  ) -> tuple[float, int, int, int]:
    """Depth of the dent holding samples ``a..b`` of the developed curve ``x`` (2-D).

    ``x`` turns left where the fit is concave, so the outer hull lies on the left.
    Returns ``(depth (mm), deepest index, bridge start, bridge end)``.
    """
    t_m = tangents[m]
    n_m = np.array([-t_m[1], t_m[0]])
    cos_limit = np.cos(np.radians(WINDOW_TURN_DEG))
    reach = max(WINDOW_STRETCHES * (b - a + 1), 2 * SAMPLES_PER_INTERVAL)
    lo_region, hi_region = max(lo_region, a - reach), min(hi_region, b + reach)
    facing = tangents[lo_region:hi_region + 1] @ t_m >= cos_limit
    left = facing[:a - lo_region][::-1]
    lo = a - (int(np.argmin(left)) if not left.all() else left.size)
    right = facing[b - lo_region + 1:]
    hi = b + (int(np.argmin(right)) if not right.all() else right.size)
    window = x[lo:hi + 1] - x[m]
    u, v = window @ t_m, window @ n_m
    order = np.argsort(u, kind="stable")
    hull = np.sort(order[_upper_hull(u[order], v[order])])
    j = int(np.searchsorted(hull, m - lo))
    if j == 0 or j >= hull.size:
        return 0.0, m, lo, hi
    p, q = int(hull[j - 1]), int(hull[j])
    du, dv = u[q] - u[p], v[q] - v[p]
    length = np.hypot(du, dv)
    if length == 0.0:
        return 0.0, m, lo, hi
    inside = slice(p, q + 1)
    # distance below the bridge line p -> q, positive inside the hull
    depth = (du * (v[p] - v[inside]) - dv * (u[p] - u[inside])) / length
    k = int(np.argmax(depth))
    return max(float(depth[k]), 0.0), lo + p + k, lo + p, lo + q


def _development(tt, xt, xtt, normal) -> tuple[NDArray[np.float64], ...]:
    """The curve unrolled into the plane keeping only its normal curvature.

    With speed ``|X'|``, normal curvature ``k = X'' · N / |X'|^2`` (positive: concave) and
    arc length ``σ``, the plane curve of turning angle ``θ = ∫ k dσ`` is
    ``(∫ cos θ dσ, ∫ sin θ dσ)``: for a plane curve the curve itself (up to a motion),
    for a section in 3-D the profile a cutter moving along it meets.
    Returns the points (n, 2), unit tangents (n, 2), ``k`` (n,) and ``σ`` (n,).
    """
    speed = np.linalg.norm(xt, axis=1)
    kappa = np.einsum("ij,ij->i", xtt, normal) / np.maximum(speed, TINY) ** 2
    dt = np.diff(tt)
    dsigma = 0.5 * (speed[1:] + speed[:-1]) * dt
    theta = np.concatenate(([0.0], np.cumsum(0.5 * (kappa[1:] + kappa[:-1]) * dsigma)))
    tangents = np.stack((np.cos(theta), np.sin(theta)), axis=1)
    steps = 0.5 * (tangents[1:] + tangents[:-1]) * dsigma[:, None]
    sigma = np.concatenate(([0.0], np.cumsum(dsigma)))
    return np.vstack((np.zeros((1, 2)), np.cumsum(steps, axis=0))), tangents, kappa, sigma


def _concave_stretches(section: float, tt, xt, xtt, normal, convex_dense
                       ) -> list[ConcaveStretch]:
    """Every concave stretch (any depth) inside the runs of convex data.

    A fit that is not finite everywhere (an exponential beyond range) is one stretch of
    infinite depth where it first fails.
    """
    bad = ~(np.isfinite(xt).all(axis=1) & np.isfinite(xtt).all(axis=1)
            & np.isfinite(normal).all(axis=1))
    if bad.any():
        k = int(np.argmax(bad))
        return [ConcaveStretch(section, float(tt[k]), np.inf, float(tt[k]), float(tt[k]))]
    x, tangents, kappa, sigma = _development(tt, xt, xtt, normal)
    found: dict[tuple[int, int], ConcaveStretch] = {}
    for lo_region, hi_region in _runs(convex_dense):
        inside = kappa[lo_region:hi_region + 1] > 0.0
        for a, b in _runs(inside):
            a, b = a + lo_region, b + lo_region
            # a dent under a bridge of length L with concave curvature <= k is at most
            # k L^2 / 8 deep: skip the hull where even the widest window's bound is nil
            reach = max(WINDOW_STRETCHES * (b - a + 1), 2 * SAMPLES_PER_INTERVAL)
            span = sigma[min(b + reach, hi_region)] - sigma[max(a - reach, lo_region)]
            # the normal's turn back over the stretch (trapezoid rule on k dσ)
            turn_deg = float(np.degrees(np.sum(0.5 * (kappa[a + 1:b + 1] + kappa[a:b])
                                               * np.diff(sigma[a:b + 1]))))
            if kappa[a:b + 1].max() * span**2 / 8.0 < NEGLIGIBLE_DEPTH_MM \
                    and turn_deg <= CONCAVE_TURN_DEG:
                continue
            depth, deepest, p, q = _bridge_depth(x, tangents, (a + b) // 2, a, b,
                                                 lo_region, hi_region)
            key = (p, q)
            known = found.get(key)
            if known is None or known.depth_mm < depth:
                known = ConcaveStretch(section, float(tt[deepest]), depth, float(tt[a]),
                                       float(tt[b]), known.turn_deg if known else 0.0)
            found[key] = dataclasses.replace(known, turn_deg=max(known.turn_deg, turn_deg))
    return list(found.values())


def _circles(points: NDArray[np.float64], closed: bool
             ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Circle through each point and its neighbours: centres (n, 3), radii, plane normals.

    Radii are inf where the three points are collinear (and at open ends).
    """
    prev = np.roll(points, 1, axis=0)
    nxt = np.roll(points, -1, axis=0)
    if closed:  # the last point repeats the first
        prev[0], nxt[-1] = points[-2], points[1]
    a, b = prev - points, nxt - points
    axb = np.cross(a, b)
    area2 = np.einsum("ij,ij->i", axb, axb)
    ok = area2 > _STRAIGHT_AREA2_MM4
    safe = np.where(ok, area2, 1.0)
    offset = (np.cross(axb, a) * np.einsum("ij,ij->i", b, b)[:, None]
              + np.cross(b, axb) * np.einsum("ij,ij->i", a, a)[:, None]) / (2 * safe[:, None])
    radii = np.where(ok, np.linalg.norm(offset, axis=1), np.inf)
    if not closed:
        radii[0] = radii[-1] = np.inf
    return points + offset, radii, unit(axb) * ok[:, None]


def _nose_points(radii: NDArray[np.float64], convex: NDArray[np.bool_], length: float
                 ) -> NDArray[np.bool_]:
    """Data points on a nose: around each small-radius turning peak (see module doc)."""
    r = np.where(convex, radii, np.inf)
    nose = np.zeros(r.size, dtype=bool)
    for i in np.flatnonzero(r < NOSE_MAX_LENGTH_FRACTION * length):
        lo, hi = max(i - 1, 0), min(i + 1, r.size - 1)
        if r[i] > r[lo] or r[i] > r[hi] or nose[i]:
            continue  # not a peak of turning, or already on a nose
        within = r <= NOSE_RADIUS_FACTOR * r[i]
        j = i
        while j > 0 and within[j - 1]:
            j -= 1
        k = i
        while k < r.size - 1 and within[k + 1]:
            k += 1
        nose[j:k + 1] = True
    return nose


def _nose_error(points, convex, closed, tt, x, per_interval
                ) -> list[tuple[float, float, float, float]]:
    """Deviation of the dense samples from the data's nose circles, per nose interval.

    Between nose points ``i`` and ``i + 1`` the curve lies, as far as the data tell, in the
    band between their two circles: a curve whose curvature runs from one circle's to the
    other's keeps between them (exact for a circle, to first order for a curvature varying
    along the interval; the exact 60-point ellipse of a test fixture leaves the nearer
    circle by 0.0087 mm and the band by 0). A sample's radial deviation is 0 inside the
    band, else its distance to the nearer circle; out of the circles' planes its smaller
    height is added in quadrature. An interval is checked only where both circles model
    the curve (the step spans at most :data:`NOSE_STEP_ARC_DEG` of each): a nose whose
    steps are as long as its radius (a propeller's LE sampled 0.11 mm apart at radius
    0.11 mm) is not resolved by its data, and a circle beside it is no model of it.

    Returns ``(deviation_mm, t_worst, t_start, t_end)`` for every checked interval.
    """
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    length = float(steps.sum())
    centres, radii, axes = _circles(points, closed)
    nose = _nose_points(radii, convex, length)
    reach = 2.0 * np.sin(np.radians(0.5 * NOSE_STEP_ARC_DEG))
    i = np.flatnonzero(nose[:-1] & nose[1:])
    i = i[(steps[i] <= reach * radii[i]) & (steps[i] <= reach * radii[i + 1])]
    if i.size == 0:
        return []
    rows = i[:, None] * per_interval + np.arange(per_interval + 1)[None, :]
    samples = x[rows]  # (k, per_interval + 1, 3)
    radial, height = [], []
    for j in (i, i + 1):
        rel = samples - centres[j][:, None, :]
        h = np.einsum("kpd,kd->kp", rel, axes[j])
        planar = np.linalg.norm(rel - h[..., None] * axes[j][:, None, :], axis=2)
        radial.append(planar - radii[j][:, None])
        height.append(np.abs(h))
    between = np.sign(radial[0]) != np.sign(radial[1])
    off = np.where(between, 0.0, np.minimum(np.abs(radial[0]), np.abs(radial[1])))
    dist = np.hypot(off, np.minimum(*height))
    worst = np.argmax(dist, axis=1)
    at = np.arange(i.size)
    return [(float(d), float(tt[r]), float(tt[lo]), float(tt[hi]))
            for d, r, lo, hi in zip(dist[at, worst], rows[at, worst], rows[:, 0], rows[:, -1],
                                    strict=True)]


def _as_3d(points: NDArray[np.float64]) -> NDArray[np.float64]:
    points = np.asarray(points, dtype=float)
    if points.shape[1] == 3:
        return points
    return np.hstack((points, np.zeros((len(points), 3 - points.shape[1]))))


def _summary(stretches: list[ConcaveStretch],
             noses: list[tuple[float, float, float, float, float]], min_depth_mm: float,
             surface: bool) -> Fairness:
    """The figures, from the stretches and every checked nose interval.

    ``noses``: ``(section, deviation_mm, t, t_start, t_end)`` per interval.
    """
    deep = tuple(sorted((s for s in stretches if s.counts(min_depth_mm)),
                        key=lambda s: (s.section, s.t)))
    deepest = max(stretches, key=lambda s: s.depth_mm, default=None)
    worst = max(noses, key=lambda n: n[1], default=None)
    off = tuple(n for n in noses if n[1] > NEGLIGIBLE_DEPTH_MM)
    section, error_mm, t = (worst[0], worst[1], worst[2]) if worst else (None, 0.0, None)
    return Fairness(deep, deepest, error_mm, section, t, min_depth_mm, surface, off)


def _plane_normal(points: NDArray[np.float64]) -> NDArray[np.float64]:
    """Unit normal of the best-fit plane of ``points`` (the smallest principal axis)."""
    centred = points - points.mean(axis=0)
    return np.linalg.svd(centred, full_matrices=False)[2][-1]


def curve_fairness(curve: Any, points: Any, *, closed: bool = False,
                   min_depth_mm: float = CONCAVE_DEPTH_MM,
                   per_interval: int = SAMPLES_PER_INTERVAL) -> Fairness:
    """Concave stretches and nose deviation of a fitted curve (see the module doc).

    Parameters
    ----------
    curve
        A fitted curve with ``params``, ``__call__(t)`` and ``derivative(t, order)``.
    points : array_like, shape (n, 2) or (n, 3)
        The data it was fitted to (mm), in order, at ``curve.params``.
    closed : bool
        A closed curve: the turning wraps round the seam and the samples cover [0, 1]
        (``points`` may end with the first point again, at ``t = 1``, or not).
    min_depth_mm : float
        Depth (mm) from which a concave stretch counts.
    per_interval : int
        Dense samples per data interval (at least 20).
    """
    data = _as_3d(points)
    t = np.asarray(curve.params, dtype=float)
    if closed and t[-1] < 1.0:  # a closed fit's parameters stop short of the seam t = 1:
        t = np.append(t, 1.0)  # sample the last interval too, round to the first point
        if len(data) < t.size:
            data = np.vstack((data, data[:1]))
    tt = dense_parameters(t, per_interval)
    x, xt, xtt = (_as_3d(np.asarray(v).reshape(tt.size, -1))
                  for v in (curve(tt), curve.derivative(tt, 1), curve.derivative(tt, 2)))
    plane = _plane_normal(data) if data.shape[1] == 3 and np.ptp(data[:, 2]) > 0 \
        else np.array([0.0, 0.0, 1.0])
    before, after = _chords(data, closed)
    turn = np.arctan2(np.cross(before, after) @ plane, np.einsum("ij,ij->i", before, after))
    sense = -1.0 if turn.sum() < 0.0 else 1.0
    normal = -sense * unit(np.cross(plane, xt))
    normal_data = -sense * unit(np.cross(plane, before + after))
    convex = _convex_points(data, normal_data, closed)
    stretches = _concave_stretches(0.0, tt, xt, xtt, normal,
                                   _dense_mask(convex, per_interval))
    noses = [(0.0, *n) for n in _nose_error(data, convex, closed, tt, x, per_interval)]
    return _summary(stretches, noses, min_depth_mm, surface=False)


def surface_fairness(surface: Any, points: Any, *, min_depth_mm: float = CONCAVE_DEPTH_MM,
                     per_interval: int = SAMPLES_PER_INTERVAL) -> Fairness:
    """Concave stretches on every section ``s = s_j`` and midway, and nose deviation.

    Parameters
    ----------
    surface
        A fitted :class:`toolpath.surface.ParametricSurface` (``t_params``, ``s_params``,
        ``closed_t``; its batched partials and outward ``orientation``).
    points : array_like, shape (m, n, 3)
        Its sections (mm) on the grid of ``t_params`` (closed: last column = first).
    """
    data = np.asarray(points, dtype=float)
    t = np.asarray(surface.t_params, dtype=float)
    s = np.asarray(surface.s_params, dtype=float)
    closed = bool(surface.closed_t)
    tt = dense_parameters(t, per_interval)
    normals_at_data = surface.normal(t[None, :], s[:, None])  # (m, n, 3)
    convex = np.stack([_convex_points(data[j], normals_at_data[j], closed)
                       for j in range(len(s))])
    stretches: list[ConcaveStretch] = []
    noses: list[tuple[float, float, float, float, float]] = []
    levels = [(float(j), s[j], convex[j]) for j in range(len(s))]
    levels += [(j + 0.5, 0.5 * (s[j] + s[j + 1]), convex[j] & convex[j + 1])
               for j in range(len(s) - 1)]
    # one evaluation for every level (a compiled kernel's call costs more than its points)
    parts = surface.partials_many(
        np.tile(tt, len(levels)), np.repeat([s_value for _, s_value, _ in levels], tt.size),
        ((0, 0), (1, 0), (0, 1), (2, 0)))
    normal = outward_normals(surface, parts[1, 0], parts[0, 1])
    for k, (label, _, convex_here) in enumerate(levels):
        rows = slice(k * tt.size, (k + 1) * tt.size)
        stretches += _concave_stretches(label, tt, parts[1, 0][rows], parts[2, 0][rows],
                                        normal[rows], _dense_mask(convex_here, per_interval))
        if label == int(label):
            j = int(label)
            noses += [(label, *n) for n in _nose_error(data[j], convex[j], closed, tt,
                                                       parts[0, 0][rows], per_interval)]
    return _summary(stretches, noses, min_depth_mm, surface=True)


def curve_fair_check(make_curve: Any, points: Any, tol_mm: float, *, closed: bool = False):
    """``fair_check`` for :func:`toolpath.adaptive.adapt_knots` on a curve fit.

    ``make_curve(fit, knots)`` builds the curve from what the method's ``fit_at`` returns.
    Besides the concave stretches and the nose circles, a data interval where the fit is
    estimated beyond ``tol_mm`` between the points
    (:func:`toolpath.between_data.between_data_over`) is one to mend: a nose sampled as
    coarsely as its radius, which the circles do not check, or a flank 2.5 mm between
    points (the real-like propeller's LE: 0.0126 mm between points, within tol at them).
    Those are looked for once the fit is fair (the mend mends the unfair stretches first).
    """
    # (imported here: the CLI's --help reads this module, and between_data needs scipy)
    from .between_data import DataCurve, between_data_over

    data = np.asarray(points, dtype=float)
    made: dict[bytes, DataCurve] = {}  # the data curve, once per parametrization

    def check(fit: Any, knots: NDArray[np.float64]) -> list[tuple]:
        curve = make_curve(fit, knots)
        unfair = curve_fairness(curve, points, closed=closed).unfair(tol_mm)
        if unfair:
            return unfair
        t, ring = np.asarray(curve.params, dtype=float), data
        if closed and t[-1] < 1.0:  # round to the first point again (as curve_fairness)
            t = np.append(t, 1.0)
            if len(ring) < t.size:
                ring = np.vstack((data, data[:1]))
        key = t.tobytes()
        if key not in made:
            made[key] = DataCurve(t, ring, closed)
        return between_data_over(curve, t, ring, tol_mm, closed=closed, data=made[key])

    return check


def surface_fair_check(make_surface: Any, points: Any, tol_mm: float, *,
                       per_interval: int = SAMPLES_PER_INTERVAL, data_mask: Any = None):
    """``fair_check`` for a surface fit: ``make_surface(fit, knots)`` builds the surface.

    As :func:`curve_fair_check`, with every section's intervals off the data between its
    data points: ``data_mask`` (m, n) marks them on the grid (None: every entry is data).
    """
    from .between_data import DataCurve, between_data_over, on_section, section_data, worst_first

    data = np.asarray(points, dtype=float)
    # (t, section, data curve) per section, once per parametrization and closure
    made: dict[tuple[bytes, bool], list[tuple]] = {}

    def sections(surface: Any) -> list[tuple]:
        t = np.asarray(surface.t_params, dtype=float)
        closed = bool(surface.closed_t)
        key = (t.tobytes(), closed)
        if key not in made:
            made[key] = [(u, ring, DataCurve(u, ring, closed))
                         for u, ring in section_data(t, data, closed, data_mask)]
        return made[key]

    def check(fit: Any, knots: NDArray[np.float64]) -> list[tuple]:
        surface = make_surface(fit, knots)
        unfair = surface_fairness(surface, data, per_interval=per_interval).unfair(tol_mm)
        if unfair:
            return unfair
        closed = bool(surface.closed_t)
        off: list[tuple] = []
        for j, ((u, ring, curve), s_j) in enumerate(zip(sections(surface), surface.s_params,
                                                        strict=True)):
            off += [(lo, hi, mm, f"section {j}: {what}", kind) for lo, hi, mm, what, kind
                    in between_data_over(on_section(surface, s_j), u, ring, tol_mm,
                                         closed=closed, data=curve)]
        return worst_first(off)

    return check
