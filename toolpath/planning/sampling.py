"""Points along a pass from the chord tolerance, and the cutter-to-surface gap that checks them.

Between two cutter locations the cutter moves on a straight line. With the surface's
normal curvature ``k`` along the pass and the cutter's section radius ``rho`` along the feed
(``R`` for a ball), the cutter's osculating circle centre moves on a curve of radius
``|1/k - rho|``; the chord between contacts ``L`` apart leaves the cutter at mid-chord
``delta = L^2 |k| |1 - rho k| / 8`` off the surface (into it on convex parts, above it on
concave ones). Adding the pass's geodesic curvature ``kg`` (sideways drift of the track),
the allowed spacing is the chord of a circle of curvature
``kappa = sqrt((k (1 - rho k))^2 + kg^2)`` with sagitta ``tol``:
``L = 2 sqrt(tol (2/kappa - tol))``. In 5-axis the axis turns by ``theta = L w`` over the
move (``w`` per mm); interpolated normalized-linearly it is longer than the linear mean by
``1/cos(theta/2)``, which lifts the point ``c`` above the tip (the corner-circle centre)
by ``c theta^2 / 8``: on concave parts, where the move stands above the surface, that adds
``c w^2`` to ``k (1 - rho k)`` (on convex ones it lessens the cut: left out).

The points of each pass equidistribute ``int |X_t| / L dt`` (so every chord gets the same
share of the tolerance), and are then verified: :func:`cutter_gap` measures the signed
distance between the cutter and the surface at chord midpoints by projecting the cutter's
corner-circle centre onto the surface (Newton), and offending chords are split. Where
the curvature changes along a move the largest gap is off its middle (near a leading
edge, by 8 % of the tolerance at ``u = 0.4``), so the gap is measured at
``u = 1/4, 1/2, 3/4`` and modelled as ``g(u) = u (1 - u)(a + b u + c u^2)`` (zero at the
contacts, exact for curvature varying quadratically along the move); the model's extreme
``u*`` is where the move is judged (:func:`chord_extremes`: both the lowest and the highest).
"""

from __future__ import annotations

import functools
import math
from typing import Any, NamedTuple

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from machines import Machine
from machines.kinematics import forward

from ..compiled import Moves
from ..projection_kernel import seam_lerp_rows
from ..row_threads import run_in_threads
from ..surface import ParametricSurface
from ..tolerances import FLAT_PER_MM, LIMIT_SLACK, ROUND_OFF
from ..vectors import row_lengths
from .cutters import Cutter, CutterKind, disc_basis
from .local import (
    CONVERGED_MM,
    EXTRA_ITERATIONS,
    PassFrame,
    project_to_surface,
    signed_distance_near,
)
from .open_edges import edge_readings
from .tool_axis import segment_index

__all__ = [
    "CHORD_FRACTIONS",
    "ball_end_slopes",
    "chord_extremes",
    "chord_length_mm",
    "contact_end_slopes",
    "cutter_gap",
    "equidistribute",
    "JointEnds",
    "MoveEnds",
    "joint_moves",
    "pass_densities",
    "move_gaps",
    "move_poses",
    "split_evenly",
]

#: Where inside a move the gap is measured; with the ends (gap 0) they fix the model below.
CHORD_FRACTIONS = (0.25, 0.5, 0.75)
#: A disc point's foot off the normal through the point by more than this (mm) is not its
#: closest point: a converged Newton foot lies on it to round-off (1e-14 mm measured), one
#: stopped within :data:`~.local.CONVERGED_MM` of it to about that (:meth:`_Disc._stationary`).
STATIONARY_MM = 0.01
#: Newton steps beyond the disc's own for a point searched again from a neighbour's foot.
STATIONARY_EXTRA = 4
#: Samples of the gap model's slope on [0, 1] that bracket its extremes (:func:`chord_extremes`).
_GRID = 21
#: A gap model (mm) whose coefficients are all below this is round-off: it has no extremes
#: worth a search.
_ROUND_OFF_MODEL_MM = 1e-15
#: Second difference of three sampled gaps (mm) below which their parabola has no minimum
#: (flat or bending down): the sample stays where it is.
_LEAST_BEND_MM = 1e-15


def chord_length_mm(frame: PassFrame, feed_radius_mm: NDArray[np.float64],
                    tol_mm: float | NDArray[np.float64], max_segment_mm: float, *,
                    lift_mm: float = 0.0, turn_per_mm: ArrayLike = 0.0
                    ) -> NDArray[np.float64]:
    """Allowed contact spacing along the pass, mm (formula in the module docstring).

    Parameters
    ----------
    frame : PassFrame
        Geometry at the probe points.
    feed_radius_mm : ndarray
        Cutter section radius along the feed, mm (finite).
    tol_mm : float or ndarray
        Chord tolerance (per point: concave passes get the smaller undercut allowance).
    max_segment_mm : float
        Upper bound on any spacing.
    lift_mm, turn_per_mm : float, float or ndarray
        ``c`` and ``w``: the height of the corner-circle centre above the tip and the
        axis' turn along the pass, rad/mm (5-axis; 0 in 3-axis).
    """
    k = frame.s11
    bend = k * (1.0 - feed_radius_mm * k) + np.where(
        k > 0.0, lift_mm * np.square(turn_per_mm), 0.0)
    kappa = np.hypot(bend, frame.kg)
    radius = 1.0 / np.maximum(kappa, FLAT_PER_MM)
    length = 2.0 * np.sqrt(np.maximum(tol_mm * (2.0 * radius - tol_mm), tol_mm * tol_mm))
    return np.minimum(length, max_segment_mm)


