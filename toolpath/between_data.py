"""How far a fit may be from the section *between* its data points: an estimate.

A fit is measured at its data; between them, where flank points lie 1-8 mm apart, it may
swing away from the section it models. The section between the points is unknown; what
is known is the data, and a smooth section differs from the cubic interpolant of its
points by about Hall's bound, ``5/384 h_i^4 |f''''|`` on the interval of length ``h_i``
(:func:`toolpath.between_sections.interpolation_errors`, the same estimate across the
sections, here along ``t`` with ``f''''`` from the fourth divided differences of the
points, from the one or two windows of five with the interval in their middle). So on
every data interval

    ``e_i = max |X - D| + 5/384 h_i^4 |f''''|_i``  (mm),

with ``D`` the **data curve**, the not-a-knot cubic spline through the points over their
own chord length (periodic round a closed section), and ``|X - D|`` the distance from the
fit at seven places in the interval to ``D`` (its polyline nearby): by projection, as a
cutter sees it, and free of how the fit's parameter ``t`` runs (a surface's ``t`` is the
sections' common one). The data's corners (:func:`toolpath.knots.detect_corners`, a closed
loop read round its seam too) split ``D`` into smooth pieces: no cubic crosses a corner,
and an interval with the corner inside it (between its two samples) is not estimated (the
data cannot tell where the corner lies). Noses sampled densely are checked against their
circles as well (:mod:`toolpath.fairness`).

Measured against the truth (``tests/toolpath/test_between_data.py``; the dev blades'
generator ``benchmarks/make_real_like.py`` evaluated 20-40x denser at the same stations),
tol 0.01, each section's largest error between its points, estimate / truth:
propeller (7 sections, flanks 2.3 mm apart, LE circles 0.05-0.2 mm sampled 0.044-0.3 mm
apart) 1.02-2.34 for the streamline surface (blade: 0.0134 / 0.0093 mm), 0.98-1.91 for
single-section curve fits (true 0.0091-0.0126 mm); blunt rotor (9 sections, flanks 2.5 mm
apart) 0.83-1.19 for both methods (true 0.0008-0.0086 mm). The same ``|X - D|`` over the
fit's own ``t`` overstated the blunt rotor's by up to 22x (``D`` in the sections' common
parameter swings between sparse points).

The fitters use it as a criterion (:func:`between_data_over`, through the fair checks of
:mod:`toolpath.fairness`): an interval is mended where ``|X - D|`` exceeds ``tol`` less
Hall's term, or ``tol`` itself where Hall's term is over :data:`DATA_SHARE` of it (the data
cannot tell the section better there). With it the real-like blades' single-section fits
(both methods, every section) are within 0.0099 mm of the true section between the data
(``benchmarks/between_data_truth.py``; before: up to 0.0137 mm, 23 intervals over 0.01).
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import Any

import numpy as np
import scipy.interpolate
from numpy.typing import NDArray

from .between_sections import interpolation_errors
from .knots import detect_corners
from .parametrize import cumulative_parameters
from .tolerances import TINY

__all__ = ["BETWEEN_DATA", "BETWEEN_DATA_FRACTIONS", "DATA_SHARE", "DataCurve",
           "between_data_errors", "between_data_estimate", "between_data_over",
           "between_data_parts", "on_section", "section_data", "surface_between_data",
           "worst_first"]

#: Where in each data interval the fit is compared with the data curve.
BETWEEN_DATA_FRACTIONS = (0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875)
#: The kind that :func:`between_data_over` gives its intervals (their fifth entry).
BETWEEN_DATA = "between data"
#: The share of the tolerance the data's own uncertainty (Hall's term) may take in the
#: criterion of :func:`between_data_over`; where it is larger the data cannot tell the
#: section to the tolerance (a nose sampled as coarsely as its radius: 0.007-0.01 mm on the
#: real-like propeller's LE; a flank interval whose fourth differences reach into a dense
#: nose: up to 1 mm, a bound far above the truth there), and the fit is held to the data
#: curve alone.
DATA_SHARE = 0.5
#: Samples of the data curve per data interval (its polyline): a flank interval of 8 mm on
#: a 50 mm radius sags 0.16 mm, its 1/16 chords 0.6 um.
POLYLINE_SAMPLES = 16


def _corner_samples(points: NDArray[np.float64], t: NDArray[np.float64], closed: bool
                    ) -> list[tuple[int, bool]]:
    """``(index, between)`` of the data's corners.

    ``index`` is the sample at or just before each one, ``between`` whether it lies between
    that sample and the next. A closed loop (last point = first) is read as it is and
    rolled half-way round, so a corner at its seam counts too.
    """
    found = {c.index: bool(c.t > t[c.index]) for c in detect_corners(points, t)}
    if closed:
        m = len(points) - 1
        half = m // 2
        rolled_t = np.concatenate((t[half:m] - t[half], t[:half] + 1.0 - t[half]))
        rolled = np.roll(points[:-1], -half, axis=0)
        for c in detect_corners(np.vstack((rolled, rolled[:1])), np.append(rolled_t, 1.0)):
            found.setdefault((c.index + half) % m, bool(c.t > rolled_t[c.index]))
    return sorted(found.items())


def between_data_errors(fitted_at: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                        t: NDArray[np.float64], points: NDArray[np.float64], *,
                        closed: bool = False) -> NDArray[np.float64]:
    """Estimated largest error (mm) of the fit in each data interval (module docstring).

    The sum of the two parts of :func:`between_data_parts`; parameters as there, NaN where
    a corner lies inside an interval.
    """
    fit_mm, data_mm = between_data_parts(fitted_at, t, points, closed=closed)
    return fit_mm + data_mm


def between_data_parts(fitted_at: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                       t: NDArray[np.float64], points: NDArray[np.float64], *,
                       closed: bool = False, data: DataCurve | None = None
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The fit's largest distance from the data curve, and Hall's term, per data interval.

    Parameters
    ----------
    fitted_at : callable
        ``fitted_at(u)`` gives the fit's points ``(k, d)`` at parameters ``u`` in [0, 1].
    t : ndarray, shape (n,)
        The data's parameters, increasing; a closed section ends at ``t = 1`` with its first
        point again.
    points : ndarray, shape (n, d)
        The data points (mm).
    closed : bool
        Whether the section is a closed loop (then ``points[-1] == points[0]``).
    data : DataCurve, optional
        ``DataCurve(t, points, closed)`` made beforehand (a fitter compares many fits with
        the same data).

    Returns
    -------
    fit_mm, data_mm : ndarray, shape (n - 1,)
        Per interval ``i`` (``t_i`` to ``t_(i+1)``): ``max |X - D|`` there, and Hall's
        term, how far the data curve itself may be from the section whatever the fit (the
        data's uncertainty); both NaN where a corner lies inside the interval.
    """
    if data is None:
        data = DataCurve(t, points, closed)
    return data.distances(fitted_at), data.hall


