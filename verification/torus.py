r"""Where a line enters and leaves a flat or bull-nose cutter swept along a segment.

The cutter of :class:`toolpath.planning.cutters.Cutter` (radius ``R``, corner radius ``r``)
is the set of points within ``r`` of its *core*: the disc of radius ``rho0 = R - r`` at
height ``r`` above the tip, swept up the axis ``a`` by the core height ``L``. In the tool's
(radial, axial) half-plane the core is the rectangle ``[0, rho0] x [0, L]`` (``z`` measured
from the core's bottom centre ``C``), so the signed distance of a point ``Y = X - C`` to
the core is the closed-form 2-D distance to that rectangle
(:func:`core_signed_distance`), and the cutter is ``{X : sd_core(X - C) <= r}``: the flat
bottom out to ``rho0``, the torus tube of radius ``r``, the cylinder side. ``r = 0`` is a
flat end mill; ``rho0 = 0, L = 0`` a ball (the capsule kernel of :mod:`.capsule` is then
the same answer in closed form).

A piece is that cutter translated, axis fixed, from core centre ``C0`` to ``C0 + D``. Its
sweep ``S`` is convex (a convex solid plus a segment), and

.. math::

    \Phi(\lambda, w) = \mathrm{sd_{core}}(P + \lambda d - C_0 - w D) - r,
    \qquad F(\lambda) = \min_{w \in [0, 1]} \Phi(\lambda, w)

is jointly convex in ``(lam, w)``, so ``F`` (the signed distance of the dexel point
``P + lam d`` to the sweep, exact outside it) is convex in ``lam``, and the line meets
``S`` in the interval ``{F <= 0} = [lam_in, lam_out]``:

* **inner problem** (``w``): a chord across the axis (3-axis moves in the XY plane)
  changes only ``rho``, and ``sd`` grows with ``rho`` at a fixed ``z``: ``w`` is the
  projection of ``P + lam d - C0`` on ``D``, clipped to ``[0, 1]``. A chord along the
  axis changes only ``z``, and ``sd`` is even about the core's mid-height: ``w`` puts
  ``z`` there. Otherwise ``dPhi/dw = -grad(sd) . D`` is non-decreasing in ``w``; its
  root is bracketed between the ball's minimiser (the projection on ``D``) and an end,
  and found by the Illinois variant of false position. It stops when
  ``min(|Phi_w(lo)|, |Phi_w(hi)|) (hi - lo) <= 1e-9`` mm: by convexity the minimum is
  then known to 1e-9 mm;
* **outer problem** (``lam``): Newton's method on ``F`` from a lower bound (the entry into
  a bounding capsule and the slab the sweep spans along ``a``), with
  ``F'(lam) = grad(sd) . d`` at the inner minimiser (Danskin). On a convex function the
  tangent lies below the graph, so every iterate stays left of the first root and
  ``F > 0`` on everything skipped: the iteration is monotone, cannot overshoot, converges
  quadratically on a transversal entry (halving the gap at a tangency), and a line that
  misses shows ``F' >= 0`` with ``F > 0``. The exit is the same from the right.

Iteration stops at ``|F| <= CONVERGED_MM`` (1e-7 mm): the point returned lies within that
of the sweep's boundary.
"""

from __future__ import annotations

from typing import Final

import numpy as np
from numpy.typing import NDArray

from .capsule import line_capsule_interval

__all__ = ["CONVERGED_MM", "core_signed_distance", "line_sweep_interval", "sweep_distance",
           "sweep_entry_bound"]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

CONVERGED_MM: Final[float] = 1e-7
"""``|F|`` at which an entry or exit counts as found, mm (0.1 nm: far below the 0.5 um
replay tolerance, and reached in a few Newton steps)."""

_MAX_NEWTON: Final[int] = 40
"""Newton steps on ``lam`` (a tangent line halves its gap per step: 2^-40 of the span)."""

