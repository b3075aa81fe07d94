r"""Runs of consecutive flat or bull-nose pieces, each held inside one dilated piece.

A flat or bull-nose piece holds its axis fixed, so where a 5-axis program turns the axis
the replay's chords are cut into pieces each turning it by what moves a cutter point by the
replay tolerance (:func:`~verification.pieces.cutter_pieces`): a micrometre or two of path
per piece, hundreds of thousands of pieces on a blade, and some sixteen thousand of them
within a dexel's search radius. Their cheap bound (a capsule cut by a slab,
:func:`~verification.torus.sweep_bound`) is loose across the passes (a bull-nose's flat
bottom puts every neighbouring pass at about the same slab height), so thousands of pieces
per dexel were measured exactly: the bull-nose 5-axis blade took over 28 CPU minutes.

A *run* is a stretch of consecutive pieces ``k = i..j`` (same core height, same kind)
held inside one reference piece dilated by ``delta``:

* the reference: axis ``A`` of the run's middle piece, core bottom centre moving along the
  segment from the first piece's start ``a_i`` to the last one's end ``a_j + e_j``;
* the cutter with axis ``a_k`` is the one with axis ``A`` turned by the smallest rotation
  taking ``A`` to ``a_k`` (a solid of revolution about its axis), which moves a point
  ``y`` from the core's bottom centre by at most ``|a_k - A| |y|``, and every cutter point
  lies within ``rho_k = hypot(R - r, L_k) + r`` of that centre: within ``|a_k - A| rho_k``
  of the reference cutter;
* piece ``k``'s core centre path lies within ``p_k`` of the reference segment, ``p_k`` the
  larger distance of its two ends from it (a point's distance from a segment is convex
  along another segment);

so piece ``k``'s sweep lies within ``delta = max_k (|a_k - A| rho_k + p_k)`` of the
reference sweep, that is inside the reference sweep with the corner radius ``r + delta``
(the set within ``r + delta`` of the swept core). A line's entry into that dilated sweep is
therefore a lower bound on its entry into every piece of the run, and on the material any
of them leaves (:func:`~verification.capsule_search.pair_value` is the entry or more).
:mod:`verification.sweep_search` measures that entry once per run and the run's pieces
only where it lies below the best value so far: the same minimum as piece by piece.

The entries are found by Newton steps from the left that stop within ``CONVERGED_MM`` of
the boundary (:mod:`verification.torus`); a piece's measured entry is a point within that
of its sweep, hence within ``delta + CONVERGED_MM`` of the reference one. The dilation
stored adds :data:`ENTRY_MARGIN_MM` for it, so the run's measured entry never exceeds a
piece's measured entry.

**The pieces' support planes.** The dilation is charged in every direction, and the
reference (one axis along the whole chord) itself stands up to ``delta`` off the pieces:
on a bull-nose 5-axis blade the runs a dexel opens enter 5 to 19 um after the reference
and 43 um after its dilated floor (median), so thousands of halves were measured per
dexel. Each piece's sweep, though, lies on one side of any plane: for a unit ``nu``, the
cutter with axis ``u`` has the support ``h(nu) = rho0 sqrt(1 - c^2) + L max(0, c) + r``
(``c = nu . u``: the core's bottom or top rim, then the corner radius), so every point
``X`` of piece ``k``'s sweep has ``nu . X <= nu . a_k + max(0, nu . e_k) + h_k(nu)``,
and a dexel with ``nu . d < 0`` enters it no sooner than

.. math::

    \lambda_k(\nu) = \frac{\nu \cdot (P - a_k) - \max(0, \nu \cdot e_k) - h_k(\nu)
                      - m}{-\nu \cdot d}

(``m`` = :data:`ENTRY_MARGIN_MM`: a measured entry is a point within ``CONVERGED_MM`` of
the sweep; the numerator's rounding, some 1e-12 mm, stays far inside it whatever
``nu . d``). It holds for every ``nu``; it is tight (equal to the piece's entry, but for
the margin) where the piece is entered at a point whose outward normal is ``nu``. The
normal of the dilated reference where the dexel enters it is close to that of every piece
inside (they lie within ``delta`` of it): :func:`run_floor` takes the largest of the
dilated floor and ``min_k lambda_k`` over the run's (or half's) pieces, a pass over them
without a Newton step. On the bull-nose blade's prefix that least plane stands a median
0.9 um below the least entry of the pieces (:func:`support_floor`).

**Blocks of support planes.** That pass is over every piece of a run or half, for every
floor a dexel measures: on the bull-nose blade's fine model (runs of thousands of pieces a
fraction of a micrometre long) 58 floors of some 3,000 pieces each per dexel, 8 billion
planes on a 3,000-line prefix and most of its verification's time. So the pieces of each
run are cut in *blocks* of :data:`SUPPORT_BLOCK` consecutive pieces, each with one plane
bound on all its pieces. Write the numerator of ``lambda_k`` as
``nu . P - max(H(a_k, u_k), H(b_k, u_k)) - m`` with ``b_k = a_k + e_k`` and

.. math::

    H(x, u) = \nu \cdot x + \rho_0 |\nu \times u| + L \max(0, \nu \cdot u) + r,

which is convex in ``(x, u)`` (a linear term, a norm of a linear map, a maximum of linear
terms; for any vector ``u``, not only a unit one) and Lipschitz:
``|H(x, u) - H(x', u')| <= |x - x'| + (rho0 + L) |u - u'|``. Along the segment
``z(t) = (x(t), u(t)) = (1 - t) (s0, u0) + t (s1, u1)`` from the block's first piece's
start and axis to its last piece's end and axis, ``H(z(t))`` is convex in ``t``, so at
most its larger end. For either end ``x`` of piece ``k``, take ``t_x`` projecting ``x``
onto the positions' segment and ``t_u`` projecting ``u_k`` onto the axes' (any two places
would do): ``nu . x <= nu . x(t_x) + |x - x(t_x)|``, ``x(t)`` is affine so
``nu . x(t_x) = nu . x(t_u) + (t_x - t_u) nu . (s1 - s0)``, and
``f(u_k) <= f(u(t_u)) + (rho0 + L) |u_k - u(t_u)|`` (``f = H - nu . x``): so

.. math::

    \max_k H(\cdot, u_k) \le \max(H(s_0, u_0), H(s_1, u_1)) + \zeta_x
        + (\rho_0 + L) \zeta_u + \tau |\nu \cdot (s_1 - s_0)| + \epsilon

with ``zeta_x``, ``zeta_u``, ``tau`` the largest ``|x - x(t_x)|``, ``|u_k - u(t_u)|`` and
``|t_x - t_u|`` over the block (measured once; ``t_u = t_x`` where the axis does not
turn), plus ``rho0`` times :data:`_SINE_ROUNDING` (a piece's sine as computed may
stand that far above the true one). Projecting each on its own keeps ``zeta`` the
sagittas of the path and of the axes' turn over a block: pairing a piece's end with its
own axis at one ``t`` would charge a whole piece's turn, ``(rho0 + L)`` times 13 urad =
0.3 um on the blade's fine pieces; ``tau`` is charged along ``s1 - s0`` only, to which
the sweep's normal at an entry stands nearly square. ``epsilon`` =
:data:`_BLOCK_PAD_MM` covers the rounding of both sides, and the block's plane
``(nu . P - that - m) / (-nu . d)`` lies at or below every ``lambda_k`` of its pieces,
as computed. :func:`run_floor` takes the block's plane where it is not below the
best so far (``limit``) and its pieces' ``lambda_k`` one by one where it is: the least is
then the same as the pass over every piece wherever that lies below ``limit`` (the piece
giving it is in a block whose plane lies lower still, so opened), and at or above
``limit`` wherever that does (every term is), so the walks take the same decisions, open
the same halves and measure the same pieces (the same pairs count), for a block's two
planes instead of its pieces' ``SUPPORT_BLOCK`` where the block's plane decides.

A run takes, from its first piece, as many pieces as keep its ``delta`` within
``max_dilation_mm``, its length within ``max_length_mm`` and its count within
``max_pieces`` (found by doubling, then halving, the count): a jump in the path (a rapid,
the next pass) or a change of core height or kind starts a new one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Final

import numba
import numpy as np
from numpy.typing import NDArray

from toolpath.row_threads import run_in_threads

from .capsule_search import ROUNDING_SLACK_MM
from .pieces import Pieces
from .torus import CONVERGED_MM, sweep_entry_normal, sweep_exit

__all__ = ["ENTRY_MARGIN_MM", "RUN_DILATION_MM", "RUN_LENGTH_MM", "RUN_PIECES",
           "SUPPORT_BLOCK", "PieceRuns", "blocked_support_floor", "floor_entry", "piece_runs",
           "run_floor", "span_reference", "support_floor"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

RUN_DILATION_MM: Final[float] = 0.06
"""Largest dilation of a run's reference piece, mm. A run is opened where its dilated
entry lies below the best value so far, then halved (each half's own, smaller dilation
measured) down to single pieces: on the bull-nose 5-axis blade (pieces turning the axis by
about a micrometre at the cutter's reach) 16 to 60 um took about as long with the dilated
floor alone; with the pieces' support planes (:func:`run_floor`) the whole program's
verification took 135 s CPU at 30 um, 118-120 at 60 and 120 um, 136 at 250, 181 at 15
(the same figures at each: the runs only prune; measured before the block planes of
:data:`SUPPORT_BLOCK`)."""

RUN_PIECES: Final[int] = 4096
"""Most pieces in one run (the fine model's pieces, 25 times shorter than the whole
program's, fill their dilation with thousands)."""

RUN_LENGTH_MM: Final[float] = 1.0
"""Longest run, mm: a run is a candidate wherever one of its pieces may be, so its spread
widens every dexel's walk over the runs' grid (long straight pieces of a 3-axis program
would otherwise make runs metres long)."""

SUPPORT_BLOCK: Final[int] = 128
"""Most pieces in one block of support planes (module docstring, *Blocks*): a block's
plane costs two pieces' planes and decides for all of its pieces where it lies at or
above the best so far."""

RUN_SLICE_PIECES: Final[int] = 1 << 16
"""Pieces whose runs a thread finds at a time (:func:`piece_runs`); no run crosses a
multiple of it, so the runs are the same whatever the threads (a run break every 65,536
pieces: a few more runs among the hundreds of thousands of a 5-axis program's)."""

ENTRY_MARGIN_MM: Final[float] = 2.0 * CONVERGED_MM
"""Added to every run's dilation: a piece's entry as measured (a point within
``CONVERGED_MM`` of its sweep) stays at or after the run's."""

#: Relative widening of a measured dilation (the rounding of its sums).
_ROUNDING: Final[float] = 1e-9

#: Added to a block's support bound, mm (``epsilon`` of the module docstring): the two
#: sides' rounding, some 1e-13 mm at a metre from the origin, far inside it.
_BLOCK_PAD_MM: Final[float] = 1e-9

#: How far a piece's sine, ``max(|nu x u|, sqrt(1 - c^2))`` in :func:`support_floor`, may
#: stand above the true one: ``c`` rounded by an ulp or two makes ``sqrt(1 - c^2)`` up to
#: ``sqrt(1.4e-15)`` ~ 3.7e-8 where ``nu`` lies along the axis (|nu x u| ~ 1e-16). A block's
#: bound (true sines, by convexity) is raised by ``core_radius`` times this, so an inner
#: piece's rounded-up sine cannot put its plane under the block's (a flat 50's core: 1.25 nm).
_SINE_ROUNDING: Final[float] = 5e-8

#: Relative (and absolute, mm) widening of a span's path length from the run's prefix
#: sums: up to :data:`RUN_PIECES` terms of a run at most a few millimetres long, each
#: rounded by 1e-16 relative, so under 1e-12 mm; the semi-minor axis it feeds grows as the
#: square root of the length's error, hence the margin.
_PREFIX_ROUNDING: Final[float] = 1e-11


@dataclass(frozen=True, eq=False)
class PieceRuns:
    """Runs of consecutive pieces and the dilated reference piece holding each.

    Attributes
    ----------
    start, stop : ndarray of int64, shape (k,)
        The run's pieces are ``start <= piece < stop`` (indices into the pieces).
    c0, chord, axis : ndarray, shape (k, 3)
        The reference piece: core bottom centre at its start, its travel (mm), unit axis.
    height_mm : ndarray, shape (k,)
        Core height of the run's pieces, mm.
    dilation_mm : ndarray, shape (k,)
        ``delta`` plus :data:`ENTRY_MARGIN_MM`: every piece lies inside the reference
        sweep with corner radius ``r + dilation``, mm.
    mid : ndarray, shape (k, 3)
        Midpoint of the reference segment, mm.
    spread_mm : ndarray, shape (k,)
        Farthest piece midpoint from ``mid``, mm.
    half_mm : ndarray, shape (k,)
        ``max (|mid_k - mid| + half_k)`` over the run: every piece's solid lies within a
        piece's bounding radius about its own midpoint plus this of ``mid``, mm.
    along_mm, turned : ndarray, shape (pieces,)
        Per piece (in the pieces' order, whatever the runs' order), from its run's first
        piece: the path length to its start through the pieces and the gaps between
        them, mm, and the steps ``|a_{m+1} - a_m|`` of the axis summed
        (:func:`span_reference` bounds any span's dilation from them).
    block_of : ndarray of int64, shape (pieces,)
        Per piece its block of support planes (module docstring, *Blocks*; blocks are
        numbered in piece order and never cross a run).
    block_span : ndarray of int64, shape (blocks, 2)
        A block's pieces are ``block_span[b, 0] <= piece < block_span[b, 1]``.
    block_slack : ndarray, shape (blocks, 3)
        ``zeta_x`` (mm), ``zeta_u`` and ``tau`` of each block, widened for rounding.
    """

    start: IntArray
    stop: IntArray
    c0: FloatArray
    chord: FloatArray
    axis: FloatArray
    height_mm: FloatArray
    dilation_mm: FloatArray
    mid: FloatArray
    spread_mm: FloatArray
    half_mm: FloatArray
    along_mm: FloatArray
    turned: FloatArray
    block_of: IntArray
    block_span: IntArray
    block_slack: FloatArray

    @property
    def size(self) -> int:
        """Number of runs."""
        return int(self.start.shape[0])

    def taken(self, rows: IntArray) -> PieceRuns:
        """The runs at ``rows``, every field contiguous (the grid's order, for a walk)."""
        f = np.ascontiguousarray
        return PieceRuns(f(self.start[rows]), f(self.stop[rows]), f(self.c0[rows]),
                         f(self.chord[rows]), f(self.axis[rows]), f(self.height_mm[rows]),
                         f(self.dilation_mm[rows]), f(self.mid[rows]), f(self.spread_mm[rows]),
                         f(self.half_mm[rows]), self.along_mm, self.turned, self.block_of,
                         self.block_span, self.block_slack)

    @property
    def max_spread_mm(self) -> float:
        """Largest spread of a run, mm (0 when empty)."""
        return float(self.spread_mm.max()) if self.size else 0.0


@numba.njit(cache=True)
def _segment_gap(px: float, py: float, pz: float, s: FloatArray, dx: float, dy: float,
                 dz: float, dd: float) -> float:
    """Distance of a point from the segment ``s -> s + D`` (``dd = |D|^2``)."""
    vx, vy, vz = px - s[0], py - s[1], pz - s[2]
    f = 0.0
    if dd > 0.0:
        f = min(max((vx * dx + vy * dy + vz * dz) / dd, 0.0), 1.0)
    vx, vy, vz = vx - f * dx, vy - f * dy, vz - f * dz
    return math.sqrt(vx * vx + vy * vy + vz * vz)


@numba.njit(cache=True)
def _dilation(first: int, last: int, a: FloatArray, e: FloatArray, axis: FloatArray,
              height: FloatArray, core_radius: float, corner_radius: float) -> float:
    """``delta`` of the pieces ``first..last`` about their reference (module docstring)."""
    ref = (first + last) // 2
    s = a[first]
    dx = a[last, 0] + e[last, 0] - s[0]
    dy = a[last, 1] + e[last, 1] - s[1]
    dz = a[last, 2] + e[last, 2] - s[2]
    dd = dx * dx + dy * dy + dz * dz
    worst = 0.0
    for k in range(first, last + 1):
        tx, ty, tz = axis[k, 0] - axis[ref, 0], axis[k, 1] - axis[ref, 1], axis[k, 2] - axis[ref, 2]
        turn = math.sqrt(tx * tx + ty * ty + tz * tz) * (
            math.hypot(core_radius, height[k]) + corner_radius)
        g0 = _segment_gap(a[k, 0], a[k, 1], a[k, 2], s, dx, dy, dz, dd)
        g1 = _segment_gap(a[k, 0] + e[k, 0], a[k, 1] + e[k, 1], a[k, 2] + e[k, 2], s, dx, dy,
                          dz, dd)
        worst = max(worst, turn + max(g0, g1))
    return worst


@numba.njit(cache=True)
def span_reference(first: int, last: int, a: FloatArray, e: FloatArray, axis: FloatArray,
                   height: FloatArray, along: FloatArray, turned: FloatArray,
                   core_radius: float, corner_radius: float, chord: FloatArray
                   ) -> tuple[int, float]:
    """The reference piece of pieces ``first..last`` of one run, and a bound on its dilation.

    Writes its chord ``a_last + e_last - a_first`` into ``chord``; returns the piece whose
    axis it holds (the middle one) and a bound on its dilation (``delta`` of the module
    docstring, widened for rounding, plus :data:`ENTRY_MARGIN_MM`), in constant time from
    the run's prefix sums (:attr:`PieceRuns.along_mm`, :attr:`PieceRuns.turned`) rather
    than a pass over the pieces (a walk halves a run of thousands of fine pieces per dexel):

    * turn: ``|a_k - A|`` is at most the sum of the steps ``|a_{m+1} - a_m|`` between ``k``
      and the reference, so at most ``max(T_ref - T_first, T_last - T_ref)``;
    * path: the pieces' ends lie on the polyline from ``s0 = a_first`` to
      ``s1 = a_last + e_last`` through every piece and the gaps between them, of length
      ``Lp``; a point ``x`` of it has ``|x - s0| + |x - s1| <= Lp`` (a spheroid with foci
      ``s0, s1``), hence stands within its semi-minor axis ``sqrt(Lp^2 - c^2) / 2`` of the
      segment (``c = |s1 - s0|``).

    Its core starts at ``a[first]``; the pieces share one core height (a run's).
    """
    for c in range(3):
        chord[c] = a[last, c] + e[last, c] - a[first, c]
    ref = (first + last) // 2
    turn = max(turned[ref] - turned[first], turned[last] - turned[ref])
    ex, ey, ez = e[last, 0], e[last, 1], e[last, 2]
    length = along[last] - along[first] + math.sqrt(ex * ex + ey * ey + ez * ez)
    length = length * (1.0 + _PREFIX_ROUNDING) + _PREFIX_ROUNDING
    cc = chord[0] * chord[0] + chord[1] * chord[1] + chord[2] * chord[2]
    off = 0.5 * math.sqrt(max(length * length - cc, 0.0))
    delta = turn * (math.hypot(core_radius, height[ref]) + corner_radius) + off
    return ref, delta * (1.0 + _ROUNDING) + ENTRY_MARGIN_MM


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def reaches(hi: float) -> bool:
    """Whether pieces inside a sweep whose exit bound is ``hi`` may reach the design point.

    ``hi`` is :func:`~verification.torus.sweep_bound`'s bound on the exit of a piece's
    sweep, or of a run's or half's dilated one. A piece leaves material only where it
    reaches the design point (``lam_out > 0``,
    :func:`~verification.capsule_search.pair_value`), and its exit as measured (Newton
    from the right: a point within ``CONVERGED_MM`` of its sweep, hence inside the
    dilated one) stands at or before ``hi`` but for that bound's rounding; so a bound
    below ``-ROUNDING_SLACK_MM`` rules out every piece inside, without the Newton steps of
    :func:`floor_entry` (whose ``inf`` says the same). On the bull-nose 5-axis blade
    these are the cutter on the other side of the thin blade, met by every dexel of this
    side: 7 of every 8 runs floored, 120 -> 18 floors a dexel.
    """
    return not hi < -ROUNDING_SLACK_MM


@numba.njit(cache=True)
def _dilated_floor(p: FloatArray, d: FloatArray, c0: FloatArray, chord: FloatArray,
                   axis: FloatArray, height: float, core_radius: float, dilated_radius: float,
                   lo: float, hi: float, best: float) -> tuple[float, float, float, float]:
    """:func:`floor_entry`, and the dilated sweep's outward normal at the entry (or zeros)."""
    if not lo < best:
        return lo, 0.0, 0.0, 0.0
    entry, gx, gy, gz = sweep_entry_normal(p, d, c0, chord, axis, height, core_radius,
                                           dilated_radius, lo, hi)
    if not entry < best:
        return entry, 0.0, 0.0, 0.0
    if entry < 0.0 and not sweep_exit(p, d, c0, chord, axis, height, core_radius,
                                      dilated_radius, entry, hi) > 0.0:
        return math.inf, 0.0, 0.0, 0.0
    return entry, gx, gy, gz


@numba.njit(cache=True)
def floor_entry(p: FloatArray, d: FloatArray, c0: FloatArray, chord: FloatArray,
                axis: FloatArray, height: float, core_radius: float, dilated_radius: float,
                lo: float, hi: float, best: float) -> float:
    """A lower bound on what any piece inside a dilated sweep leaves on a dexel.

    The dilated sweep's entry (its bounds ``lo, hi`` from
    :func:`~verification.torus.sweep_bound`); ``inf`` where it leaves the line at or below
    the design point (a piece inside it then leaves nothing: the other side of a thin
    blade), and ``lo`` itself when that is not below ``best`` (nothing measured).
    """
    return _dilated_floor(p, d, c0, chord, axis, height, core_radius, dilated_radius, lo, hi,
                          best)[0]


@numba.njit(cache=True)
def support_floor(p: FloatArray, d: FloatArray, nx: float, ny: float, nz: float, first: int,
                  stop: int, a: FloatArray, e: FloatArray, axis: FloatArray,
                  height: FloatArray, core_radius: float, corner_radius: float) -> float:
    """``min_k lambda_k(nu)`` over pieces ``first <= k < stop`` (module docstring).

    The plane of unit normal ``nu = (nx, ny, nz)`` on each piece's sweep (corner radius
    ``corner_radius``: a widened piece's too) bounds its entry into the dexel from below;
    ``-inf`` where ``nu . d`` is not negative (the planes face away). The least over every
    piece even where one lies below the best so far: a floor waiting in the walk is
    compared again with a lower best (an early stop there cost more halves than the pass
    saves).
    """
    nd = nx * d[0] + ny * d[1] + nz * d[2]
    if not nd < 0.0:
        return -math.inf
    least = math.inf
    for k in range(first, stop):
        c = nx * axis[k, 0] + ny * axis[k, 1] + nz * axis[k, 2]
        # sin of the angle between nu and the axis: |nu x axis|, which keeps an angle of
        # 1e-8 rad that 1 - c^2 rounds to 0 (a core radius of 25 mm would lose 2.5e-7 mm,
        # past the margin); the larger of the two, as either may round low
        sx = ny * axis[k, 2] - nz * axis[k, 1]
        sy = nz * axis[k, 0] - nx * axis[k, 2]
        sz = nx * axis[k, 1] - ny * axis[k, 0]
        sine = max(math.sqrt(sx * sx + sy * sy + sz * sz), math.sqrt(max(1.0 - c * c, 0.0)))
        support = core_radius * sine + height[k] * max(c, 0.0) + corner_radius
        ahead = max(nx * e[k, 0] + ny * e[k, 1] + nz * e[k, 2], 0.0)
        gap = (nx * (p[0] - a[k, 0]) + ny * (p[1] - a[k, 1]) + nz * (p[2] - a[k, 2]) - ahead
               - support - ENTRY_MARGIN_MM)
        least = min(least, gap / -nd)
    return least


@numba.njit(cache=True)
def _plane_height(nx: float, ny: float, nz: float, x0: float, x1: float, x2: float,
                  u: FloatArray, height: float, core_radius: float,
                  corner_radius: float) -> float:
    """``H(x, u)`` of the module docstring (*Blocks*), ``x = (x0, x1, x2)``.

    The point as floats: no array made per block on the walks' hottest path.
    """
    c = nx * u[0] + ny * u[1] + nz * u[2]
    sx = ny * u[2] - nz * u[1]
    sy = nz * u[0] - nx * u[2]
    sz = nx * u[1] - ny * u[0]
    sine = max(math.sqrt(sx * sx + sy * sy + sz * sz), math.sqrt(max(1.0 - c * c, 0.0)))
    return (nx * x0 + ny * x1 + nz * x2 + core_radius * sine + height * max(c, 0.0)
            + corner_radius)


@numba.njit(cache=True)
def blocked_support_floor(p: FloatArray, d: FloatArray, nx: float, ny: float, nz: float,
                          first: int, stop: int, limit: float, a: FloatArray, e: FloatArray,
                          axis: FloatArray, height: FloatArray, core_radius: float,
                          corner_radius: float, block_of: IntArray, block_span: IntArray,
                          block_slack: FloatArray) -> float:
    """:func:`support_floor` wherever it lies below ``limit``; at or above it wherever it does.

    Block by block (module docstring, *Blocks*): a block's one plane where it is not below
    ``limit``, its pieces' planes (over ``first <= k < stop`` only) where it is. A block
    holding pieces outside the span bounds the span's too (the least over more pieces is
    no larger).
    """
    nd = nx * d[0] + ny * d[1] + nz * d[2]
    if not nd < 0.0:
        return -math.inf
    if stop <= first:
        return math.inf
    at = nx * p[0] + ny * p[1] + nz * p[2]
    least = math.inf
    for b in range(block_of[first], block_of[stop - 1] + 1):
        b0, b1 = block_span[b, 0], block_span[b, 1]
        k = b1 - 1
        end0, end1, end2 = a[k, 0] + e[k, 0], a[k, 1] + e[k, 1], a[k, 2] + e[k, 2]
        top = max(_plane_height(nx, ny, nz, a[b0, 0], a[b0, 1], a[b0, 2], axis[b0], height[b0],
                                core_radius, corner_radius),
                  _plane_height(nx, ny, nz, end0, end1, end2, axis[k], height[k], core_radius,
                                corner_radius))
        along = abs(nx * (end0 - a[b0, 0]) + ny * (end1 - a[b0, 1]) + nz * (end2 - a[b0, 2]))
        top += (block_slack[b, 0] + (core_radius + height[b0]) * block_slack[b, 1]
                + block_slack[b, 2] * along + _BLOCK_PAD_MM + core_radius * _SINE_ROUNDING)
        plane = (at - top - ENTRY_MARGIN_MM) / -nd
        if not plane < limit:
            least = min(least, plane)
            continue
        least = min(least, support_floor(p, d, nx, ny, nz, max(first, b0), min(stop, b1), a,
                                         e, axis, height, core_radius, corner_radius))
    return least


@numba.njit(cache=True)
def run_floor(p: FloatArray, d: FloatArray, c0: FloatArray, chord: FloatArray,
              ref_axis: FloatArray, ref_height: float, core_radius: float,
              corner_radius: float, dilation: float, lo: float, hi: float, best: float,
              first: int, stop: int, a: FloatArray, e: FloatArray, axis: FloatArray,
              height: FloatArray, block_of: IntArray, block_span: IntArray,
              block_slack: FloatArray) -> float:
    """A lower bound on what any of the pieces ``first <= k < stop`` leaves on a dexel.

    The pieces lie inside the reference (``c0``, ``chord``, ``ref_axis``,
    ``ref_height``) dilated by ``dilation`` (corner radius ``corner_radius + dilation``;
    ``lo, hi`` its :func:`~verification.torus.sweep_bound`). Its :func:`floor_entry`;
    where that lies below ``best``, the larger of it and the pieces' least support plane
    at the dilated sweep's normal there (:func:`support_floor`, by blocks:
    :func:`blocked_support_floor`, the same value wherever the result lies below
    ``best``). ``inf`` where no piece reaches the design point, ``lo`` where that is not
    below ``best``; the blocks are :class:`PieceRuns`'.
    """
    floor, gx, gy, gz = _dilated_floor(p, d, c0, chord, ref_axis, ref_height, core_radius,
                                       corner_radius + dilation, lo, hi, best)
    if not floor < best:
        return floor
    norm = math.sqrt(gx * gx + gy * gy + gz * gz)
    if not norm > 0.0:
        return floor
    return max(floor, blocked_support_floor(p, d, gx / norm, gy / norm, gz / norm, first,
                                            stop, best, a, e, axis, height, core_radius,
                                            corner_radius, block_of, block_span,
                                            block_slack))


@numba.njit(cache=True)
def _prefixes(a: FloatArray, e: FloatArray, axis: FloatArray, start: IntArray,
              stop: IntArray) -> tuple[FloatArray, FloatArray]:
    """Per piece, from its run's first: path length to its start, and the axis steps summed."""
    along = np.zeros(a.shape[0])
    turned = np.zeros(a.shape[0])
    for r in range(start.shape[0]):
        for k in range(start[r] + 1, stop[r]):
            gx = a[k, 0] - a[k - 1, 0] - e[k - 1, 0]
            gy = a[k, 1] - a[k - 1, 1] - e[k - 1, 1]
            gz = a[k, 2] - a[k - 1, 2] - e[k - 1, 2]
            ex, ey, ez = e[k - 1, 0], e[k - 1, 1], e[k - 1, 2]
            along[k] = (along[k - 1] + math.sqrt(ex * ex + ey * ey + ez * ez)
                        + math.sqrt(gx * gx + gy * gy + gz * gz))
            tx = axis[k, 0] - axis[k - 1, 0]
            ty = axis[k, 1] - axis[k - 1, 1]
            tz = axis[k, 2] - axis[k - 1, 2]
            turned[k] = turned[k - 1] + math.sqrt(tx * tx + ty * ty + tz * tz)
    return along, turned


@numba.njit(cache=True)
def _blocks(a: FloatArray, e: FloatArray, axis: FloatArray, start: IntArray, stop: IntArray,
            size: int) -> tuple[IntArray, IntArray, FloatArray]:
    """Each run's pieces in blocks of ``size`` (module docstring, *Blocks*).

    Per piece its block; per block its span and ``zeta_x, zeta_u, tau``, widened for
    rounding.
    """
    n = a.shape[0]
    block_of = np.zeros(n, dtype=np.int64)
    count = 0
    for r in range(start.shape[0]):
        count += (stop[r] - start[r] + size - 1) // size
    span = np.empty((count, 2), dtype=np.int64)
    slack = np.zeros((count, 3))
    x = np.empty(3)
    b = 0
    for r in range(start.shape[0]):
        for b0 in range(start[r], stop[r], size):
            b1 = min(b0 + size, stop[r])
            span[b, 0], span[b, 1] = b0, b1
            last = b1 - 1
            s0, u0, u1 = a[b0], axis[b0], axis[last]
            dx = a[last, 0] + e[last, 0] - s0[0]
            dy = a[last, 1] + e[last, 1] - s0[1]
            dz = a[last, 2] + e[last, 2] - s0[2]
            dd = dx * dx + dy * dy + dz * dz
            vx, vy, vz = u1[0] - u0[0], u1[1] - u0[1], u1[2] - u0[2]
            vv = vx * vx + vy * vy + vz * vz
            worst_x = 0.0
            worst_u = 0.0
            worst_t = 0.0
            for k in range(b0, b1):
                block_of[k] = b
                # the axis's own place on the axes' segment (any place bounds it)
                ux, uy, uz = axis[k, 0] - u0[0], axis[k, 1] - u0[1], axis[k, 2] - u0[2]
                t_u = -1.0
                if vv > 0.0:
                    t_u = min(max((ux * vx + uy * vy + uz * vz) / vv, 0.0), 1.0)
                for end in range(2):
                    for c in range(3):
                        x[c] = a[k, c] + (e[k, c] if end == 1 else 0.0)
                    t = 0.0
                    if dd > 0.0:
                        t = min(max(((x[0] - s0[0]) * dx + (x[1] - s0[1]) * dy
                                     + (x[2] - s0[2]) * dz) / dd, 0.0), 1.0)
                    gx = x[0] - s0[0] - t * dx
                    gy = x[1] - s0[1] - t * dy
                    gz = x[2] - s0[2] - t * dz
                    worst_x = max(worst_x, math.sqrt(gx * gx + gy * gy + gz * gz))
                    tu = t if t_u < 0.0 else t_u
                    hx = ux - tu * vx
                    hy = uy - tu * vy
                    hz = uz - tu * vz
                    worst_u = max(worst_u, math.sqrt(hx * hx + hy * hy + hz * hz))
                    worst_t = max(worst_t, abs(t - tu))
            slack[b, 0] = worst_x * (1.0 + _ROUNDING)
            slack[b, 1] = worst_u * (1.0 + _ROUNDING)
            slack[b, 2] = worst_t * (1.0 + _ROUNDING)
            b += 1
    return block_of, span, slack


@numba.njit(cache=True)
def _fits(first: int, last: int, a: FloatArray, e: FloatArray, axis: FloatArray,
          height: FloatArray, shank: NDArray[np.bool_], core_radius: float,
          corner_radius: float, max_dilation: float, max_length: float) -> float:
    """The dilation of pieces ``first..last`` as one run, or ``-1`` where they cannot be one."""
    for k in range(first + 1, last + 1):
        if height[k] != height[first] or shank[k] != shank[first]:
            return -1.0
    gx = a[last, 0] + e[last, 0] - a[first, 0]
    gy = a[last, 1] + e[last, 1] - a[first, 1]
    gz = a[last, 2] + e[last, 2] - a[first, 2]
    if not gx * gx + gy * gy + gz * gz <= max_length * max_length:
        return -1.0
    delta = _dilation(first, last, a, e, axis, height, core_radius, corner_radius)
    return delta if delta <= max_dilation else -1.0


@numba.njit(cache=True, nogil=True)
def _runs(a: FloatArray, e: FloatArray, axis: FloatArray, height: FloatArray,
          shank: NDArray[np.bool_], core_radius: float, corner_radius: float,
          max_dilation: float, max_pieces: int, max_length: float, slice_pieces: int,
          first: NDArray[np.bool_], delta_of: FloatArray, lo: int, hi: int) -> None:
    """Runs of pieces ``lo .. hi - 1``: the longest that fits, found by doubling then halving.

    Marks each run's first piece in ``first`` and writes its dilation in ``delta_of``. No
    run crosses a multiple of ``slice_pieces`` (``lo`` and ``hi`` are such multiples, or
    the ends): the runs are the same however the pieces are shared among threads. A run's
    dilation is measured whole for each length tried (``O(m log m)`` per run of ``m``
    pieces); the length kept is one that fits, not always the longest.
    """
    i = lo
    while i < hi:
        end = min(hi, (i // slice_pieces + 1) * slice_pieces)
        good, delta = 1, 0.0
        bad = 2
        # doubling: the first length that does not fit (or the most allowed)
        while True:
            size = min(bad, max_pieces, end - i)
            if size <= good:
                bad = size + 1
                break
            trial = _fits(i, i + size - 1, a, e, axis, height, shank, core_radius,
                          corner_radius, max_dilation, max_length)
            if trial < 0.0:
                bad = size
                break
            good, delta = size, trial
            bad = 2 * size
        # halving between the last length that fits and the first that does not
        while bad - good > 1:
            size = (good + bad) // 2
            trial = _fits(i, i + size - 1, a, e, axis, height, shank, core_radius,
                          corner_radius, max_dilation, max_length)
            if trial < 0.0:
                bad = size
            else:
                good, delta = size, trial
        first[i] = True
        delta_of[i] = delta
        i += good


def piece_runs(pieces: Pieces, *, core_radius_mm: float, corner_radius_mm: float,
               max_dilation_mm: float = RUN_DILATION_MM, max_pieces: int = RUN_PIECES,
               max_length_mm: float = RUN_LENGTH_MM,
               block_pieces: int = SUPPORT_BLOCK) -> PieceRuns:
    """Consecutive pieces gathered in runs, each inside its dilated reference piece.

    Parameters
    ----------
    pieces : Pieces
        Flat or bull-nose pieces (and shank pieces), in path order.
    core_radius_mm, corner_radius_mm : float
        ``rho0 = R - r`` and ``r``, mm.
    max_dilation_mm : float
        A run grows while its ``delta`` stays within this, mm.
    max_pieces : int
        Most pieces in a run.
    max_length_mm : float
        Longest run (its reference segment), mm.
    block_pieces : int
        Most pieces in a block of support planes.

    Returns
    -------
    PieceRuns
    """
    f = np.ascontiguousarray
    a, e, axis = f(pieces.a, dtype=float), f(pieces.e, dtype=float), f(pieces.axis, dtype=float)
    n = a.shape[0]
    first, delta_of = np.zeros(n, dtype=np.bool_), np.zeros(n)
    run_in_threads(_runs, n, a, e, axis, f(pieces.height_mm, dtype=float),
                   f(pieces.shank, dtype=np.bool_), float(core_radius_mm),
                   float(corner_radius_mm), float(max_dilation_mm), int(max_pieces),
                   float(max_length_mm), RUN_SLICE_PIECES, first, delta_of,
                   min_rows=RUN_SLICE_PIECES, dynamic=True)
    bounds = np.append(np.flatnonzero(first), n)
    start, stop = bounds[:-1], bounds[1:]
    delta = delta_of[start]
    last = stop - 1
    c0 = a[start]
    chord = a[last] + e[last] - c0
    ref_axis = axis[(start + last) // 2]
    mid = c0 + 0.5 * chord
    owner = np.repeat(np.arange(start.shape[0]), stop - start)
    off = np.sqrt(np.sum((pieces.mid - mid[owner]) ** 2, axis=1))
    spread = np.zeros(start.shape[0])
    half = np.zeros(start.shape[0])
    np.maximum.at(spread, owner, off)
    np.maximum.at(half, owner, off + pieces.half_mm)
    return PieceRuns(start, stop, f(c0), f(chord), f(ref_axis), f(pieces.height_mm[start]),
                     delta * (1.0 + _ROUNDING) + ENTRY_MARGIN_MM, f(mid),
                     spread * (1.0 + _ROUNDING), half * (1.0 + _ROUNDING),
                     *_prefixes(a, e, axis, start, stop),
                     *_blocks(a, e, axis, start, stop, int(block_pieces)))
