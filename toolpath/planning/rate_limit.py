"""The tool axis' turn rate limited within the lean cone (5-axis passes).

Round a leading edge tighter than the rate allows, the nominal axes (the normal, led and
tilted) turn too fast, and a moving average cannot help: averaged over both faces of a
thin blade the normals cancel. :func:`rate_limited_axes` treats each pass as a turn about
an axis ``B`` and limits the axis' azimuth about ``B`` inside a tube round the normal's
(the lean limit): the axis starts turning before the edge and finishes after it. Compiled
per pass (numba; one thread: a pass takes microseconds, and a parallel loop here cost
about 3 s of compiling on a cold start, issue 27). The parts of one pass's limit called
from one place each (:func:`_limit_pass`, :func:`_azimuth_tube`, :func:`_azimuth_path`,
:func:`_fit_tube`) are inlined by numba into :func:`_limit_passes`: a kernel compiled on
its own links in and optimizes again the machine code of everything it calls, so each
level of calls compiled the whole rate limit below it once more.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import NDArray

from ..tolerances import ANGLE_SLACK_DEG, LIMIT_SLACK, SAME_POINT_MM

__all__ = [
    "LEAST_RATE_SLACK",
    "RATE_MARGIN",
    "RATE_ROUNDS",
    "rate_limited_axes",
]

#: Rounds of :func:`rate_limited_axes` that tighten a pass's in-plane rate where the axis'
#: sideways turn (the frame's own twist) puts the true rate over the limit.
RATE_ROUNDS = 6
#: The in-plane rate aimed at, as a share of the limit (room for the sideways turn).
RATE_MARGIN = 0.98
#: The least rate that fits a tube is taken this much larger (relative), for the
#: round-off of the slews' sums.
LEAST_RATE_SLACK = 1e-12
#: Slack of the tube test (rad of azimuth): bounds that cross by less still hold a path
#: (round-off of the slews' sums); the least rate reads the bounds with the same slack.
TUBE_SLACK_RAD = 1e-12
#: Where the doubling search for a rate that fits the tube starts when the least rate is 0
#: (rad of azimuth per unit of the pass' abscissa): the least positive rate worth a trial.
FIRST_TRIAL_RATE = 1e-9

#: Floor of the cosines of the axis' and the normal's elevations (about the pole) in the
#: lean-cone half-width: at the pole (90 deg) the azimuth is undefined, and the floor (an
#: elevation of 89.94 deg) keeps the half-width finite (the ``acos`` argument is clipped).
_LEAST_POLAR_COS = 1e-3
#: The feed's component round the pole (``feed . (pole x n)``, of unit vectors) beyond
#: which the feed has a side, ahead being increasing azimuth if positive, and the lean
#: tube is narrowed to keep the nominal lead: a feed nearly along the meridian (within
#: about 17 deg of it, for a normal square to the pole) has no clear "ahead", and its
#: sign could flip from one point to the next.
LEAD_SIDE_LEAST_SHARE = 0.3
#: The azimuth's path (:func:`_azimuth_path`) keeps at least this share of the rate limit
#: where the elevation alone would turn at the limit: the axis can still turn round the
#: pole there (the in-plane rate is tightened afterwards, :data:`RATE_ROUNDS`), and the
#: path's abscissa keeps increasing.
LEAST_AZIMUTH_ROOM_SHARE = 0.1
#: Floor of the cosine of the elevation in the azimuth's path: near the pole a turn of the
#: azimuth moves the axis by ``cos(elevation)`` as much, and the floor (84 deg) keeps the
#: path's length finite.
LEAST_PATH_COS = 0.1


class _Passes(NamedTuple):
    """The passes' rows (``n`` of them) for the compiled rate limit.

    ``normals``, ``axes`` (wanted), ``feed``, ``nominal`` (the leads to keep, or the
    axes again), shape (n, 3); ``x``: arc length along the passes, mm.
    """

    normals: NDArray[np.float64]
    axes: NDArray[np.float64]
    feed: NDArray[np.float64]
    nominal: NDArray[np.float64]
    x: NDArray[np.float64]


class _RateRule(NamedTuple):
    """What the compiled rate limit works to.

    ``has_lead``: keep the leads ``nominal``; ``cos_lean``: cosine of the largest lean
    from the normal; ``rho``: the rate limit, rad per mm; ``rounds``, ``margin``:
    :data:`RATE_ROUNDS`, :data:`RATE_MARGIN`.
    """

    has_lead: bool
    cos_lean: float
    rho: float
    rounds: int
    margin: float


def rate_limited_axes(axes: NDArray[np.float64], normals: NDArray[np.float64],
                      feed_dirs: NDArray[np.float64], x_mm: NDArray[np.float64],
                      starts: NDArray[np.int64], *, max_rate_deg_per_mm: float,
                      max_lean_deg: float, nominal: NDArray[np.float64] | None = None
                      ) -> NDArray[np.float64]:
    """Axes turning at most ``max_rate_deg_per_mm``, within ``max_lean_deg`` of the normal.

    Along a pass the normals turn about an axis ``B`` (the span of a blade round its
    leading edge, the pole of a latitude circle; two candidates, :func:`_turn_axes`, the
    second tried where the first misses the rate, the slower result kept).
    About ``B`` a unit vector has an azimuth ``phi`` and an elevation ``beta``; the
    wanted axes (``axes``) keep their elevation and the azimuth is rate limited: the
    turn rate is ``sqrt(cos(beta)^2 phi'^2 + beta'^2)``, so each segment allows
    ``|phi'| <= sqrt(rho^2 - beta'^2) / cos(beta)``. The lean limit is a tube
    ``|phi - phi_n| <= h`` round the normal's azimuth, ``cos(h) = (cos(max_lean) -
    sin(beta) sin(beta_n)) / (cos(beta) cos(beta_n))``. Per pass (compiled,
    :func:`_rate_tube`) the tube is narrowed to what a path within the rate can reach
    (forward and backward sweeps), then ``phi`` follows the wanted azimuth as closely as
    the rate allows, slewing forward and backward, and the mean of the two is taken (both
    feasible, so their mean is). Round a leading edge the axis starts turning before the
    edge and finishes after it. Where no path meets the rate within the tube, the
    smallest rate that fits is used. The result is measured; a pass still over (its
    normals not quite on a circle) is done again with its rate lowered by the excess
    (:data:`RATE_ROUNDS`).

    Parameters
    ----------
    axes : ndarray, shape (n, 3)
        The wanted axes (smoothed nominal), passes contiguous from ``starts``.
    normals, feed_dirs : ndarray, shape (n, 3)
        Unit normals and feed directions.
    x_mm : ndarray, shape (n,)
        Increasing arc length along the passes (the rate's path), mm.
    starts : ndarray of int
        First row of each pass.
    nominal : ndarray, shape (n, 3), optional
        Leads to keep: the axis may lean further ahead of the normal than these, not
        less. A flat or bull-nose face must not cross the normal: where it stands square
        on a convex edge its contact jumps across the face, and lying flat on a concave
        stretch it gouges.
    """
    bounds = np.r_[starts, len(normals)].astype(np.int64)
    poles = _turn_axes(normals, starts)
    has_lead = nominal is not None
    out = np.empty_like(axes)
    rows = _Passes(*(np.ascontiguousarray(v, dtype=float) for v in (
        normals, axes, feed_dirs, nominal if has_lead else axes, x_mm)))
    rule = _RateRule(has_lead, math.cos(math.radians(max_lean_deg)),
                     math.radians(max_rate_deg_per_mm), RATE_ROUNDS, RATE_MARGIN)
    _limit_passes(rows, np.ascontiguousarray(poles, dtype=float), bounds, rule, out)
    return out


def _turn_axes(normals: NDArray[np.float64], starts: NDArray[np.int64]) -> NDArray[np.float64]:
    """Per pass, two candidates for the axis its normals turn about, shape (n_pass, 2, 3).

    The normal of the plane that fits their tips best (least eigenvector of their
    covariance: the pole of a latitude circle, whose normals keep their elevation), and
    the dominant direction of the segments' turn vectors ``c = n_i x n_(i+1)`` (largest
    eigenvector of the sum of ``c c^T``, signs irrelevant: the axis of a short bend
    between long flats, which the plane fit mistakes for the mean normal when the pass
    twists a little).
    """
    bounds = np.r_[starts, len(normals)]
    v = np.ascontiguousarray(normals)
    cov = np.empty((len(starts), 3, 3))
    turns = np.empty((len(starts), 3, 3))
    _pass_moments(v, bounds, cov, turns)
    poles = np.empty((len(starts), 2, 3))
    poles[:, 0] = np.linalg.eigh(cov)[1][:, :, 0]
    poles[:, 1] = np.linalg.eigh(turns)[1][:, :, 2]
    return poles


@numba.njit(cache=True)
def _pass_moments(v, bounds, cov, turns):
    """Per pass ``k`` (rows ``bounds[k]:bounds[k + 1]`` of ``v``): covariance and turn moments.

    ``cov[k]``: the covariance of the rows; ``turns[k]``: the sum of ``c c^T`` over
    ``c = v_i x v_(i+1)``. (One kernel for both: one compile on a cold start, issue 27.)
    """
    for k in range(bounds.size - 1):
        a, b = bounds[k], bounds[k + 1]
        m0 = m1 = m2 = 0.0
        for i in range(a, b):
            m0 += v[i, 0]
            m1 += v[i, 1]
            m2 += v[i, 2]
        mean = (m0 / (b - a), m1 / (b - a), m2 / (b - a))
        for c in range(3):
            for d in range(3):
                acc = 0.0
                for i in range(a, b):
                    acc += (v[i, c] - mean[c]) * (v[i, d] - mean[d])
                cov[k, c, d] = acc / (b - a)
                turns[k, c, d] = 0.0
        for i in range(a, b - 1):
            c0 = v[i, 1] * v[i + 1, 2] - v[i, 2] * v[i + 1, 1]
            c1 = v[i, 2] * v[i + 1, 0] - v[i, 0] * v[i + 1, 2]
            c2 = v[i, 0] * v[i + 1, 1] - v[i, 1] * v[i + 1, 0]
            cv = (c0, c1, c2)
            for c in range(3):
                for d in range(3):
                    turns[k, c, d] += cv[c] * cv[d]


@numba.njit(cache=True)
def _limit_passes(rows, poles, bounds, rule, out):
    """:func:`rate_limited_axes` on each pass ``bounds[k]:bounds[k + 1]``.

    ``poles[k]`` holds the pass's candidate turning axes: the next is tried while the
    rate is not met, and the pass keeps the slowest result.
    """
    limit_deg = math.degrees(rule.rho)
    for k in range(bounds.size - 1):
        a, b = bounds[k], bounds[k + 1]
        best = np.inf
        trial = np.empty((b - a, 3))
        for c in range(poles.shape[1]):
            rate = _limit_pass(rows, poles[k, c], a, b, rule, trial)
            if rate < best or best == np.inf:
                best = rate
                for i in range(b - a):  # (a loop: a slice copy here compiled for seconds)
                    for col in range(3):
                        out[a + i, col] = trial[i, col]
            if best <= limit_deg * (1.0 + LIMIT_SLACK):
                break


@numba.njit(cache=True, inline="always")
def _limit_pass(rows, pole, a, b, rule, out):
    """One pass (``rows`` ``a:b``) about one pole into ``out``; returns its largest rate.

    The tube the azimuth about the pole must keep to (:func:`_azimuth_tube`), the path
    along which it may turn at the rate (:func:`_azimuth_path`), then rounds of the tube
    fit (:func:`_fit_tube`) lowered by the excess until the axes meet the rate.
    """
    limit_deg = math.degrees(rule.rho)
    x = rows.x
    m = b - a
    # a basis (ex, ey) of the plane normal to the pole (tuples: no arrays to compile)
    ref = (1.0, 0.0, 0.0) if abs(pole[0]) < 0.9 else (0.0, 1.0, 0.0)
    ex = _cross(pole, ref)
    size = math.sqrt(ex[0] ** 2 + ex[1] ** 2 + ex[2] ** 2)
    ex = (ex[0] / size, ex[1] / size, ex[2] / size)
    ey = _cross(pole, ex)
    lo, hi, want, beta = _azimuth_tube(rows, pole, ex, ey, a, b, rule)
    x_phi = _azimuth_path(x, beta, a, rule.rho)
    scale = 1.0
    best = np.inf
    phi = np.empty(m)
    trial = np.empty((m, 3))
    for _ in range(rule.rounds):
        _fit_tube(x_phi, lo, hi, want, scale, phi)
        for j in range(m):
            cb, sb = math.cos(beta[j]), math.sin(beta[j])
            cp, sp = math.cos(phi[j]), math.sin(phi[j])
            for c in range(3):
                trial[j, c] = cb * (cp * ex[c] + sp * ey[c]) + sb * pole[c]
        worst = 0.0
        for j in range(1, m):
            worst = max(worst, segment_rate(trial, j - 1, x[a + j] - x[a + j - 1]))
        if worst < best or best == np.inf:
            best = worst
            for j in range(m):
                for c in range(3):
                    out[j, c] = trial[j, c]
        if worst <= limit_deg * (1.0 + LIMIT_SLACK) or not np.isfinite(worst):
            break  # met, or a segment of no length turns: lowering cannot help
        scale *= rule.margin * limit_deg / worst
    return best


@numba.njit(cache=True, inline="always")
def _azimuth_tube(rows, pole, ex, ey, a, b, rule):
    """Bounds ``lo``, ``hi`` of the azimuth about ``pole``, the wanted one, the elevation.

    Per row ``a:b`` (unwrapped along the pass): the lean limit's tube round the normal's
    azimuth, narrowed with ``rule.has_lead`` so the axis leans no less ahead of the
    normal than the nominal one; the wanted azimuth (the axis') clipped into it.
    """
    normals, axes, feed, nominal, _ = rows
    m = b - a
    phi_n = np.empty(m)
    lo = np.empty(m)
    hi = np.empty(m)
    want = np.empty(m)
    beta = np.empty(m)
    for j in range(m):
        i = a + j
        az_n, beta_n = _polar(normals[i], pole, ex, ey)
        if j == 0:
            phi_n[j] = az_n
        else:  # unwrapped along the pass
            phi_n[j] = phi_n[j - 1] + _wrap_pi(az_n - phi_n[j - 1])
        az_w, beta_w = _polar(axes[i], pole, ex, ey)
        beta[j] = beta_w
        c = ((rule.cos_lean - math.sin(beta_w) * math.sin(beta_n))
             / (max(math.cos(beta_w), _LEAST_POLAR_COS) * max(math.cos(beta_n), _LEAST_POLAR_COS)))
        half = math.acos(min(max(c, -1.0), 1.0))
        lo[j] = phi_n[j] - half
        hi[j] = phi_n[j] + half
        if rule.has_lead:
            az_l, _ = _polar(nominal[i], pole, ex, ey)
            lead = phi_n[j] + _wrap_pi(az_l - phi_n[j])
            # the way the feed runs round the pole: ahead is increasing azimuth if > 0
            side = _cross(pole, (normals[i, 0], normals[i, 1], normals[i, 2]))
            ahead = feed[i, 0] * side[0] + feed[i, 1] * side[1] + feed[i, 2] * side[2]
            if ahead > LEAD_SIDE_LEAST_SHARE:
                lo[j] = max(lo[j], min(lead, hi[j]))
            elif ahead < -LEAD_SIDE_LEAST_SHARE:
                hi[j] = min(hi[j], max(lead, lo[j]))
        want[j] = min(max(phi_n[j] + _wrap_pi(az_w - phi_n[j]), lo[j]), hi[j])
    return lo, hi, want, beta


@numba.njit(cache=True, inline="always")
def _azimuth_path(x, beta, a, rho):
    """A path along which the azimuth may turn 1 per unit at the rate limit ``rho``.

    Per segment of the pass (rows ``a`` on, arc length ``x``), the room the elevation's
    own turn leaves, over the cosine of the elevation.
    """
    m = beta.size
    x_phi = np.empty(m)
    x_phi[0] = 0.0
    for j in range(1, m):
        dx = x[a + j] - x[a + j - 1]
        slope = (beta[j] - beta[j - 1]) / max(dx, SAME_POINT_MM)
        room = math.sqrt(max(rho * rho - slope * slope, (LEAST_AZIMUTH_ROOM_SHARE * rho) ** 2))
        cos_mid = max(math.cos(0.5 * (beta[j] + beta[j - 1])), LEAST_PATH_COS)
        x_phi[j] = x_phi[j - 1] + dx * room / cos_mid
    return x_phi


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _cross(a, b):
    """``a x b`` of two 3-vectors (an array and a tuple), a tuple.

    (numba's ``np.cross`` is slow to compile, and a new array compiled numpy's array
    constructor.)
    """
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0])


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _polar(v, pole, ex, ey):
    """Azimuth and elevation of ``v`` about ``pole`` (rad)."""
    up = v[0] * pole[0] + v[1] * pole[1] + v[2] * pole[2]
    az = math.atan2(v[0] * ey[0] + v[1] * ey[1] + v[2] * ey[2],
                    v[0] * ex[0] + v[1] * ex[1] + v[2] * ex[2])
    return az, math.asin(min(max(up, -1.0), 1.0))


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _wrap_pi(angle):
    """``angle`` folded into [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def angle_deg_at(a, b, i, j):
    """The angle between unit rows ``a[i]`` and ``b[j]``, deg (``atan2(|a x b|, a . b)``).

    For kernels only: compiled without a Python wrapper (not in ``__all__``).
    """
    c0 = a[i, 1] * b[j, 2] - a[i, 2] * b[j, 1]
    c1 = a[i, 2] * b[j, 0] - a[i, 0] * b[j, 2]
    c2 = a[i, 0] * b[j, 1] - a[i, 1] * b[j, 0]
    dot = a[i, 0] * b[j, 0] + a[i, 1] * b[j, 1] + a[i, 2] * b[j, 2]
    return math.degrees(math.atan2(math.sqrt(c0 * c0 + c1 * c1 + c2 * c2), dot))


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def segment_rate(axes, i, length):
    """Turn of the axis from row ``i`` to ``i + 1`` per ``length``, deg/mm.

    A segment shorter than :data:`~toolpath.tolerances.SAME_POINT_MM` turning by more than
    :data:`~toolpath.tolerances.ANGLE_SLACK_DEG` turns at ``inf``.
    """
    turn = angle_deg_at(axes, axes, i, i + 1)
    if length > SAME_POINT_MM:
        return turn / length
    return np.inf if turn > ANGLE_SLACK_DEG else 0.0


@numba.njit(cache=True, inline="always")
def _fit_tube(x, lo, hi, want, rate, phi):
    """:func:`_rate_tube` on one pass, its ends pinned if the rate allows it.

    The ends keep the wanted axis where the rate allows it (as centred windows do: spiral
    rings join there), else they are free; where no path keeps the rate in the tube, the
    smallest rate that does is used (:func:`_least_rate`; bisected where it cannot tell).
    """
    # (np.bool_: a bare True / False is typed as a literal, one compiled _rate_tube each)
    pinned, free = np.bool_(True), np.bool_(False)
    if _rate_tube(x, lo, hi, want, rate, pinned, phi):
        return
    if _rate_tube(x, lo, hi, want, rate, free, phi):
        return
    need = _least_rate(x, lo, hi)
    if need < np.inf and _rate_tube(x, lo, hi, want, max(need * (1.0 + LEAST_RATE_SLACK), rate),
                                    free, phi):
        return
    # (x repeats, or round-off: bisect for it)
    low, high = rate, max(rate, FIRST_TRIAL_RATE)
    fits = False
    for _ in range(80):
        high *= 2.0
        if _rate_tube(x, lo, hi, want, high, free, phi):
            fits = True
            break
    if not fits:  # no rate fits (a segment of no length): the wanted axes, in the tube
        for i in range(x.size):
            phi[i] = min(max(want[i], lo[i]), hi[i])
        return
    for _ in range(40):
        mid = 0.5 * (low + high)
        if _rate_tube(x, lo, hi, want, mid, free, phi):
            high = mid
        else:
            low = mid
    _rate_tube(x, lo, hi, want, high, free, phi)


@numba.njit(cache=True)
def _least_rate(x, lo, hi):
    """The least rate at which a path fits the tube ``[lo, hi]`` (ends free).

    A path exists iff ``lo[k] - hi[j] <= rate |x[k] - x[j]|`` for every pair (what the
    slews of :func:`_rate_tube` propagate, with its :data:`TUBE_SLACK_RAD`): the largest of those
    slopes, each way (:func:`_max_slope`). ``inf`` where ``x`` does not increase (a
    segment of no length: the caller bisects).
    """
    for i in range(1, x.size):
        if not x[i] > x[i - 1]:
            return np.inf
    # (loops, not array expressions, which compiled numpy's ufunc machinery; reversed
    # copies: views of another layout would compile _max_slope again)
    n = x.size
    bottom, x_back, top_back = np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        bottom[i] = lo[i] - TUBE_SLACK_RAD
    forward = _max_slope(x, hi, bottom, 1.0)
    for i in range(n):
        x_back[i], top_back[i] = x[n - 1 - i], hi[n - 1 - i]
        bottom[i] = lo[n - 1 - i] - TUBE_SLACK_RAD
    backward = _max_slope(x_back, top_back, bottom, -1.0)
    return max(0.0, forward, backward)


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _max_slope(x, top, bottom, sense):
    """Largest ``(bottom[k] - top[j]) / (sense (x[k] - x[j]))`` over ``j`` before ``k``.

    ``sense * x`` increasing; ``-inf`` for fewer than two points. The ``(x, top)`` before
    ``k`` are kept as their lower convex hull; the slopes from its vertices to
    ``(x[k], bottom[k])`` rise, then fall: a binary search finds the tangent.
    """
    n = x.size
    hx = np.empty(n)
    hy = np.empty(n)
    h = 0
    best = -np.inf
    for k in range(n):
        xk, yk = sense * x[k], bottom[k]
        if h:
            a, b = 0, h - 1
            while a < b:
                m = (a + b) // 2
                if (yk - hy[m + 1]) * (xk - hx[m]) >= (yk - hy[m]) * (xk - hx[m + 1]):
                    a = m + 1
                else:
                    b = m
            best = max(best, (yk - hy[a]) / (xk - hx[a]))
        while h >= 2 and ((hx[h - 1] - hx[h - 2]) * (top[k] - hy[h - 2])
                          - (hy[h - 1] - hy[h - 2]) * (xk - hx[h - 2])) <= 0.0:
            h -= 1
        hx[h] = xk
        hy[h] = top[k]
        h += 1
    return best


@numba.njit(cache=True)
def _rate_tube(x, lo, hi, want, rate, pin_ends, phi):
    """One pass: ``phi`` in the tube ``[lo, hi]``, turning at most ``rate``; False if none.

    ``|phi[i] - phi[i-1]| <= rate (x[i] - x[i-1])``; ``phi`` follows ``want`` (the mean of
    a forward and a backward slew), equal to it at both ends with ``pin_ends``.
    """
    n = x.size
    low = lo.copy()
    high = hi.copy()
    if pin_ends:
        low[0] = high[0] = min(max(want[0], lo[0]), hi[0])
        low[n - 1] = high[n - 1] = min(max(want[n - 1], lo[n - 1]), hi[n - 1])
    for i in range(1, n):
        d = rate * (x[i] - x[i - 1])
        high[i] = min(high[i], high[i - 1] + d)
        low[i] = max(low[i], low[i - 1] - d)
    for i in range(n - 2, -1, -1):
        d = rate * (x[i + 1] - x[i])
        high[i] = min(high[i], high[i + 1] + d)
        low[i] = max(low[i], low[i + 1] - d)
    for i in range(n):
        if low[i] > high[i] + TUBE_SLACK_RAD:
            return False
    fwd = np.empty(n)
    fwd[0] = min(max(want[0], low[0]), high[0])
    for i in range(1, n):
        d = rate * (x[i] - x[i - 1])
        fwd[i] = min(max(want[i], max(low[i], fwd[i - 1] - d)), min(high[i], fwd[i - 1] + d))
    bwd = np.empty(n)
    bwd[n - 1] = min(max(want[n - 1], low[n - 1]), high[n - 1])
    for i in range(n - 2, -1, -1):
        d = rate * (x[i + 1] - x[i])
        bwd[i] = min(max(want[i], max(low[i], bwd[i + 1] - d)), min(high[i], bwd[i + 1] + d))
    for i in range(n):
        phi[i] = 0.5 * (fwd[i] + bwd[i])
    return True