_MAX_INNER: Final[int] = 30
"""False-position steps on ``w`` (Illinois: superlinear; bracketed, so never worse)."""

_CLOSED_FORM: Final[float] = 1e-24
"""``(D.a)^2 / |D|^2`` (or the across part's) below which a chord counts as exactly across
(along) the axis: the inner minimiser is then in closed form."""


def _dot(u: FloatArray, v: FloatArray) -> FloatArray:
    return np.einsum("ij,ij->i", u, v)


def core_signed_distance(y: FloatArray, axis: FloatArray, height_mm: FloatArray,
                         core_radius_mm: float) -> tuple[FloatArray, FloatArray]:
    """Signed distance of points to the core cylinder and its gradient (< 0 inside).

    With ``z = y . a``, ``rho = |y - z a|``, ``dx = rho - rho0`` and
    ``dz = max(-z, z - L)``: outside, ``sqrt(max(dx, 0)^2 + max(dz, 0)^2)``; inside,
    ``max(dx, dz)``: the distance to the rectangle ``[0, rho0] x [0, L]`` of the (radial,
    axial) half-plane (the same solid as :meth:`Cutter.signed_distance
    <toolpath.planning.cutters.Cutter.signed_distance>` before its offset by ``r``).

    Parameters
    ----------
    y : ndarray, shape (m, 3)
        Points relative to the core's bottom centre, mm.
    axis : ndarray, shape (m, 3)
        Unit tool axes.
    height_mm : ndarray, shape (m,)
        Core heights ``L``, mm (>= 0).
    core_radius_mm : float
        ``rho0 = R - r``, mm.

    Returns
    -------
    sd : ndarray, shape (m,)
        Signed distance, mm.
    grad : ndarray, shape (m, 3)
        Its gradient (unit outside; a one-sided choice on the axis and the medial
        surfaces, where it has none).
    """
    z = _dot(y, axis)
    yp = y - z[:, None] * axis
    rho = np.sqrt(_dot(yp, yp))
    e_rho = yp / np.where(rho > 0.0, rho, 1.0)[:, None]
    dx = rho - core_radius_mm
    below = -z >= z - height_mm
    dz = np.where(below, -z, z - height_mm)
    s_z = np.where(below, -1.0, 1.0)
    ox, oz = np.maximum(dx, 0.0), np.maximum(dz, 0.0)
    h = np.hypot(ox, oz)
    out = h > 0.0
    inv = 1.0 / np.where(out, h, 1.0)
    cx = np.where(out, ox * inv, dx >= dz)
    cz = np.where(out, oz * inv, dx < dz) * s_z
    sd = np.where(out, h, np.maximum(dx, dz))
    return sd, cx[:, None] * e_rho + cz[:, None] * axis