def equidistribute(t_grid: NDArray[np.float64], density: NDArray[np.float64]
                   ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Points per pass where the cumulative density reaches whole numbers.

    The density's integral by trapezoids on the grid, ``n = ceil(total)`` equal segments
    (at least one), the points where the integral reaches ``k total / n`` by linear
    interpolation (compiled, pass by pass).

    Parameters
    ----------
    t_grid : ndarray, shape (m,)
        Increasing parameters from 0 to 1.
    density : ndarray, shape (n_passes, m)
        Segments per unit ``t`` (``|X_t| / L``), > 0.

    Returns
    -------
    t : ndarray
        Parameters, each pass from 0 to 1 inclusive, passes concatenated.
    pass_id : ndarray of int
        The pass of each point.
    """
    grid = np.ascontiguousarray(t_grid, dtype=float)
    dens = np.ascontiguousarray(density, dtype=float)
    cum = np.empty(dens.shape)
    n_seg = np.empty(dens.shape[0], dtype=np.int64)
    _cumulate(grid, dens, cum, n_seg)
    counts = n_seg + 1
    pass_id = np.repeat(np.arange(dens.shape[0]), counts)
    t = np.empty(int(counts.sum()))
    _place(grid, cum, n_seg, t)
    return t, pass_id


@numba.njit(cache=True)
def _cumulate(t_grid, density, cum, n_seg):
    """Per pass the trapezoid integral of the density and its whole segments (at least 1)."""
    for p in range(density.shape[0]):
        cum[p, 0] = 0.0
        for i in range(1, t_grid.size):
            cum[p, i] = cum[p, i - 1] + 0.5 * (density[p, i] + density[p, i - 1]) * (
                t_grid[i] - t_grid[i - 1])
        n_seg[p] = max(math.ceil(cum[p, -1] - LIMIT_SLACK), 1)


@numba.njit(cache=True)
def _place(t_grid, cum, n_seg, out):
    """The ``n_seg[p] + 1`` points of each pass, ends exact, into ``out`` (passes in order)."""
    at = 0
    for p in range(cum.shape[0]):
        total = cum[p, -1]
        k = 0
        for j in range(n_seg[p] + 1):
            x = j * (total / n_seg[p])
            while k < t_grid.size - 2 and cum[p, k + 1] < x:
                k += 1
            span = cum[p, k + 1] - cum[p, k]
            slope = (t_grid[k + 1] - t_grid[k]) / span if span > 0.0 else 0.0
            out[at + j] = slope * (x - cum[p, k]) + t_grid[k]
        out[at] = t_grid[0]
        out[at + n_seg[p]] = t_grid[-1]
        at += n_seg[p] + 1


def pass_densities(t_grid: NDArray[np.float64], s_grid: NDArray[np.float64],
                   density: NDArray[np.float64], s_start: NDArray[np.float64],
                   s_end: NDArray[np.float64]) -> NDArray[np.float64]:
    """The grid's chord density along each pass, interpolated linearly in ``s``.

    Pass ``p`` runs from ``s_start[p]`` to ``s_end[p]`` as ``t`` goes from 0 to 1 (a
    spiral ring climbs). ``density`` has shape ``(t_grid.size, s_grid.size)``; returns
    ``(n_passes, t_grid.size)``.
    """
    out = np.empty((len(s_start), len(t_grid)))
    _pass_densities(np.ascontiguousarray(t_grid, dtype=float),
                    np.ascontiguousarray(s_grid, dtype=float),
                    np.ascontiguousarray(density, dtype=float),
                    np.ascontiguousarray(s_start, dtype=float),
                    np.ascontiguousarray(s_end, dtype=float), out)
    return out


@numba.njit(cache=True)
def _pass_densities(t_grid, s_grid, density, s_start, s_end, out):
    for p in range(out.shape[0]):
        level = s_start[p] == s_end[p]  # (a pass at one s: one segment for all of it)
        for i in range(t_grid.size):
            if i == 0 or not level:
                ss = s_start[p] + (s_end[p] - s_start[p]) * t_grid[i]
                j = segment_index(s_grid, ss)  # s_grid[j] <= ss < s_grid[j + 1], clamped
                w = (ss - s_grid[j]) / (s_grid[j + 1] - s_grid[j])
            out[p, i] = (1.0 - w) * density[i, j] + w * density[i, j + 1]


def split_evenly(lo: NDArray[np.float64], hi: NDArray[np.float64], parts: NDArray[np.int64]
                 ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """The points dividing each ``[lo[i], hi[i]]`` into ``parts[i]`` equal pieces.

    Returns the ``parts[i] - 1`` interior points of every interval, in order, and the
    interval each belongs to.
    """
    inner = np.asarray(parts, dtype=np.int64) - 1
    which = np.repeat(np.arange(inner.size), inner)
    k = np.arange(which.size) - np.repeat(np.cumsum(inner) - inner, inner) + 1
    return lo[which] + (hi[which] - lo[which]) * k / (inner[which] + 1), which


#: How many times over the normal's turn under the disc it must lean for the lowest point
#: to be sought near the rim point facing down the surface only (:func:`cutter_gap`).
TURN_MARGIN = 3.0
#: Poses per call of the disc search in :func:`cutter_gap` (its 33 samples per pose and
#: their Newton searches stay within a few hundred MB).
GAP_CHUNK = 100_000
#: Projections of the golden-section search along the rim (``refine_rim``): the bracket
#: of two sample steps shrinks to 0.618^10 of itself, under 0.3 deg.
RIM_REFINE_STEPS = 12
#: Points of the corner-circle disc tried by :func:`cutter_gap` for flat and bull-nose
#: cutters: 24 on its rim (15 deg apart, then refined), its centre and 8 at half radius.
_RIM = 24


def cutter_gap(surface: ParametricSurface, cutter: Cutter, tips_mm: NDArray[np.float64],
               axes: NDArray[np.float64], t0: NDArray[np.float64], s0: NDArray[np.float64],
               *, newton: int = 3, refine_rim: bool = False, chunk: int = GAP_CHUNK
               ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Signed gap between the cutter and the surface near ``(t0, s0)``, mm.

    The cutting end is every point within ``r`` of the disc of radius ``R - r`` at height
    ``r`` on the axis (a point, the ball centre, for a ball), so the gap is
    ``min over the disc of (K - X(K)) . n - r`` with ``X(K)`` the closest surface point of
    ``K``: positive where the cutter stands clear (material left), negative where it cuts
    into the surface. For a ball one projection. Otherwise the disc's centre is projected
    first: where the surface normal there leans off the axis clearly (more than the normal
    can turn under the disc), the lowest point is on the rim, facing down the surface, and
    5 rim points within 30 deg of that direction are projected and the lowest refined by a
    parabola. Elsewhere (a disc lying almost flat, whose minimum over a convex surface may
    lie inside, or a window whose lowest sample is at its end) the centre, 8 points at half
    its radius and 24 on its rim are projected, the rim minimum refined likewise. Last,
    the rim point facing down the surface at ``(t0, s0)`` (the expected contact) is
    tried. With ``refine_rim``, where the disc was scanned whole, the lowest rim point is
    then sought by golden section within one sample step either side
    (:data:`RIM_REFINE_STEPS` projections more): round an edge much tighter than the disc
    the distance dips over a few degrees of the rim, which neither the samples nor a
    parabola through them resolve. Flat and bull-nose cutters are measured ``chunk`` poses
    at a time (:data:`GAP_CHUNK`: the disc's samples of every pose at once would take
    gigabytes); the gaps do not depend on it.

    Returns
    -------
    gap_mm, t, s : ndarray
        The gap and the parameters of the closest surface point.
    """
    r = cutter.corner_radius_mm
    if cutter.kind is CutterKind.BALL:
        signed, t, s = signed_distance_near(surface, tips_mm + r * axes, t0, s0,
                                            iterations=newton)
        return signed - r, t, s
    if len(tips_mm) > chunk:  # the disc's samples, a chunk of poses at a time
        parts = [cutter_gap(surface, cutter, tips_mm[i:i + chunk], axes[i:i + chunk],
                            t0[i:i + chunk], s0[i:i + chunk], newton=newton,
                            refine_rim=refine_rim, chunk=chunk)
                 for i in range(0, len(tips_mm), chunk)]
        gap, t, s = (np.concatenate(x) for x in zip(*parts, strict=True))
        return gap, t, s
    disc = _Disc(surface, cutter, tips_mm, axes, newton + 1, (t0, s0))
    all_rows = np.arange(len(tips_mm))
    # the centre's foot point: its normal tells which rim point can touch
    d_c, t_c, s_c, n_c, k_c = disc.signed(disc.centre, t0, s0, all_rows, curvature=True,
                                          inner=np.ones(len(tips_mm), dtype=bool))
    lateral = n_c - np.einsum("ij,ij->i", n_c, axes)[:, None] * axes
    lean = np.linalg.norm(lateral, axis=1)
    # the rim point facing down the surface is the lowest when the normal leans clearly
    # everywhere under the disc: more than the normal can turn over it (curvature times
    # the disc's reach, three times over) and than 2 deg
    tilted = lean > np.maximum(TURN_MARGIN * k_c * (disc.radius + r),
                               np.sin(np.radians(2.0)))
    out = (d_c, t_c, s_c, np.full(len(tips_mm), np.nan))  # and the rim angle
    full = ~tilted
    rows = np.flatnonzero(tilted)
    if rows.size:
        phi0 = np.arctan2(-np.einsum("ij,ij->i", lateral[rows], disc.b2[rows]),
                          -np.einsum("ij,ij->i", lateral[rows], disc.b1[rows]))
        *found, inside = disc.rim_window(rows, phi0, t_c[rows], s_c[rows])
        _keep_lower(out, rows, found)
        full[rows[~inside]] = True  # the lowest sample at the window's end: scan it all
    scanned = np.flatnonzero(full)
    other_dip = None
    if scanned.size:
        found, other_dip = disc.scan(scanned, t0[scanned], s0[scanned])
        _keep_lower(out, scanned, found)
    # the rim point facing down the surface at the expected contact (t0, s0): round a
    # leading edge tighter than the disc, the distance along the rim dips there sharply,
    # between the samples above, and the centre's foot faces another way
    n_0 = surface.normal(t0, s0)
    lat_0 = n_0 - np.einsum("ij,ij->i", n_0, axes)[:, None] * axes
    phi_0 = np.arctan2(-np.einsum("ij,ij->i", lat_0, disc.b2),
                       -np.einsum("ij,ij->i", lat_0, disc.b1))
    _keep_lower(out, all_rows, (*disc.signed(disc.rim(all_rows, phi_0), t0, s0, all_rows),
                                phi_0))
    # only where the normal turns under the disc (the scanned rows): elsewhere the rim's
    # distance is smooth over a sample step and the parabola has it
    rows = np.flatnonzero(np.isfinite(out[3]) & full) if refine_rim else all_rows[:0]
    if rows.size:
        _keep_lower(out, rows, disc.golden_rim(rows, out[3][rows], out[1][rows],
                                               out[2][rows], 2.0 * np.pi / _RIM))
    # and round the rim's other dip: over an edge tighter than the disc the rim can dip
    # twice, the sharper dip the deeper though its samples read higher (dev_rotor_dca's
    # flat:6 5-axis job, a pose at the hub edge over the leading edge: the lowest sample
    # 0.071 mm off at 90 deg, the other dip's 0.074 mm at 30 deg, the contact at 22 deg)
    if refine_rim and other_dip is not None:
        angle, t_dip, s_dip = other_dip
        dips = np.flatnonzero(np.isfinite(angle))
        if dips.size:
            _keep_lower(out, scanned[dips], disc.golden_rim(
                scanned[dips], angle[dips], t_dip[dips], s_dip[dips], 2.0 * np.pi / _RIM))
    return out[0] - r, out[1], out[2]


def _off_normal_mm(reach_mm: NDArray[np.float64], along_mm: NDArray[np.float64]
                   ) -> NDArray[np.float64]:
    """How far a foot ``X`` lies off the normal through its point ``K``, mm.

    ``sqrt(|K - X|^2 - ((K - X) . n)^2)`` from ``reach_mm = |K - X|`` and ``along_mm =
    (K - X) . n`` (0 at a closest point; round-off never makes it imaginary).
    """
    return np.sqrt(np.maximum(reach_mm * reach_mm - along_mm * along_mm, 0.0))


class _Disc:
    """The corner-circle disc of a flat or bull-nose cutter at many poses (rows).

    Its centre ``r`` up the axis from each tip (``r`` the corner radius), its radius
    ``R - r``.
    """

    def __init__(self, surface: ParametricSurface, cutter: Cutter, tips_mm: NDArray[np.float64],
                 axes: NDArray[np.float64], iterations: int,
                 seeds: tuple[NDArray[np.float64], NDArray[np.float64]]) -> None:
        self.surface, self.cutter, self.tips, self.axes = surface, cutter, tips_mm, axes
        self.seeds = tuple(np.broadcast_to(np.asarray(x, dtype=float), (len(tips_mm),))
                           for x in seeds)  # (each pose's expected contact ``t``, ``s``)
        self.centre = tips_mm + cutter.corner_radius_mm * axes
        self.radius = cutter.radius_mm - cutter.corner_radius_mm
        self.iterations = iterations
        self.b1, self.b2 = disc_basis(axes)

    def signed(self, points: NDArray[np.float64], tt: NDArray[np.float64],
               ss: NDArray[np.float64], poses: NDArray[np.int64], *,
               curvature: bool = False, inner: NDArray[np.bool_] | None = None
               ) -> tuple[Any, ...]:
        """Signed distance of points to the surface and the foot's ``t, s``.

        ``poses``: each point's disc (row). ``inner``: the points inside the disc (not
        on its rim; None: none), whose deep readings from a face turned away are dropped
        (:meth:`_inner_reading`). A point past an open edge of the surface reads
        what its disc can cut there, the edge (:func:`~.open_edges.edge_readings`).
        With ``curvature=True`` also the foot's normal and largest absolute principal
        curvature (1/mm). On a closed surface the foot and distance are always
        :func:`~toolpath.planning.local.signed_distance_near`'s, whose seam rules search
        the seam's other face too (a disc centre beside a knife edge, its search started
        across the seam, read 1.4 mm inside the part from the far face).
        """
        if not curvature:
            signed, tt, ss = signed_distance_near(self.surface, points, tt, ss,
                                                  iterations=self.iterations)
            signed, tt, ss = self._stationary(points, signed, tt, ss, poses)
            if inner is not None:
                rows = np.flatnonzero(inner & (signed < -STATIONARY_MM))
                if rows.size:  # (the inner points' deep readings: few)
                    signed[rows] = self._inner_reading(
                        signed[rows], self.surface.normal(tt[rows], ss[rows]), poses[rows])
            return self._edges(points, tt, ss, signed, poses), tt, ss
        signed = None
        if self.surface.closed_t:
            signed, tt, ss = signed_distance_near(self.surface, points, tt, ss,
                                                  iterations=self.iterations)
            signed, tt, ss = self._stationary(points, signed, tt, ss, poses)
        else:
            tt, ss, _ = project_to_surface(self.surface, points, tt, ss,
                                           iterations=self.iterations)
            _, tt, ss = self._stationary(points, None, tt, ss, poses)
        f = self.surface.frame(tt, ss)
        if signed is None:
            signed = np.einsum("ij,ij->i", points - f.point, f.normal)
        if inner is not None:
            signed = np.where(inner, self._inner_reading(signed, f.normal, poses), signed)
        k_min, k_max = f.principal_curvatures()
        bend = np.nan_to_num(np.maximum(np.abs(k_min), np.abs(k_max)), nan=np.inf)
        return self._edges(points, tt, ss, signed, poses), tt, ss, f.normal, bend

    def _inner_reading(self, signed: NDArray[np.float64], normals: NDArray[np.float64],
                       poses: NDArray[np.int64]) -> NDArray[np.float64]:
        """Inner points' readings, ``inf`` where deep from a face turned away from the axis.

        The inner points: the disc's centre and those at half its radius. Inside the disc
        a point is lowest only where the surface lies almost level under it, a face turned
        towards the axis; and where a cutter cuts in, the deepest reading stands on a face
        turned towards it (the rim's readings have it). A deep reading from a face turned
        away that :meth:`_stationary`'s search again kept is a stationary point's that is
        no closest point: the flat:6 disc's centre beside dev_rotor_blunt's leading edge,
        0.48 mm clear, read 1.40 mm deep from the far face's nose, seeded at its rim's
        contact and again from there (the planner split that move into a stack of points
        reading 1.4 to 1.8 mm). Not the rim's points: one of those dropped can take the
        disc's lowest point with it.
        """
        return np.where((signed < -STATIONARY_MM)
                        & (np.einsum("ij,ij->i", normals, self.axes[poses]) <= 0.0),
                        np.inf, signed)

    def _stationary(self, points: NDArray[np.float64], signed: NDArray[np.float64] | None,
                    tt: NDArray[np.float64], ss: NDArray[np.float64], poses: NDArray[np.int64]
                    ) -> tuple[Any, NDArray[np.float64], NDArray[np.float64]]:
        """Readings whose foot is not a closest point, searched again.

        A foot ``X`` of ``K`` is a closest point only where ``K - X`` lies along the normal
        there. Round a leading edge thinner than the disc a point's Newton search can cycle
        between the two faces and stop anywhere (a flat:6 disc point 1.97 mm off its
        "foot", mostly sideways, read 0.084 mm inside the propeller's edge where the disc
        stands 0.001 mm deep): a foot off the normal by more than :data:`STATIONARY_MM` is
        searched again from the foot of the nearest point of the same disc whose foot is
        a closest point and reads no deeper than that (else from its own). And a foot on the
        normal may be the far face's, ``K`` lying behind its plane though outside the part
        (dev_rotor_blunt's bull:6:1 5-axis job read poses past the leading edge 3.1 mm deep
        from the far face, 0.01 mm clear): a reading more than :data:`STATIONARY_MM` inside
        from a face turned away from the tool axis (``n . a <= 0``; where a cutter cuts in,
        a face turned towards it is inside it too, so the deepest reading stands on one),
        or farther from ``K`` than its pose's expected contact is (a surface point nearer
        than the foot: round dev_rotor_blunt's 0.4 mm leading edge a flat:6 rim point
        0.005 mm off the surface found a foot on the edge's nose, on its normal, 0.83 mm
        off, whose face turns 83 deg from the axis: read 0.83 mm inside), is searched again
        likewise (else from its pose's expected contact), the new foot kept where it is
        nearer to ``K``; an off-normal one's where it is a closest point or nearer. Then
        what a neighbour's foot left doubtful, and every reading still deeper than
        :data:`STATIONARY_MM` whose foot lies beside the cutter's footprint (farther from
        the axis than its radius), is searched from the pose's expected contact too (once),
        kept where it is nearer (or a doubtful one's where it is no longer doubtful).
        ``signed`` (None: not read) and the feet are returned mended.
        """
        read = signed is not None
        if not read:
            x, normals = self.surface.points_and_normals(tt, ss)
            along = np.einsum("ij,ij->i", points - x, normals)
        else:  # (off the normal from |K - X| and the reading: the point alone, no normal)
            x, along, normals = self.surface(tt, ss), signed, None
        reach = row_lengths(points - x)
        off_normal, deep = self._doubtful(points, x, along, reach, normals, tt, ss, poses)
        bad = np.flatnonzero(off_normal | deep)
        beyond = (along < -STATIONARY_MM) & self._past_footprint(x, poses)
        if not bad.size and not beyond.any():
            return (signed if read else None), tt, ss
        seed_t, seed_s = tt[bad].copy(), ss[bad].copy()
        far = deep[bad]  # (without a neighbour: from the pose's expected contact)
        seed_t[far], seed_s[far] = self.seeds[0][poses[bad[far]]], self.seeds[1][poses[bad[far]]]
        good = np.flatnonzero(~off_normal & ~deep)
        good = good[np.argsort(poses[good], kind="stable")]
        first = np.searchsorted(poses[good], poses[bad], side="left")
        count = np.searchsorted(poses[good], poses[bad], side="right") - first
        has = count > 0  # (seeded from a neighbour's foot)
        if has.any():  # the same disc's good points, padded to the most
            block = first[:, None] + np.arange(count.max())[None, :]
            inside = np.arange(count.max())[None, :] < count[:, None]
            rows = good[np.where(inside, block, 0)]
            apart = np.where(inside, np.linalg.norm(points[rows] - points[bad][:, None, :],
                                                    axis=2), np.inf)
            near = rows[np.arange(bad.size), np.argmin(apart, axis=1)]
            seed_t[has], seed_s[has] = tt[near[has]], ss[near[has]]
        d2, t2, s2 = signed_distance_near(self.surface, points[bad], seed_t, seed_s,
                                          iterations=self.iterations + STATIONARY_EXTRA)
        x2 = self.surface(t2, s2)
        reach2 = row_lengths(points[bad] - x2)
        off2 = _off_normal_mm(reach2, d2)
        nearer = reach2 < reach[bad]
        take = np.where(far, nearer, (off2 <= STATIONARY_MM) | nearer)
        tt, ss = tt.copy(), ss.copy()
        signed = along.copy() if signed is None else signed.copy()
        rows = bad[take]
        tt[rows], ss[rows], signed[rows], reach[rows] = t2[take], s2[take], d2[take], reach2[take]
        x[rows] = x2[take]
        # from the pose's expected contact too: what is still doubtful after a search from
        # a neighbour's foot, and every reading still deep from a foot beside the cutter's
        # footprint (a closest point of the far face, or a stationary point that is none:
        # the nearest foot found decides). Round
        # a leading edge thinner than the disc, the feet of a tilted disc's far rim lie on
        # the far face or across the nose, as the window seeded at the centre's foot found
        # them: dev_rotor_blunt's flat:6 5-axis job (scallop 0.005 mm) read a pose that
        # touches the edge 1.07 mm deep, a rim point 0.78 mm deep from a face at 89 deg to
        # the axis, 0.09 mm clear
        from_contact = np.zeros(len(points), dtype=bool)
        from_contact[bad[far & ~has]] = True
        doubtful = np.zeros(len(points), dtype=bool)
        doubtful[bad[has]] = np.logical_or(*self._doubtful(
            points[bad[has]], x[bad[has]], signed[bad[has]], reach[bad[has]], None,
            tt[bad[has]], ss[bad[has]], poses[bad[has]]))
        beyond[bad] = (signed[bad] < -STATIONARY_MM) & self._past_footprint(x[bad], poses[bad])
        again = np.flatnonzero((doubtful | beyond) & ~from_contact)
        if again.size:
            d3, t3, s3 = signed_distance_near(
                self.surface, points[again], self.seeds[0][poses[again]],
                self.seeds[1][poses[again]], iterations=self.iterations + STATIONARY_EXTRA)
            x3 = self.surface(t3, s3)
            reach3 = row_lengths(points[again] - x3)
            sure = ~np.logical_or(*self._doubtful(points[again], x3, d3, reach3, None, t3,
                                                  s3, poses[again]))
            take = (sure & doubtful[again]) | (reach3 < reach[again])
            rows = again[take]
            tt[rows], ss[rows], signed[rows] = t3[take], s3[take], d3[take]
        return (signed if read else None), tt, ss

    def _past_footprint(self, x: NDArray[np.float64], poses: NDArray[np.int64]
                        ) -> NDArray[np.bool_]:
        """Feet ``x`` farther from their pose's axis than the cutter's radius.

        A deep reading where the cutter cuts in stands over the cut, within the cutter's
        footprint; one whose foot lies beside it may be a far face's.
        """
        rel = x - self.tips.take(poses, 0)
        axes = self.axes.take(poses, 0)
        rel -= np.einsum("ij,ij->i", rel, axes)[:, None] * axes
        return row_lengths(rel) > self.cutter.radius_mm

    def _doubtful(self, points: NDArray[np.float64], x: NDArray[np.float64],
                  along: NDArray[np.float64], reach: NDArray[np.float64],
                  normals: NDArray[np.float64] | None, tt: NDArray[np.float64],
                  ss: NDArray[np.float64], poses: NDArray[np.int64]
                  ) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
        """Feet ``x`` of ``points`` off the normal, and deep ones that may be no closest point.

        :meth:`_stationary`'s two tests: ``along`` is ``(K - X) . n``, ``reach``
        ``|K - X|``, ``normals`` the feet's (None: evaluated for the deep ones).
        """
        off = _off_normal_mm(reach, along)
        # (a foot on an open edge stands off the normal: the edge's rule reads it)
        inner = (ss > 0.0) & (ss < 1.0)
        if not self.surface.closed_t:
            inner &= (tt > 0.0) & (tt < 1.0)
        off_normal = (off > STATIONARY_MM) & inner
        deep = ~off_normal & (along < -STATIONARY_MM)
        if deep.any():  # (only a face turned from the tool: one it cuts faces it)
            rows = np.flatnonzero(deep)
            n = (normals[rows] if normals is not None
                 else self.surface.points_and_normals(tt[rows], ss[rows])[1])
            seed_nearer = reach[rows] > row_lengths(points[rows]
                                                    - self.seed_points.take(poses[rows], 0))
            deep[rows] = (np.einsum("ij,ij->i", n, self.axes[poses[rows]]) <= 0.0) | seed_nearer
        return off_normal, deep

    @functools.cached_property
    def seed_points(self) -> NDArray[np.float64]:
        """Each pose's expected contact on the surface (mm), from its seed ``t, s``."""
        return self.surface(*self.seeds)

    def _edges(self, points: NDArray[np.float64], tt: NDArray[np.float64],
               ss: NDArray[np.float64], signed: NDArray[np.float64],
               poses: NDArray[np.int64]) -> NDArray[np.float64]:
        """``signed`` with the points past an open edge read at the edge."""
        return edge_readings(self.surface, points, tt, ss, signed, self.cutter,
                             self.tips.take(poses, 0), self.axes.take(poses, 0))

    def rim(self, rows: NDArray[np.int64], angle: NDArray[np.float64]) -> NDArray[np.float64]:
        """Rim points at ``angle`` (rad, from ``b1`` towards ``b2``) of discs ``rows``."""
        return self.centre[rows] + self.radius * (np.cos(angle)[:, None] * self.b1[rows]
                                                  + np.sin(angle)[:, None] * self.b2[rows])

    def rim_window(self, rows: NDArray[np.int64], phi0: NDArray[np.float64],
                   tt: NDArray[np.float64], ss: NDArray[np.float64]) -> tuple[Any, ...]:
        """Lowest rim point within 30 deg of ``phi0`` (5 samples, then a parabola).

        Returns the distance, ``t``, ``s``, the rim angle and whether the lowest sample
        was inside the window (else the true minimum may lie beyond it).
        """
        offsets = np.radians([-30.0, -15.0, 0.0, 15.0, 30.0])
        n, k = rows.size, offsets.size
        angle = (phi0[:, None] + offsets[None, :]).ravel()
        poses = np.repeat(rows, k)
        d, t5, s5 = self.signed(self.rim(poses, angle), np.repeat(tt, k), np.repeat(ss, k),
                                poses)
        d, t5, s5 = d.reshape(n, k), t5.reshape(n, k), s5.reshape(n, k)
        j = np.argmin(d, axis=1)
        inside = (j > 0) & (j < k - 1)
        i = np.arange(n)
        out = d[i, j], t5[i, j], s5[i, j], phi0 + offsets[j]
        sel = np.flatnonzero(inside)
        if sel.size:
            js = j[sel]
            ang = _parabola_angle(d[sel, js - 1], d[sel, js], d[sel, js + 1],
                                  phi0[sel] + offsets[js], offsets[1] - offsets[0])
            _keep_lower(out, sel, (*self.signed(self.rim(rows[sel], ang), t5[sel, js],
                                                 s5[sel, js], rows[sel]), ang))
        return (*out, inside)

    def scan(self, rows: NDArray[np.int64], tt: NDArray[np.float64], ss: NDArray[np.float64]
             ) -> tuple[tuple[NDArray[np.float64], ...], tuple[NDArray[np.float64], ...]]:
        """Lowest point of the whole disc, by samples; and the rim's other dip.

        Its centre, 8 points at half radius and 24 on the rim; the rim minimum is refined
        by a parabola through its neighbours. Returns the distance, ``t``, ``s`` and the
        rim angle (NaN where the lowest point is inside the disc); and the angle, ``t``
        and ``s`` of the lowest rim sample lower than both its neighbours other than the
        rim's lowest (angle NaN: none).
        """
        phi = np.arange(_RIM) * (2.0 * np.pi / _RIM)
        inner = np.arange(8) * (np.pi / 4.0)
        offs = np.concatenate([np.stack([np.cos(phi), np.sin(phi)], 1) * self.radius,
                               [[0.0, 0.0]],
                               np.stack([np.cos(inner), np.sin(inner)], 1) * 0.5 * self.radius])
        m, k = rows.size, len(offs)
        pts = (self.centre[rows][:, None, :] + offs[None, :, 0, None] * self.b1[rows][:, None, :]
               + offs[None, :, 1, None] * self.b2[rows][:, None, :]).reshape(-1, 3)
        d, tt, ss = self.signed(pts, np.repeat(tt, k), np.repeat(ss, k), np.repeat(rows, k),
                                inner=np.tile(np.arange(k) >= _RIM, m))
        d, tt, ss = d.reshape(m, k), tt.reshape(m, k), ss.reshape(m, k)
        best = np.argmin(d, axis=1)
        i_all = np.arange(m)
        out = (d[i_all, best], tt[i_all, best], ss[i_all, best],
               np.where(best < _RIM, phi[np.minimum(best, _RIM - 1)], np.nan))
        i = np.flatnonzero(best < _RIM)
        if i.size:
            j = best[i]
            ang = _parabola_angle(d[i, (j - 1) % _RIM], d[i, j], d[i, (j + 1) % _RIM], phi[j],
                                  2.0 * np.pi / _RIM)
            _keep_lower(out, i, (*self.signed(self.rim(rows[i], ang), tt[i, j], ss[i, j],
                                              rows[i]), ang))
        rim = d[:, :_RIM]
        dips = np.where((rim < np.roll(rim, 1, axis=1)) & (rim < np.roll(rim, -1, axis=1)),
                        rim, np.inf)
        dips[i_all, np.argmin(rim, axis=1)] = np.inf
        j2 = np.argmin(dips, axis=1)
        other = (np.where(np.isfinite(dips[i_all, j2]), phi[j2], np.nan), tt[i_all, j2],
                 ss[i_all, j2])
        return out, other

    def golden_rim(self, rows: NDArray[np.int64], phi: NDArray[np.float64],
                   tt: NDArray[np.float64], ss: NDArray[np.float64], half_width: float
                   ) -> tuple[NDArray[np.float64], ...]:
        """Lowest rim point within ``half_width`` (rad) of ``phi``, by golden section.

        Returns the distance, ``t``, ``s`` and angle of the lowest point tried.
        """
        ratio = (np.sqrt(5.0) - 1.0) / 2.0
        lo, hi = phi - half_width, phi + half_width
        a, b = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
        fa, fb = (self.signed(self.rim(rows, x), tt, ss, rows) for x in (a, b))
        best = tuple(np.where(fa[0] <= fb[0], u, v) for u, v in zip((*fa, a), (*fb, b),
                                                                     strict=True))
        for _ in range(RIM_REFINE_STEPS - 2):
            left = fa[0] <= fb[0]  # the minimum lies in [lo, b]: drop (b, hi]
            hi = np.where(left, b, hi)
            lo = np.where(left, lo, a)
            new = np.where(left, hi - ratio * (hi - lo), lo + ratio * (hi - lo))
            f_new = self.signed(self.rim(rows, new), *best[1:3], rows)
            # left: (a, b) <- (new, a); right: (a, b) <- (b, new)
            fa, fb = (tuple(np.where(left, u, v) for u, v in zip(f_new, fb, strict=True)),
                      tuple(np.where(left, u, v) for u, v in zip(fa, f_new, strict=True)))
            a, b = np.where(left, new, b), np.where(left, a, new)
            lower = f_new[0] < best[0]
            best = tuple(np.where(lower, u, v) for u, v in zip((*f_new, new), best,
                                                               strict=True))
        return best


def _keep_lower(best: tuple[NDArray[np.float64], ...], rows: NDArray[np.int64],
                new: tuple[NDArray[np.float64], ...]) -> None:
    """Where ``new`` distances (first arrays) are lower at ``rows``, take them (in place)."""
    lower = new[0] < best[0][rows]
    for arr, value in zip(best, new, strict=True):
        arr[rows] = np.where(lower, value, arr[rows])


def _parabola_angle(before: NDArray[np.float64], here: NDArray[np.float64],
                    after: NDArray[np.float64], angle: NDArray[np.float64], spacing: float
                    ) -> NDArray[np.float64]:
    """Where the parabola through three equally spaced samples is lowest (within one step)."""
    den = before - 2.0 * here + after
    step = np.where(den > _LEAST_BEND_MM,
                    0.5 * (before - after) / np.where(den > _LEAST_BEND_MM, den, 1.0), 0.0)
    return angle + np.clip(step, -1.0, 1.0) * spacing


def _kernel_rows(u: NDArray[np.float64]) -> NDArray[np.float64]:
    """``u`` as a contiguous, writable float64 array for a compiled kernel.

    A read-only view (``np.broadcast_to`` of one move's fractions stays one when it is
    already contiguous) would compile the kernel a second time, for read-only arrays.
    """
    return np.require(u, dtype=np.float64, requirements=("C", "W"))


def _lerp(a: NDArray[np.float64], b: NDArray[np.float64], u: NDArray[np.float64]
          ) -> NDArray[np.float64]:
    """Rows ``a + u (b - a)``, every move with its fractions ``u`` (m, k), move by move.

    numpy (a move's few fractions at a time: a compiled loop saved less than loading it
    costs a fresh process, a few ms).
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    u = np.asarray(u, dtype=float)
    return (a[:, None, :] + u[:, :, None] * (b - a)[:, None, :]).reshape(-1, a.shape[1])


def _nlerp(a: NDArray[np.float64], b: NDArray[np.float64], u: NDArray[np.float64]
           ) -> NDArray[np.float64]:
    """:func:`_lerp` of unit vectors, normalized (the axis of a tip-linear move).

    A move whose end axes point opposite ways has no axis where the chord passes through
    zero: a ValueError names the move, not a division by zero further on.
    """
    out = _lerp(a, b, u)
    length = np.sqrt(out[:, 0] * out[:, 0] + out[:, 1] * out[:, 1] + out[:, 2] * out[:, 2])
    if not np.all(length > 0.0):
        move = int(np.flatnonzero(~(length > 0.0))[0]) // max(np.shape(u)[-1], 1)
        raise ValueError(f"move {move} of this chunk turns its tool axis half a turn: "
                         f"its end axes {np.asarray(a)[move]} and {np.asarray(b)[move]} "
                         "leave no axis between them to interpolate")
    out /= length[:, None]
    return out


#: Moves under a 5-axis machine's joint interpolation: the machine and the joints at the
#: moves' two ends, ``(machine, q_a, q_b)``.
JointEnds = tuple[Machine, NDArray[np.float64], NDArray[np.float64]]


class MoveEnds(NamedTuple):
    """The two ends of ``m`` moves: tips, tool axes (m, 3) and contacts' ``t, s`` (m,).

    The contacts start the Newton search at points inside the moves (:func:`move_gaps`).
    """

    tips_a: NDArray[np.float64]
    tips_b: NDArray[np.float64]
    axes_a: NDArray[np.float64]
    axes_b: NDArray[np.float64]
    t_a: NDArray[np.float64]
    t_b: NDArray[np.float64]
    s_a: NDArray[np.float64]
    s_b: NDArray[np.float64]

    def take(self, rows: NDArray[np.int64]) -> MoveEnds:
        """The moves ``rows``."""
        return MoveEnds(*(column[rows] for column in self))


def joint_moves(machine: Machine | None, joints: NDArray[np.float64] | None,
                idx: NDArray[np.int64]) -> JointEnds | None:
    """:func:`move_gaps`'s ``joints`` for moves ``idx -> idx + 1`` interpolated in ``joints``.

    None (tip-linear moves) when ``joints`` or ``machine`` is None.
    """
    if joints is None or machine is None:
        return None
    return machine, joints[idx], joints[idx + 1]


def move_poses(ends: MoveEnds, fractions: NDArray[np.float64], joints: JointEnds | None
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Tips and unit tool axes (m k, 3) at ``fractions`` (m, k) of each move, move by move.

    Tip linear and axis normalized-linear without ``joints``; with ``joints = (machine,
    q_a, q_b)`` the forward kinematics of the joints linear (as :func:`move_gaps`).
    """
    if joints is None:
        return (_lerp(ends.tips_a, ends.tips_b, fractions),
                _nlerp(ends.axes_a, ends.axes_b, fractions))
    machine, q_a, q_b = joints
    return forward(machine, _lerp(q_a, q_b, fractions))


def move_gaps(surface: ParametricSurface, cutter: Cutter, ends: MoveEnds,
              fractions: NDArray[np.float64], *, newton: int = 2, refine_rim: bool = False,
              joints: JointEnds | None = None,
              start: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Gaps of the cutter at ``fractions`` of each move.

    The cutter moves as the machine moves it: without ``joints``, tip linear and axis
    normalized-linear (a control interpolating the tool tip); with ``joints = (machine,
    q_a, q_b)``, the joints linear, the pose their forward kinematics (a 5-axis control
    without tool-centre-point interpolation, whose tip bows off the chord where the
    rotary axes turn). The Newton search starts between the ends' contacts
    ``(t_a, s_a)`` and ``(t_b, s_b)`` (across the seam the short way on closed sections).

    ``fractions`` are the same for every move (shape (k,)) or each move's own (m, k).
    ``newton`` and ``refine_rim`` go to :func:`cutter_gap`. ``start``: the ``t``, ``s``
    (m, k) to start the search from instead (nearer seeds the caller knows; the search
    converges to the same foot, in fewer steps).

    Returns
    -------
    gap, t, s : ndarray, shape (m, k)
    """
    m = len(ends.tips_a)
    u = np.asarray(fractions, dtype=float)
    u = np.broadcast_to(u, (m, u.shape[-1]))
    tips, axes = move_poses(ends, u, joints)
    if start is not None:
        t0, s0 = (np.asarray(x, dtype=float).ravel() for x in start)
    else:
        t0 = seam_lerp_rows(np.ascontiguousarray(ends.t_a, dtype=float),
                            np.ascontiguousarray(ends.t_b, dtype=float),
                            _kernel_rows(u), bool(surface.closed_t)).ravel()
        s0 = (ends.s_a[:, None] * (1.0 - u) + ends.s_b[:, None] * u).ravel()
    gap, t, s = cutter_gap(surface, cutter, tips, axes, t0, s0, newton=newton,
                           refine_rim=refine_rim)
    return gap.reshape(u.shape), t.reshape(u.shape), s.reshape(u.shape)


def point_move_gaps(surface: ParametricSurface, cutter: Cutter, tips_mm: NDArray[np.float64],
                    axes: NDArray[np.float64], t: NDArray[np.float64], s: NDArray[np.float64],
                    first: NDArray[np.int64], fractions: NDArray[np.float64], *,
                    newton: int = 2, refine_rim: bool = False, joints: JointEnds | None = None
                    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """:func:`move_gaps` of the moves ``first -> first + 1`` of a sequence of points.

    ``tips_mm``, ``axes``, ``t``, ``s`` are the points' (all of them); ``joints`` the
    moves' ends, as for :func:`move_gaps`. A ball moving tip-linear over a compiled
    surface is done in one compiled pass that never stores the poses
    (:meth:`~toolpath.compiled.StreamlineKernel.project_moves`: the same numbers);
    anything else by :func:`move_gaps` on the moves' ends.
    """
    kernel = surface.kernel()
    if kernel is not None and joints is None and cutter.kind is CutterKind.BALL:
        u = np.broadcast_to(np.asarray(fractions, dtype=float),
                            (len(first), np.shape(fractions)[-1]))
        t_out, s_out, gap = kernel.project_moves(
            Moves(tips_mm, axes, t, s, first, u, cutter.corner_radius_mm),
            kernel.search(newton, EXTRA_ITERATIONS, CONVERGED_MM, surface.orientation))
        return gap, t_out, s_out
    nxt = first + 1
    ends = MoveEnds(tips_mm[first], tips_mm[nxt], axes[first], axes[nxt], t[first], t[nxt],
                    s[first], s[nxt])
    return move_gaps(surface, cutter, ends, fractions, newton=newton, refine_rim=refine_rim,
                     joints=joints)


def chord_extremes(gaps: NDArray[np.float64], fractions: ArrayLike = CHORD_FRACTIONS, *,
                   end_slopes: NDArray[np.float64] | None = None, with_samples: bool = False
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64],
                              NDArray[np.float64], NDArray[np.float64]]:
    """Lowest and highest values of ``g(u) = u (1 - u)(a + b u + c u^2)`` on each move.

    The gap model vanishes at the move's ends (where the cutter touches the surface);
    three conditions fix its coefficients: the gaps measured at three ``fractions``, or,
    with ``end_slopes``, its slopes ``g'(0) = a`` and ``g'(1) = -(a + b + c)`` at the ends
    and one gap between them (:func:`ball_end_slopes`: no projection needed). A move can
    cut into the surface over one part and stand above it over another (an inflection of
    the pass, or a 5-axis move whose axis turns), so both extremes are returned: the first
    is checked against the chord tolerance, the second against the undercut allowance.

    Parameters
    ----------
    gaps : ndarray, shape (m, k)
        Gaps measured at the ``k`` ``fractions`` of each move (3, or 1 with
        ``end_slopes``; clipped to +-:data:`MODEL_GAP_CLIP_MM` for the model: a failed
        projection must not make it overflow).
    end_slopes : ndarray, shape (m, 2), optional
        ``g'(0)`` and ``g'(1)``, mm per unit ``u``.
    with_samples : bool
        The extremes also over the measured gaps themselves (where the model misses one;
        its ``u`` stays the model's).

    Returns
    -------
    low, u_low, high, u_high : ndarray, shape (m,)
        The model's smallest value on [0, 1] and where it is; its largest and where.
    """
    u = np.asarray(fractions, dtype=float).ravel()
    gaps = np.asarray(gaps, dtype=float).reshape(len(gaps), -1 if len(gaps) else u.size)
    basis = (u * (1.0 - u))[:, None] * np.stack([np.ones_like(u), u, u * u], axis=1)
    values = gaps
    if end_slopes is not None:
        basis = np.vstack([[1.0, 0.0, 0.0], basis, [-1.0, -1.0, -1.0]])
        values = np.column_stack([end_slopes[:, 0], gaps, end_slopes[:, 1]])
    if basis.shape != (3, 3):
        slopes = " and two end slopes" if end_slopes is not None else ""
        raise ValueError(f"the gap model takes three conditions, got {basis.shape[0]} "
                         f"({u.size} fractions{slopes})")
    out = np.empty((4, len(gaps)))
    run_in_threads(_model_extremes_rows, len(gaps), np.ascontiguousarray(values),
                   np.linalg.inv(basis), _GRID,
                   np.ascontiguousarray(gaps if with_samples else gaps[:, :0]), out)
    return out[0], out[1], out[2], out[3]


def ball_end_slopes(radius_mm: float, tips_mm: NDArray[np.float64], axes: NDArray[np.float64],
                    normals: NDArray[np.float64], first: NDArray[np.int64]
                    ) -> NDArray[np.float64]:
    """``g'(0)``, ``g'(1)`` of a ball's gap along the moves ``first -> first + 1``.

    The ball's centre ``C(u) = P(u) + R a(u) / |a(u)|`` (tip ``P`` and axis ``a`` linear
    in ``u``) stands ``R`` off the surface at the ends, over the contacts; its gap is the
    signed distance of ``C(u)`` less ``R``, whose gradient at an end is the surface's unit
    normal ``n`` there. So ``g' = n . C'`` with ``C' = dP + R (da - (a . da) a)`` at each
    end (``dP``, ``da``: the move's differences; ``|a| = 1`` at the ends):
    :func:`contact_end_slopes` with the contact on the axis.
    """
    return contact_end_slopes(radius_mm, tips_mm, axes, normals, np.zeros((0, 3)), first)


def contact_end_slopes(corner_mm: float, tips_mm: NDArray[np.float64],
                       axes: NDArray[np.float64], normals: NDArray[np.float64],
                       off_axis_mm: NDArray[np.float64], first: NDArray[np.int64]
                       ) -> NDArray[np.float64]:
    """``g'(0)``, ``g'(1)`` of a cutter's gap along tip-linear moves ``first -> first + 1``.

    The gap is ``g(u) = min over K of dist(K, surface) - r``, ``K`` over the disc of
    radius ``R - r`` at height ``r = corner_mm`` on the axis (the ball's centre alone
    where ``r = R``). Where the lowest ``K*`` is a strict minimum, by the envelope theorem
    ``g'`` is the rate of ``dist`` at ``K*`` held on the moving cutter: ``n . dK*/du``,
    ``n`` the unit normal at its foot. The cutter moves with its tip, ``dP``, and turns
    its axis at ``a' = da - (a . da) a`` (normalized-linear, ``|a| = 1`` at the ends), a
    rotation ``a x a'`` (the spin about the axis moves ``K*`` along the disc, where
    ``dist`` is stationary); with ``K* - P = r a + d`` (``d = off_axis_mm`` per location,
    in the disc's plane; empty: on the axis, every row):

        ``g' = n . (dP + r a') - (n . a)(a' . d)``.

    Valid where ``K*`` moves continuously with ``u``; where it jumps across the disc
    (two lowest points, a flat face level with the surface) ``g`` has a kink there.
    """
    out = np.empty((len(first), 2))
    _contact_end_slopes(float(corner_mm), np.ascontiguousarray(tips_mm, dtype=float),
                        np.ascontiguousarray(axes, dtype=float),
                        np.ascontiguousarray(normals, dtype=float),
                        np.ascontiguousarray(off_axis_mm, dtype=float),
                        np.ascontiguousarray(first, dtype=np.int64), out)
    return out


@numba.njit(cache=True)
def _contact_end_slopes(corner, tips, axes, normals, off_axis, first, out):
    # scalars, one row after the other: a few dozen flops a row, where the differences
    # as arrays (two allocations a row) and numba's parallel loop cost 250 ns a row
    on_axis = off_axis.shape[0] == 0
    for j in range(first.size):
        i = first[j]
        for col in range(2):
            c = i + col
            along = 0.0
            for k in range(3):
                along += axes[c, k] * (axes[i + 1, k] - axes[i, k])
            slope = 0.0
            tilt = 0.0  # a' . d
            lean = 0.0  # n . a
            for k in range(3):
                turn = (axes[i + 1, k] - axes[i, k]) - along * axes[c, k]
                slope += ((tips[i + 1, k] - tips[i, k]) + corner * turn) * normals[c, k]
                if not on_axis:
                    tilt += turn * off_axis[c, k]
                    lean += normals[c, k] * axes[c, k]
            out[j, col] = slope - lean * tilt


@numba.njit(cache=True, inline="always")
def _gap_model(u, a, b, c):
    """``g(u) = u (1 - u)(a + b u + c u^2)``."""
    return u * (1.0 - u) * (a + b * u + c * u * u)


#: The measured gaps enter the move's model clipped to +- this, mm: a failed projection
#: (a gap of a metre or ``inf``) must not make the cubic's coefficients overflow, and a
#: clipped gap still exceeds any tolerance by far.
MODEL_GAP_CLIP_MM = 1e3


@numba.njit(cache=True, nogil=True)
def _model_extremes_rows(values, inverse, n_grid, samples, out, first, stop):
    """Per row: ``out[0:2]`` the model's lowest value and where, ``out[2:4]`` its highest.

    Rows ``first .. stop - 1`` (slices of them in threads: :func:`run_in_threads`).
    The model's coefficients are ``inverse @ values[i]`` (clipped to
    +-:data:`MODEL_GAP_CLIP_MM`). Its
    extremes are at the ends (0) or where ``g'`` (a cubic) vanishes: ``g'`` is sampled at
    ``n_grid`` points on [0, 1] and each sign change solved by bracketed Newton steps
    (every bump and dip, beside an end too; two roots within one step, a wiggle of no
    depth, would cancel). The extremes also over ``samples[i]`` (none: no columns).
    """
    step = 1.0 / (n_grid - 1)
    for i in range(first, stop):
        a = b = c = 0.0
        for k in range(3):
            g = min(max(values[i, k], -MODEL_GAP_CLIP_MM), MODEL_GAP_CLIP_MM)
            a += inverse[0, k] * g
            b += inverse[1, k] * g
            c += inverse[2, k] * g
        low = high = at_low = at_high = 0.0  # the ends: g(0) = g(1) = 0
        before = _gap_slope(0.0, a, b, c)
        # (a model of nothing but round-off has no extremes worth a search)
        for j in range(1 if max(abs(a), abs(b), abs(c)) > _ROUND_OFF_MODEL_MM else n_grid, n_grid):
            x = j * step
            after = _gap_slope(x, a, b, c)
            if (before < 0.0) != (after < 0.0) or before == 0.0:
                u = _stationary(x - step, x, before, after, a, b, c)
                value = _gap_model(u, a, b, c)
                if value < low:
                    low, at_low = value, u
                if value > high:
                    high, at_high = value, u
            before = after
        for k in range(samples.shape[1]):
            low = min(low, samples[i, k])
            high = max(high, samples[i, k])
        out[0, i], out[1, i], out[2, i], out[3, i] = low, at_low, high, at_high


@numba.njit(cache=True, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _gap_slope(u, a, b, c):
    """``g'(u) = (1 - 2u) p + (u - u^2) p'`` with ``p = a + b u + c u^2``."""
    return (1.0 - 2.0 * u) * (a + b * u + c * u * u) + (u - u * u) * (b + 2.0 * c * u)


@numba.njit(cache=True, inline="always")
def _stationary(lo, hi, slope_lo, slope_hi, a, b, c):
    """The root of ``g'`` in ``[lo, hi]``, where it changes sign (Newton, kept bracketed).

    From the secant's root; a Newton step leaving the bracket is replaced by halving it;
    done when a step moves ``u`` by under ``ROUND_OFF`` (the value is then exact to
    round-off).
    """
    den = slope_lo - slope_hi
    x = lo + (hi - lo) * slope_lo / den if den != 0.0 else 0.5 * (lo + hi)
    for _ in range(40):
        slope = _gap_slope(x, a, b, c)
        if slope == 0.0 or hi - lo < ROUND_OFF:
            break
        if (slope < 0.0) == (slope_lo < 0.0):
            lo, slope_lo = x, slope
        else:
            hi = x
        p = a + b * x + c * x * x
        dp = b + 2.0 * c * x
        curve = -2.0 * p + 2.0 * (1.0 - 2.0 * x) * dp + 2.0 * c * (x - x * x)
        nxt = x - slope / curve if curve != 0.0 else 0.5 * (lo + hi)
        if abs(nxt - x) < ROUND_OFF:
            return nxt
        x = nxt if lo < nxt < hi else 0.5 * (lo + hi)
    return x