class DataCurve:
    """The data curve ``D`` of one section, split at its corners, ready to compare fits.

    Per smooth piece: the fit's parameters there, the polyline of ``D`` near every data
    interval (:data:`POLYLINE_SAMPLES` chords each over the interval and its neighbours)
    and Hall's term per interval (module docstring). ``hall`` is NaN where a corner lies
    inside the interval.
    """

    def __init__(self, t: NDArray[np.float64], points: NDArray[np.float64], closed: bool):
        t = np.asarray(t, dtype=float)
        points = np.asarray(points, dtype=float)
        n = t.size
        self.hall = np.full(n - 1, np.nan)
        #: (u, intervals, a, ab, length2, wrap) per piece: ``u`` the fit's parameters of
        #: the piece's samples, ``a`` / ``ab`` the starts and vectors (k, w, d) of the
        #: chords of ``D`` near each interval
        self._pieces: list[tuple] = []
        corners = _corner_samples(points, t, closed)
        if closed and not corners:
            # periodic: the data curve round the loop, two samples either side for windows
            tau = cumulative_parameters(points)
            period = tau[-1]
            data_curve = scipy.interpolate.CubicSpline(tau, points, axis=0,
                                                       bc_type="periodic")
            ext_tau = np.concatenate((tau[-3:-1] - period, tau, tau[1:3] + period))
            ext_p = np.vstack((points[-3:-1], points, points[1:3]))
            hall = interpolation_errors(ext_tau, ext_p[:, None, :], centred=True)[2:-2, 0]
            self._add(t, tau, data_curve, hall, np.arange(n - 1), wrap=False)
            return
        # the samples round (closed: from a corner) split at the corners into smooth pieces
        if closed:
            start = corners[0][0]
            order = np.concatenate((np.arange(start, n - 1), np.arange(0, start + 1)))
            along = np.concatenate((t[start:n - 1], t[:start + 1] + 1.0))
        else:
            order, along = np.arange(n), t
        position = {int(k): p for p, k in enumerate(order[:-1])} if closed else None
        cuts = {0, len(order) - 1}
        skip = set()
        for index, between in corners:
            p = position[index] if position is not None else index
            if between:
                skip.add(p)
                cuts.update((p, p + 1))
            else:
                cuts.add(p)
        edges = sorted(c for c in cuts if 0 <= c < len(order))
        for lo, hi in itertools.pairwise(edges):
            if lo in skip and hi == lo + 1:
                continue
            u, values = along[lo:hi + 1], points[order[lo:hi + 1]]
            tau = cumulative_parameters(values)
            data_curve = (scipy.interpolate.CubicSpline(tau, values, axis=0) if u.size >= 4
                          else scipy.interpolate.make_interp_spline(tau, values, k=1))
            hall = interpolation_errors(tau, values[:, None, :], centred=True)[:, 0]
            intervals = order[lo:hi]  # interval order[k] -> order[k] + 1 (mod the loop)
            self._add(u, tau, data_curve, hall, intervals, wrap=closed)

    def _add(self, u, tau, data_curve, hall, intervals, *, wrap: bool) -> None:
        """One piece: intervals ``u_k .. u_(k+1)``, ``D`` near each over ``k - 1 .. k + 1``."""
        self.hall[intervals] = hall
        steps = np.arange(POLYLINE_SAMPLES) / POLYLINE_SAMPLES
        fine = np.append((tau[:-1, None] + np.diff(tau)[:, None] * steps[None, :]).ravel(),
                         tau[-1])
        polyline = data_curve(fine)
        k = np.arange(u.size - 1)
        lo = np.maximum(k - 1, 0) * POLYLINE_SAMPLES
        hi = np.minimum(k + 2, u.size - 1) * POLYLINE_SAMPLES  # the window's last vertex
        # each window's chords; a short one (at a piece's end) repeats its last chord
        chord = np.minimum(lo[:, None] + np.arange(3 * POLYLINE_SAMPLES)[None, :],
                           hi[:, None] - 1)
        a, ab = polyline[chord], polyline[chord + 1] - polyline[chord]
        length2 = np.maximum(np.einsum("kwd,kwd->kw", ab, ab), TINY)
        self._pieces.append((u, intervals, a, ab, length2, wrap))

    def distances(self, fitted_at: Callable[[NDArray[np.float64]], NDArray[np.float64]]
                  ) -> NDArray[np.float64]:
        """``max |X - D|`` (mm) at :data:`BETWEEN_DATA_FRACTIONS` of every interval.

        The fit is evaluated once, at every piece's samples; NaN where a corner lies
        inside the interval.
        """
        out = np.full(self.hall.size, np.nan)
        if not self._pieces:
            return out
        frac = np.asarray(BETWEEN_DATA_FRACTIONS)
        at = [(u[:-1, None] + np.diff(u)[:, None] * frac[None, :]).ravel()
              for u, *_ in self._pieces]
        wrapped = np.concatenate([np.mod(v, 1.0) if piece[5] else v
                                  for v, piece in zip(at, self._pieces, strict=True)])
        fitted = np.asarray(fitted_at(wrapped), dtype=float).reshape(wrapped.size, -1)
        start = 0
        for (u, intervals, a, ab, length2, _), v in zip(self._pieces, at, strict=True):
            query = fitted[start:start + v.size].reshape(u.size - 1, frac.size, -1)
            start += v.size
            rel = query[:, :, None, :] - a[:, None, :, :]  # (k, fractions, chords, d)
            w = np.clip(np.einsum("kqwd,kwd->kqw", rel, ab) / length2[:, None, :], 0.0, 1.0)
            gap = rel - w[..., None] * ab[:, None, :, :]
            out[intervals] = np.sqrt(np.einsum("kqwd,kqwd->kqw", gap, gap).min(axis=2)
                                     ).max(axis=1)
        return out