class _Piece:
    """One row per (line, piece) pair: the arrays the kernel evaluates ``Phi`` with."""

    def __init__(self, core0: FloatArray, chord: FloatArray, axis: FloatArray,
                 height_mm: FloatArray, core_radius_mm: float, corner_radius_mm: float
                 ) -> None:
        self.core0, self.chord, self.axis, self.height = core0, chord, axis, height_mm
        self.rho0, self.r = core_radius_mm, corner_radius_mm

    def phi(self, x: FloatArray, w: FloatArray, rows: NDArray[np.int64]
            ) -> tuple[FloatArray, FloatArray]:
        """``Phi`` at points ``x`` and segment parameters ``w`` of pairs ``rows``; gradient."""
        y = x - self.core0[rows] - w[:, None] * self.chord[rows]
        sd, g = core_signed_distance(y, self.axis[rows], self.height[rows], self.rho0)
        return sd - self.r, g

    def inner_min(self, x: FloatArray, rows: NDArray[np.int64]
                  ) -> tuple[FloatArray, FloatArray]:
        """``F = min_w Phi`` at points ``x`` and the gradient of ``Phi`` at the minimiser.

        ``dPhi/dw = -grad . D`` is non-decreasing: an end where it does not change sign is
        the minimiser; otherwise Illinois false position on ``[0, 1]``.
        """
        chord, axis = self.chord[rows], self.axis[rows]
        # closed forms: a chord across the axis moves rho only (sd grows with rho at a
        # fixed z), one along the axis moves z only (sd is even about the mid-height)
        y0 = x - self.core0[rows]
        rise = _dot(chord, axis)
        across = chord - rise[:, None] * axis
        cc, aa = _dot(chord, chord), _dot(across, across)
        flat = rise * rise <= _CLOSED_FORM * cc
        upright = (aa <= _CLOSED_FORM * cc) & ~flat
        safe_cc = np.where(cc > 0.0, cc, 1.0)
        # the general case starts where a ball's minimiser would be: the projection on D
        w = _dot(y0, chord) / safe_cc
        w[flat] = _dot(y0[flat], across[flat]) / np.where(flat & (cc > 0.0), aa, 1.0)[flat]
        w[upright] = (_dot(y0[upright], axis[upright]) - 0.5 * self.height[rows[upright]]
                      ) / rise[upright]
        w = np.clip(w, 0.0, 1.0)
        best_f, best_g = self.phi(x, w, rows)
        slope = -_dot(best_g, chord)
        todo = np.flatnonzero(~(flat | upright) & (slope != 0.0))
        if todo.shape[0] == 0:
            return best_f, best_g
        # bracket: the guess and the end on the downhill side, unless that end is lower
        right = slope[todo] > 0.0
        end = np.where(right, 0.0, 1.0)
        f_end, g_end = self.phi(x[todo], end, rows[todo])
        s_end = -_dot(g_end, chord[todo])
        take = f_end < best_f[todo]
        best_f[todo] = np.where(take, f_end, best_f[todo])
        best_g[todo] = np.where(take[:, None], g_end, best_g[todo])
        inside = np.where(right, s_end < 0.0, s_end > 0.0)
        todo, right, s_end, end = todo[inside], right[inside], s_end[inside], end[inside]
        lo = np.where(right, end, w[todo])
        hi = np.where(right, w[todo], end)
        slo = np.where(right, s_end, slope[todo])
        shi = np.where(right, slope[todo], s_end)
        side = np.zeros(todo.shape[0], dtype=np.int64)
        t_lo, t_hi = slo.copy(), shi.copy()  # true slopes at the bracket's ends
        for _ in range(_MAX_INNER):
            # convexity: min Phi >= Phi(end) - |slope(end)| (hi - lo) at either end
            live = np.minimum(-t_lo, t_hi) * (hi - lo) > CONVERGED_MM * 0.01
            if not live.all():
                todo, lo, hi, slo, shi, side, t_lo, t_hi = (
                    v[live] for v in (todo, lo, hi, slo, shi, side, t_lo, t_hi))
                if todo.shape[0] == 0:
                    break
            w = np.clip((lo * shi - hi * slo) / (shi - slo), lo, hi)
            f, g = self.phi(x[todo], w, rows[todo])
            better = f < best_f[todo]
            best_f[todo] = np.where(better, f, best_f[todo])
            best_g[todo] = np.where(better[:, None], g, best_g[todo])
            sw = -_dot(g, chord[todo])
            go_left = sw > 0.0  # the root lies left of w
            # Illinois: halve the value kept at an end retained twice in a row
            shi = np.where(go_left, sw, np.where(side == -1, 0.5 * shi, shi))
            slo = np.where(go_left, np.where(side == 1, 0.5 * slo, slo), sw)
            t_hi = np.where(go_left, sw, t_hi)
            t_lo = np.where(go_left, t_lo, sw)
            hi = np.where(go_left, w, hi)
            lo = np.where(go_left, lo, w)
            side = np.where(go_left, 1, -1)
            done = sw == 0.0
            t_lo[done] = 0.0
        return best_f, best_g


