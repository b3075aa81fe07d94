"""Arc fitting: replace runs of points in a plane by circular arcs within a tolerance.

Given the points of a polyline in a plane (2-D coordinates ``u, v``, mm), :func:`fit_arcs`
finds spans ``start .. end`` (point indices) that one circular arc from point ``start`` to
point ``end`` reproduces: every point of the span lies within ``tol_mm`` of the arc, in
order along it, and the arc stays within ``tol_mm`` of the polyline's segments too (the
sagitta of each segment is at most ``tol_mm``, so corners of a polygon that happen to lie
on a circle are not taken for an arc). The arc starts and ends exactly on the span's end
points, so arcs and the lines between them join without gaps.

For a span with end points ``a``, ``b`` the centre is on the perpendicular bisector of
``ab``, at the least-squares solution of ``|p - c|^2 = |a - c|^2`` over the inner points
(linear in the position along the bisector); the span is then *verified* with the true
distances ``| |p - c| - r |``, so the fit rule decides only which arcs are tried. Spans are
grown greedily from each start (exponential then binary search on the end), after a
vectorized test of every shortest window finds the starts worth trying.

Examples
--------
>>> import numpy as np
>>> t = np.linspace(0.0, np.pi / 2, 200)
>>> pts = np.column_stack([10 * np.cos(t), 10 * np.sin(t)])
>>> [(s.start, s.end, s.clockwise) for s in fit_arcs(pts, 0.001)]
[(0, 199, False)]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from gcode.post_defaults import DEFAULT_ARC_TOLERANCE_MM

__all__ = [
    "ARC_MAX_RADIUS_MM",
    "ARC_MAX_SWEEP_DEG",
    "ARC_MIN_POINTS",
    "DEFAULT_ARC_TOLERANCE_MM",
    "ArcSpan",
    "arc_deviation_mm",
    "fit_arcs",
]

#: Fewest points an arc replaces (3 line segments -> 1 arc block: the program shortens).
ARC_MIN_POINTS = 4
#: Larger radii stay lines (mm): nearly straight runs gain nothing from an arc, and huge
#: centre offsets lose relative precision at the written resolution.
ARC_MAX_RADIUS_MM = 5000.0
#: Largest sweep of one arc (degrees), well short of a full turn, where the end point
#: would no longer say which way round the arc goes.
ARC_MAX_SWEEP_DEG = 350.0

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class ArcSpan:
    """One fitted arc over the points ``start .. end`` (inclusive).

    Attributes
    ----------
    start, end : int
        Indices of the first and last point (``end - start + 1 >= ARC_MIN_POINTS``).
    centre : tuple of float
        Centre ``(u, v)``, mm.
    clockwise : bool
        True when the arc turns clockwise in the ``(u, v)`` frame (negative sweep).
    max_error_mm : float
        Largest distance of a span point from the arc, mm (``<= tol_mm``).
    """

    start: int
    end: int
    centre: tuple[float, float]
    clockwise: bool
    max_error_mm: float


def arc_deviation_mm(points: npt.ArrayLike, centre: npt.ArrayLike) -> float:
    """Largest distance of ``points`` from the circle about ``centre`` through the first point.

    Parameters
    ----------
    points : array_like, shape (m, 2)
        Points ``(u, v)``, mm; the first is the arc's start (it fixes the radius, as
        controllers take the radius of an IJK arc from its start point).
    centre : array_like, shape (2,)
        Centre ``(u, v)``, mm.

    Returns
    -------
    float
        ``max | |p - c| - |p_0 - c| |``, mm.
    """
    rel = np.asarray(points, dtype=np.float64) - np.asarray(centre, dtype=np.float64)
    r = np.hypot(rel[:, 0], rel[:, 1])
    return float(np.abs(r - r[0]).max())


def _windows_fit(
    w: FloatArray, tol_mm: float, max_radius_mm: float
) -> tuple[npt.NDArray[np.bool_], FloatArray, npt.NDArray[np.bool_], FloatArray]:
    """Fit and verify arcs on windows of points.

    Parameters
    ----------
    w : ndarray, shape (k, m, 2)
        ``k`` windows of ``m >= 3`` consecutive points.
    tol_mm : float
        Largest distance of a point from the arc, mm.
    max_radius_mm : float
        Largest accepted radius, mm.

    Returns
    -------
    (ok, centre, clockwise, error)
        Per window: the arc fits, its centre (k, 2), direction and max point error (mm).
    """
    a, b = w[:, 0], w[:, -1]
    mid = 0.5 * (a + b)
    chord = b - a
    half = 0.5 * np.hypot(chord[:, 0], chord[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        n = np.stack([-chord[:, 1], chord[:, 0]], axis=1) / (2.0 * half[:, None])
        d = w[:, 1:-1] - mid[:, None, :]
        big_a = (d * d).sum(axis=2) - (half * half)[:, None]
        big_b = 2.0 * (d * n[:, None, :]).sum(axis=2)
        t = (big_a * big_b).sum(axis=1) / (big_b * big_b).sum(axis=1)
        centre = mid + t[:, None] * n
        radius = np.hypot(half, t)
        r_all = np.hypot(w[..., 0] - centre[:, None, 0], w[..., 1] - centre[:, None, 1])
        error = np.abs(r_all - radius[:, None]).max(axis=1)
        rel = w - centre[:, None, :]
        cross = rel[:, :-1, 0] * rel[:, 1:, 1] - rel[:, :-1, 1] * rel[:, 1:, 0]
        dot = (rel[:, :-1] * rel[:, 1:]).sum(axis=2)
        step = np.arctan2(cross, dot)  # signed angle between consecutive points
    sweep = step.sum(axis=1)
    same_way = np.where(sweep[:, None] >= 0.0, step > 0.0, step < 0.0).all(axis=1)
    ok = (
        np.isfinite(error)
        & (half > 0.0)
        & (radius <= max_radius_mm)
        & (error <= tol_mm)
        & same_way
        & (radius * (1.0 - np.cos(0.5 * np.abs(step).max(axis=1))) <= tol_mm)
        & (np.abs(sweep) <= np.radians(ARC_MAX_SWEEP_DEG))
    )
    return ok, centre, sweep < 0.0, error


def _span(
    points: FloatArray, s: int, e: int, tol_mm: float, max_radius_mm: float
) -> ArcSpan | None:
    ok, centre, cw, err = _windows_fit(points[None, s : e + 1], tol_mm, max_radius_mm)
    if not ok[0]:
        return None
    return ArcSpan(s, e, (float(centre[0, 0]), float(centre[0, 1])), bool(cw[0]), float(err[0]))


def _grow(
    points: FloatArray, s: int, first: ArcSpan, tol_mm: float, max_radius_mm: float
) -> ArcSpan:
    """Longest span from ``s`` found by exponential then binary search on its end."""
    n = points.shape[0]
    best = first
    step = first.end - s
    hi = n  # smallest end known to fail (n: none known)
    while best.end < n - 1:
        e = min(n - 1, best.end + step)
        span = _span(points, s, e, tol_mm, max_radius_mm)
        if span is None:
            hi = e
            break
        best = span
        step *= 2
    while hi - best.end > 1:
        e = (best.end + hi) // 2
        span = _span(points, s, e, tol_mm, max_radius_mm)
        if span is None:
            hi = e
        else:
            best = span
    return best


def fit_arcs(
    points: npt.ArrayLike,
    tol_mm: float = DEFAULT_ARC_TOLERANCE_MM,
    *,
    min_points: int = ARC_MIN_POINTS,
    max_radius_mm: float = ARC_MAX_RADIUS_MM,
) -> list[ArcSpan]:
    """Find non-overlapping arcs through runs of consecutive points.

    Parameters
    ----------
    points : array_like, shape (n, 2)
        Points ``(u, v)`` of a polyline in a plane, mm, in path order.
    tol_mm : float
        Largest distance of any point of a span from its arc, mm (> 0).
    min_points : int
        Fewest points a span covers (>= 3).
    max_radius_mm : float
        Larger radii are left as lines, mm.

    Returns
    -------
    list of ArcSpan
        In path order; consecutive spans may share an end point (one's ``end`` is the
        next one's ``start``). Points outside every span stay line segments.

    Raises
    ------
    ValueError
        For a wrong shape, non-finite points, ``tol_mm <= 0`` or ``min_points < 3``.
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"points must have shape (n, 2), got {p.shape!r}")
    if not np.isfinite(p).all():
        bad = int(np.flatnonzero(~np.isfinite(p).all(axis=1))[0])
        raise ValueError(f"points[{bad}] is not finite: {p[bad].tolist()!r}")
    if not (np.isfinite(tol_mm) and tol_mm > 0.0):
        raise ValueError(f"tol_mm must be > 0 mm, got {tol_mm!r}")
    if min_points < 3:
        raise ValueError(f"min_points must be >= 3, got {min_points!r}")
    n = p.shape[0]
    if n < min_points:
        return []
    # every shortest window at once: only starts whose shortest window fits are grown
    idx = np.arange(n - min_points + 1)[:, None] + np.arange(min_points)
    ok, _, _, _ = _windows_fit(p[idx], tol_mm, max_radius_mm)
    starts = np.flatnonzero(ok)
    spans: list[ArcSpan] = []
    s_min = 0
    for s in starts.tolist():
        if s < s_min:
            continue
        first = _span(p, s, s + min_points - 1, tol_mm, max_radius_mm)
        if first is None:  # pragma: no cover - same test as the vectorized one
            continue
        span = _grow(p, s, first, tol_mm, max_radius_mm)
        spans.append(span)
        s_min = span.end
    return spans