def between_data_over(fitted_at: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                      t: NDArray[np.float64], points: NDArray[np.float64], tol_mm: float, *,
                      closed: bool = False, data: DataCurve | None = None
                      ) -> list[tuple[float, float, float, str, str]]:
    """The data intervals where the fit is estimated beyond ``tol_mm``: what a fitter mends.

    With ``h`` Hall's term (:func:`between_data_parts`), an interval counts where
    ``|X - D| > tol - h`` if ``h <= DATA_SHARE tol``, else where ``|X - D| > tol``: the
    fit keeps within ``tol`` of the section as far as the data tell, and within ``tol``
    of the data curve where the data themselves cannot tell the section that well (no
    fit makes up for that; the estimate reported beside the fit still carries all of
    ``h``). Returns ``(t_i, t_(i+1), mm, what, BETWEEN_DATA)`` per interval, ``mm`` the
    estimate there, worst first (:func:`worst_first`). ``data``: as for
    :func:`between_data_parts`.
    """
    fit_mm, data_mm = between_data_parts(fitted_at, t, points, closed=closed, data=data)
    with np.errstate(invalid="ignore"):
        score = fit_mm + np.where(data_mm <= DATA_SHARE * tol_mm, data_mm, 0.0)
        over = np.flatnonzero(score > tol_mm)
    return worst_first([
        (float(t[i]), float(t[i + 1]), float(fit_mm[i] + data_mm[i]),
         f"{fit_mm[i] + data_mm[i]:.4f} mm from the data between points at "
         f"t={0.5 * (t[i] + t[i + 1]):.4f} (estimated, {data_mm[i]:.4f} mm of it the "
         "uncertainty of the data themselves there)", BETWEEN_DATA) for i in over])