def _newton(piece: _Piece, points: FloatArray, dirs: FloatArray, rows: NDArray[np.int64],
            start: FloatArray, stop: FloatArray, sign: float) -> FloatArray:
    """First root of ``F`` going from ``start`` towards ``stop`` (``sign`` +1: rightwards).

    Returns ``+inf * sign`` where the line misses the sweep within ``[start, stop]``.
    """
    lam = start.copy()
    out = np.full(rows.shape[0], sign * np.inf)
    todo = np.arange(rows.shape[0])
    for _ in range(_MAX_NEWTON):
        x = points[rows[todo]] + lam[todo, None] * dirs[rows[todo]]
        f, g = piece.inner_min(x, rows[todo])
        slope = sign * _dot(g, dirs[rows[todo]])  # dF along the walk
        hit = f <= CONVERGED_MM
        out[todo[hit]] = lam[todo[hit]]
        step = np.where(slope < 0.0, -f / np.where(slope < 0.0, slope, -1.0), np.inf)
        nxt = lam[todo] + sign * step
        live = ~hit & (slope < 0.0) & (sign * (nxt - stop[todo]) <= 0.0)
        lam[todo] = nxt
        todo = todo[live]
        if todo.shape[0] == 0:
            return out
    out[todo] = lam[todo]  # converging on a tangency: within 2^-40 of the span
    return out


def sweep_distance(points: FloatArray, core0: FloatArray, chord: FloatArray, axis: FloatArray,
                   height_mm: FloatArray, *, core_radius_mm: float, corner_radius_mm: float
                   ) -> FloatArray:
    """``F``: signed distance of points to the swept cutters, pairwise (exact outside), mm."""
    piece = _Piece(core0, chord, axis, height_mm, core_radius_mm, corner_radius_mm)
    f, _ = piece.inner_min(points, np.arange(points.shape[0]))
    return f


def line_sweep_interval(points: FloatArray, dirs: FloatArray, core0: FloatArray,
                        chord: FloatArray, axis: FloatArray, height_mm: FloatArray, *,
                        core_radius_mm: float, corner_radius_mm: float,
                        exit_wanted: BoolArray | None = None
                        ) -> tuple[FloatArray, FloatArray]:
    """Entry and exit of lines through swept flat/bull-nose cutters, pairwise.

    Parameters
    ----------
    points, dirs : ndarray, shape (m, 3)
        Line origins ``P`` (mm) and unit directions ``d``.
    core0 : ndarray, shape (m, 3)
        Core bottom centres ``C0 = tip + r a`` at the piece's start, mm.
    chord : ndarray, shape (m, 3)
        Translation ``D`` of the piece, mm.
    axis : ndarray, shape (m, 3)
        Unit tool axes (fixed along the piece).
    height_mm : ndarray, shape (m,)
        Core heights ``L``, mm: the piece is the cutter up to ``L + 2 r`` above its tip.
    core_radius_mm, corner_radius_mm : float
        ``rho0 = R - r`` and ``r``, mm.
    exit_wanted : ndarray of bool, optional
        Pairs whose exact exit is needed. Elsewhere the exit returned only tells whether
        the sweep reaches ``P``: ``+inf`` where it does (``lam_out > 0``), else the entry.

    Returns
    -------
    lam_in, lam_out : ndarray, shape (m,)
        Signed distances along ``d`` from ``P``, mm; ``+inf`` and ``-inf`` where the line
        misses.
    """
    m = points.shape[0]
    rho0, r = core_radius_mm, corner_radius_mm
    lam_in = np.full(m, np.inf)
    lam_out = np.full(m, -np.inf)
    lo, hi = sweep_entry_bound(points, dirs, core0, chord, axis, height_mm,
                               core_radius_mm=rho0, corner_radius_mm=r)
    cand = np.flatnonzero(np.isfinite(lo))
    if cand.shape[0] == 0:
        return lam_in, lam_out
    piece = _Piece(core0, chord, axis, height_mm, rho0, r)
    entry = _newton(piece, points, dirs, cand, lo[cand], hi[cand], 1.0)
    found = np.isfinite(entry)
    cand, entry = cand[found], entry[found]
    lam_in[cand] = entry
    below = entry < 0.0
    reach = np.ones(cand.shape[0], dtype=bool)
    if below.any():
        f0 = sweep_distance(points[cand[below]], core0[cand[below]], chord[cand[below]],
                            axis[cand[below]], height_mm[cand[below]], core_radius_mm=rho0,
                            corner_radius_mm=r)
        reach[below] = f0 <= 0.0
    lam_out[cand] = np.where(reach, np.inf, entry)
    if exit_wanted is not None:
        want = np.flatnonzero(exit_wanted[cand])
        if want.shape[0]:
            rows = cand[want]
            lam_out[rows] = _newton(piece, points, dirs, rows, hi[rows], entry[want], -1.0)
    return lam_in, lam_out


def sweep_entry_bound(points: FloatArray, dirs: FloatArray, core0: FloatArray,
                      chord: FloatArray, axis: FloatArray, height_mm: FloatArray, *,
                      core_radius_mm: float, corner_radius_mm: float
                      ) -> tuple[FloatArray, FloatArray]:
    """Bounds on where lines meet swept cutters: a bounding capsule cut by a slab.

    The sweep lies within ``sqrt(rho0^2 + (L/2)^2) + r`` of the path of the core's
    mid-height centre ``C0 + (L/2) a + w D``, and between the planes
    ``(X - C0) . a = min(0, D . a) - r`` (the tip's lowest position) and
    ``max(0, D . a) + L + r``: the line's interval through both contains ``[lam_in,
    lam_out]``.

    Parameters
    ----------
    points, dirs, core0, chord, axis, height_mm, core_radius_mm, corner_radius_mm
        As for :func:`line_sweep_interval`.

    Returns
    -------
    lo, hi : ndarray, shape (m,)
        ``lo <= lam_in`` and ``hi >= lam_out``, mm; ``+inf`` and ``-inf`` where the line
        misses the bounds.
    """
    half = 0.5 * height_mm
    bound = np.sqrt(core_radius_mm**2 + half * half) + corner_radius_mm
    lo, hi = _capsule(points, dirs, core0 + half[:, None] * axis, chord, bound)
    da = _dot(dirs, axis)
    z0 = _dot(points - core0, axis)
    rise = _dot(chord, axis)
    zlo = np.minimum(rise, 0.0) - corner_radius_mm
    zhi = np.maximum(rise, 0.0) + height_mm + corner_radius_mm
    along = np.abs(da) > 1e-12
    inv = 1.0 / np.where(along, da, 1.0)
    t1, t2 = (zlo - z0) * inv, (zhi - z0) * inv
    lo = np.where(along, np.maximum(lo, np.minimum(t1, t2)), lo)
    hi = np.where(along, np.minimum(hi, np.maximum(t1, t2)), hi)
    miss = (lo > hi) | (~along & ((z0 < zlo) | (z0 > zhi)))
    return np.where(miss, np.inf, lo), np.where(miss, -np.inf, hi)


def _capsule(points: FloatArray, dirs: FloatArray, a: FloatArray, e: FloatArray,
             radius_mm: FloatArray) -> tuple[FloatArray, FloatArray]:
    """:func:`line_capsule_interval` with a radius per pair (the pieces' bounds)."""
    scale = 1.0 / radius_mm
    lo, hi = line_capsule_interval(points * scale[:, None], dirs, a * scale[:, None],
                                   e * scale[:, None], _dot(e, e) * scale * scale, 1.0)
    return lo * radius_mm, hi * radius_mm