def worst_first(intervals: list[tuple]) -> list[tuple]:
    """``(t_start, t_end, mm, what, kind)`` intervals by their estimate ``mm``, largest first.

    ``mm`` is the figure they report; ties keep their order. One order for a curve's
    intervals and a surface's (all its sections' together).
    """
    return sorted(intervals, key=lambda item: -item[2])


def between_data_estimate(fitted_at: Callable[[NDArray[np.float64]], NDArray[np.float64]],
                          t: NDArray[np.float64], points: NDArray[np.float64], *,
                          closed: bool = False) -> tuple[float, float | None]:
    """The estimated largest error between the data (mm) and the parameter where it is.

    ``(0.0, None)`` when no interval could be estimated (every one holds a corner).
    """
    errors = between_data_errors(fitted_at, t, points, closed=closed)
    if not np.isfinite(errors).any():
        return 0.0, None
    i = int(np.nanargmax(errors))
    return float(errors[i]), float(0.5 * (t[i] + t[i + 1]))


def section_data(t: NDArray[np.float64], points: NDArray[np.float64], closed: bool,
                 data_mask: Any = None) -> list[tuple[NDArray[np.float64],
                                                      NDArray[np.float64]]]:
    """Each section's data as the estimate takes it: ``(t_j, points_j)`` per section.

    ``t`` (n,) the sections' common parameters, ``points`` (m, n, d) the grid,
    ``data_mask`` (m, n) its data entries (None: every entry); a closed section ends at
    ``t = 1`` with its first point again.
    """
    t, points = np.asarray(t, dtype=float), np.asarray(points, dtype=float)
    mask = (np.ones(points.shape[:2], dtype=bool) if data_mask is None
            else np.asarray(data_mask, dtype=bool))
    out = []
    for ring, on in zip(points, mask, strict=True):
        u, ring = t[on], ring[on]
        if closed and not np.array_equal(ring[0], ring[-1]):
            u, ring = np.append(u, 1.0), np.vstack((ring, ring[:1]))
        out.append((u, ring))
    return out


def on_section(surface: Callable[..., NDArray[np.float64]], s: float
               ) -> Callable[[NDArray[np.float64]], NDArray[np.float64]]:
    """The section ``s`` of ``surface(t, s)`` as a curve: ``u -> surface(u, s)``."""
    return lambda u: surface(u, np.full(np.shape(u), s))


def surface_between_data(surface: Callable[..., NDArray[np.float64]], sections: Any
                         ) -> tuple[float, int | None, float | None]:
    """The estimate on every section of a surface fit: ``(mm, section, t)`` where largest.

    ``surface(t, s)`` gives points for arrays ``t, s``; ``sections`` is the
    :class:`toolpath.sections.Sections` grid fitted (each section's data entries only,
    :func:`section_data`).
    """
    worst: tuple[float, int | None, float | None] = (0.0, None, None)
    for j, (s_j, (t, points)) in enumerate(zip(
            sections.s, section_data(sections.t, sections.points, sections.closed,
                                     sections.data_mask), strict=True)):
        mm, where = between_data_estimate(on_section(surface, s_j), t, points,
                                          closed=sections.closed)
        if where is not None and mm > worst[0]:
            worst = (mm, j, where)
    return worst
