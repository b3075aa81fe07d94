"""Scallop and chord error measured on a finished toolpath, independently of the planner.

Nothing here uses the planner's curvature formulas or its internal parameters: only the
toolpath's arrays (tips, axes, kinds, passes), the surface and the cutter solid.

**Chord error.** Every cutter location on a cutting move is first projected onto the
surface (Newton from the nearest of a grid of surface samples; a ball's, at every fourth
location along a run of moves, the others from those contacts interpolated, and from their
own nearest sample where the feet either side jumped or the foot found stands farther off
than theirs; a foot farther than the sample nearest its point is searched again from
there): its gap checks that it touches. A flat or bull-nose cutter's lowest rim point is
sought finely everywhere (``refine_rim`` of :func:`~toolpath.planning.sampling.cutter_gap`).
Then the cutter is placed at ``u = 1/4, 1/2, 3/4`` of each move (tip linear,
axis normalized-linear, as a 5-axis control with tool-centre-point interpolation moves
it; for a toolpath checked under a 5-axis machine's joint interpolation, its joints
linear, as that machine moves it), and, on the
moves that could hold the largest deviation (a model extreme at least
half the largest sample), once more where a smooth model through those gaps is lowest and
where it is highest; its signed
gap to the surface is measured: ``gap = dist(K, surface) - r`` with ``K`` the corner-circle
centre projected onto the surface.

**Scallop.** At a surface point ``Q`` with normal ``n`` the height of the machined surface
is the distance along ``n`` at which the ray ``Q + l n`` enters the material removed by
the cutter: for a ball, exactly, the union of capsules swept by the ball centre along each
feed move (cut in pieces of ``R/8``, their ends placed as the control places them: under a
5-axis machine's joint interpolation, by its forward kinematics); for flat and bull-nose
cutters, the union of the cutter solid over the poses of each piece (tip linear, axis
normalized-linear), the ray met at each pose exactly and the earliest pose found by search
(:mod:`.sweep_kernel`; a straight sweep of the cutter's cross-section would carry its
points ahead of and behind the contact under ``Q`` even where the axis turns them away,
round a tight leading edge). Heights beyond the horizon (10 times the request, at least
0.05 mm) count as *uncut*. The cusps are searched from every contact point and every
mid-chord contact standing above the surface found by the chord measurement, at fixed
``t``, towards increasing ``s``, over 2.5 times the distance from the contact to the
nearest contact of another pass: the height ``h_own(s)`` left by the contact's own pass
rises from 0 and the height ``h_other(s)`` left by the other passes falls to 0 at the next
pass; the cusp is where they cross (a sign change found on 3 samples over the bracket,
then closed by regula falsi with the Illinois rule, :mod:`.roots`), its height
``min(h_own, h_other)``. A contact with no
pass within that bracket borders an uncut area and has no cusp. A coarse grid (spacing
half the cutter radius along ``t``, one stepover across) gives the uncut area; distances
from it are taken along the surface (shortest paths over the grid), round a thin part's
edges rather than through it.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import scipy.sparse
import scipy.sparse.csgraph
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from machines import Machine
from machines.kinematics import forward, solve_inverse

from ..joint_refine import joints_checked, machine_key
from ..path import MoveKind, Toolpath
from ..projection_kernel import seam_lerp_rows
from ..surface import ParametricSurface, outward_normals
from ..tolerances import LENGTH_SLACK_MM, ROUND_OFF, TINY
from ..vectors import move_axes, move_poses, unit
from .clearance_kernel import SampleCells, bin_samples, pairs_within
from .cusp_kernel import RIDGE_FOUND, RIDGE_NO_PASS, RIDGE_OPEN, nearest_pieces, ridges
from .cutters import Cutter, CutterKind, radial_directions
from .gouge import SurfaceSamples
from .roots import illinois_roots
from .sampling import (
    CHORD_FRACTIONS,
    JointEnds,
    MoveEnds,
    chord_extremes,
    cutter_gap,
    move_gaps,
)
from .sweep_kernel import (
    capsule_entries,
    nearest_entries,
    piece_ends,
    ray_ranges,
    segment_distances,
    tip_plane_floors,
)
from .torus_profile import profile_ridges

__all__ = ["ChordMeasurement", "CutVolume", "ScallopMeasurement", "SeedCusps", "cusp_horizon_mm",
           "measure_chord", "measure_scallop", "seed_cusps", "split_moves"]

@dataclass(frozen=True)
class ChordMeasurement:
    """Largest deviations of the cutter from the surface along cutting moves, mm.

    ``overcut_mm`` is the deepest cut into the surface (>= 0), ``undercut_mm`` the largest
    gap left above it (>= 0), ``max_mm`` the larger; ``worst_point`` the toolpath point the
    worst move arrives at; ``contact_mm`` the largest ``|gap|`` at the cutter locations.
    """

    max_mm: float
    overcut_mm: float
    undercut_mm: float
    worst_point: int
    contact_mm: float
    n_moves: int
    seeds_t: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0), repr=False)
    seeds_s: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0), repr=False)
    seeds_pass: NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64),
                                          repr=False)


#: The last toolpath's checked joints (a weak reference to it, the machine key, the
#: joints): the chord and the scallop measurement of one plan solve them once.
_JOINTS_SOLVED: list[tuple[weakref.ref[Toolpath], str, NDArray[np.float64]]] = []


def _checked_joints(toolpath: Toolpath, machine: Machine | None
                    ) -> NDArray[np.float64] | None:
    """Joints of every point if ``toolpath`` was checked under ``machine``'s interpolation.

    (``Toolpath.joints_checked_for``: the post then leaves its cutting moves whole).
    None otherwise.
    """
    if machine is None or not joints_checked(toolpath, machine):
        return None
    key = machine_key(machine)
    for ref, known, joints in _JOINTS_SOLVED:
        if ref() is toolpath and known == key:
            return joints
    joints = solve_inverse(machine, toolpath.positions_mm, toolpath.tool_axes).joints
    _JOINTS_SOLVED[:] = [(weakref.ref(toolpath), key, joints)]
    return joints


#: A ball's contacts along a run of cutting moves are searched from the nearest surface
#: sample at every this many locations (and at the run's last); the others from those
#: contacts (:func:`_run_anchors`), unless the guard of :func:`_unsure_between` sends them
#: back to their own sample: the same feet, in about a quarter of the k-d tree's queries.
CONTACT_STRIDE = 4

#: Where the closest surface point moves continuously with the ball's centre, it moves at
#: most ``rho / (rho - d)`` times as far (``rho`` the surface's concave radius along the
#: motion, ``d`` the centre's distance, about the ball radius; on convex parts less than
#: the centre). Anchors' feet farther apart than this many times the centres' path between
#: them: the closest point jumped (across a groove, between two sheets) or the surface
#: curves concavely tighter than twice the distance, and seeds interpolated between those
#: feet can start in another local minimum's basin (:func:`_unsure_between`).
FOOT_SPREAD = 2.0

#: Newton steps for a ball's contact, then more while a step still moves the foot by over
#: :data:`~.local.CONVERGED_MM` (from the nearest sample, three leave the gap within
#: 1e-12 mm of six on the dev blade).
BALL_CONTACT_NEWTON = 3


def measure_chord(toolpath: Toolpath, surface: ParametricSurface, cutter: Cutter,
                  samples: SurfaceSamples, *, machine: Machine | None = None,
                  chunk: int = 100_000, contact_stride: int = CONTACT_STRIDE
                  ) -> ChordMeasurement:
    """Measure the chord error of ``toolpath`` (module docstring).

    With the 5-axis ``machine`` whose joint interpolation the toolpath was checked under
    (``Toolpath.joints_checked_for``: the post then leaves them whole), the cutter inside
    each move is placed as that interpolation places it (the tip bows off the chord
    where rotary axes turn). ``contact_stride``: a ball's contacts searched from the
    nearest surface sample at every this many locations along a run of cutting moves,
    the others from theirs (:func:`_run_anchors`) unless their foot may be a wrong local
    one (:func:`_unsure_between`); 1: every one from its sample, the full method.
    """
    joints = _checked_joints(toolpath, machine)
    move = _cutting_moves(toolpath)
    if not move.size:
        return ChordMeasurement(0.0, 0.0, 0.0, -1, 0.0, 0)
    contacts = _end_contacts(toolpath, surface, cutter, samples, move, chunk, contact_stride)
    contact = float(np.abs(contacts.gap).max())
    worst = np.zeros(move.size)
    over = under = 0.0
    seeds: list[tuple[NDArray[np.float64], ...]] = []
    for lo in range(0, move.size, chunk):
        seg = move[lo:lo + chunk]
        ends, gap_a, gap_b = contacts.of_moves(toolpath, seg)
        interpolation = None if joints is None else (machine, joints[seg], joints[seg + 1])
        gap, g3, t3, s3 = _move_chunk_gaps(surface, cutter, ends, gap_a, gap_b,
                                           max(contact, over, under), interpolation)
        worst[lo:lo + len(seg)] = np.abs(gap).max(axis=1)
        over = max(over, float(-gap.min()))
        under = max(under, float(gap.max()))
        seeds.append(_cusp_seeds(surface, ends, g3, t3, s3, toolpath.pass_index[seg]))
    i = int(np.argmax(worst))
    seeds_t, seeds_s, seeds_p = (np.concatenate(column) for column in zip(*seeds, strict=True))
    return ChordMeasurement(max_mm=float(worst[i]), overcut_mm=max(over, 0.0),
                            undercut_mm=max(under, 0.0), worst_point=int(move[i] + 1),
                            contact_mm=contact, n_moves=int(move.size), seeds_t=seeds_t,
                            seeds_s=seeds_s, seeds_pass=seeds_p.astype(np.int64))


def _cutting_moves(toolpath: Toolpath) -> NDArray[np.int64]:
    """First points of the cutting moves from a point of a pass to a point of a pass."""
    kinds, passes = toolpath.kinds, toolpath.pass_index
    return np.flatnonzero((kinds[1:] == MoveKind.CUT) & (passes[1:] >= 0) & (passes[:-1] >= 0))


@dataclass(frozen=True)
class _EndContacts:
    """The contact of the cutter at every point ``points`` ending a cutting move."""

    points: NDArray[np.int64]
    gap: NDArray[np.float64]
    t: NDArray[np.float64]
    s: NDArray[np.float64]

    def of_moves(self, toolpath: Toolpath, first: NDArray[np.int64]
                 ) -> tuple[MoveEnds, NDArray[np.float64], NDArray[np.float64]]:
        """Moves ``first -> first + 1``: their ends with the contacts, and the ends' gaps."""
        ia = np.searchsorted(self.points, first)
        ib = ia + 1
        pos, axes = toolpath.positions_mm, toolpath.tool_axes
        ends = MoveEnds(pos[first], pos[first + 1], axes[first], axes[first + 1],
                        self.t[ia], self.t[ib], self.s[ia], self.s[ib])
        return ends, self.gap[ia], self.gap[ib]


def _end_contacts(toolpath: Toolpath, surface: ParametricSurface, cutter: Cutter,
                  samples: SurfaceSamples, move: NDArray[np.int64], chunk: int,
                  stride: int) -> _EndContacts:
    """The contact of every cutter location on a cutting move ``move``, once.

    Seeded by the surface sample nearest to the cutter's centre (ball) or corner-circle
    centre on the axis (:func:`_contact_gaps`), ``chunk`` locations at a time. A ball's
    locations between the anchors :func:`_run_anchors` picks (every ``stride``-th) are
    seeded from the anchors' contacts instead, interpolated along the run (as
    :func:`~.sampling.move_gaps` seeds the points inside a move): a k-d tree query of a
    point a radius off the surface costs several times its Newton search. Those whose
    foot may be a wrong local one (:func:`_unsure_between`) are then searched from their
    own nearest sample after all.
    """
    pos, axes = toolpath.positions_mm, toolpath.tool_axes
    at_end = np.zeros(len(toolpath.kinds), dtype=bool)
    at_end[move] = at_end[move + 1] = True
    ends = np.flatnonzero(at_end)
    ball = cutter.kind is CutterKind.BALL
    lift = cutter.radius_mm if ball else cutter.corner_radius_mm
    centres = pos[ends] + lift * axes[ends]
    runs = _run_anchors(ends, move, centres, stride if ball else 1)
    gap, t, s = np.empty(ends.size), np.empty(ends.size), np.empty(ends.size)

    def search_from_samples(rows: NDArray[np.int64]) -> None:
        _, nearest = samples.tree.query(centres[rows], k=1, workers=-1)
        for lo in range(0, rows.size, chunk):
            part = rows[lo:lo + chunk]
            gap[part], t[part], s[part] = _contact_gaps(
                surface, cutter, samples, pos[ends[part]], axes[ends[part]],
                nearest[lo:lo + chunk])

    search_from_samples(runs.anchor)
    between, before, after, w = runs.between, runs.before, runs.after, runs.w
    if between.size:
        t0 = seam_lerp_rows(t[before], t[after], w[:, None], bool(surface.closed_t)).ravel()
        s0 = s[before] + w * (s[after] - s[before])
        gap[between], t[between], s[between] = cutter_gap(
            surface, cutter, pos[ends[between]], axes[ends[between]], t0, s0,
            newton=BALL_CONTACT_NEWTON)
        unsure = _unsure_between(surface, runs, centres, gap, t, s)
        if unsure.size:
            search_from_samples(unsure)
    return _EndContacts(ends, gap, t, s)


def _unsure_between(surface: ParametricSurface, runs: _Runs, centres: NDArray[np.float64],
                    gap: NDArray[np.float64], t: NDArray[np.float64], s: NDArray[np.float64]
                    ) -> NDArray[np.int64]:
    """The locations between anchors whose seeded foot may be a wrong local one.

    A ball's foot searched from the anchors' interpolated contacts is a local minimum of
    the distance from its centre; it is the closest point where the anchors' feet lie on
    one smooth stretch of the surface and the foot map between them is near linear. Three
    signs that it is not:

    * a foot found for a location next to it along the run, or for either anchor, lies
      nearer to its centre than its own foot (by more than :data:`FOOT_SLACK_MM`): its
      own is then not the closest point, for certain;
    * the anchors' feet lie farther apart than :data:`FOOT_SPREAD` times the centres'
      path between them: the closest point jumped, and the interpolated seeds may lie on
      the wrong side of the jump (the whole stride is unsure);
    * the gap found stands above both anchors' by more than :data:`FOOT_SLACK_MM`: a
      foot farther than its neighbours' (a wrong local minimum, or a location the
      planner lifted over something between the anchors).

    Any of them sends the location back to its own nearest sample (the full method).
    Rows index ``centres``, ``gap``, ``t``, ``s`` (every location).
    """
    between, before, after = runs.between, runs.before, runs.after
    feet = surface(t, s)
    here = centres[between]
    own = np.linalg.norm(here - feet[between], axis=1)
    # the run's locations are consecutive rows: between - 1 and between + 1 are on it
    nearer = np.zeros(between.size, dtype=bool)
    for other in (before, after, between - 1, between + 1):
        nearer |= np.linalg.norm(here - feet[other], axis=1) < own - FOOT_SLACK_MM
    spread = np.linalg.norm(feet[after] - feet[before], axis=1)
    jump = spread > FOOT_SPREAD * runs.span + FOOT_SLACK_MM
    rise = gap[between] > np.maximum(gap[before], gap[after]) + FOOT_SLACK_MM
    return between[nearer | jump | rise]


class _Runs(NamedTuple):
    """Anchors along runs of cutting moves and how the locations between follow them.

    ``anchor``: the locations with a seed of their own; ``between``: the others, each
    with the anchors ``before`` and ``after`` it, its share ``w`` of the way between
    them and the length ``span`` of the centres' path between them (mm).
    """

    anchor: NDArray[np.int64]
    between: NDArray[np.int64]
    before: NDArray[np.int64]
    after: NDArray[np.int64]
    w: NDArray[np.float64]
    span: NDArray[np.float64]


def _run_anchors(ends: NDArray[np.int64], move: NDArray[np.int64],
                 centres: NDArray[np.float64], stride: int) -> _Runs:
    """Which of the locations ``ends`` get a seed of their own, and how the others do.

    Locations ``j`` and ``j + 1`` of ``ends`` joined by a cutting move ``move`` run on;
    along each run every ``stride``-th location and the last are anchors. Returns the
    anchors, the others, the anchors before and after each other one, its share ``w`` of
    the way between them along the path of ``centres`` and that path's length.
    """
    n = ends.size
    if stride <= 1 or n < 2:
        empty = np.zeros(0, dtype=np.int64)
        return _Runs(np.arange(n), empty, empty, empty, np.zeros(0), np.zeros(0))
    starts = np.zeros(int(ends[-1]) + 1, dtype=bool)
    starts[move] = True
    broken = np.concatenate([[True], ~starts[ends[:-1]]])  # a run starts here
    run = np.cumsum(broken) - 1
    first = np.flatnonzero(broken)
    last = np.append(first[1:], n) - 1
    rank = np.arange(n) - first[run]
    anchor = (rank % stride == 0) | (np.arange(n) == last[run])
    between = np.flatnonzero(~anchor)
    before = between - rank[between] % stride
    after = np.minimum(before + stride, last[run[between]])
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(centres, axis=0), axis=1))])
    span = arc[after] - arc[before]
    w = np.where(span > 0.0, (arc[between] - arc[before]) / np.where(span > 0.0, span, 1.0),
                 (between - before) / (after - before))
    return _Runs(np.flatnonzero(anchor), between, before, after, w, span)


def _move_chunk_gaps(surface: ParametricSurface, cutter: Cutter, ends: MoveEnds,
                     gap_a: NDArray[np.float64], gap_b: NDArray[np.float64], top_mm: float,
                     joints: JointEnds | None) -> tuple[NDArray[np.float64], ...]:
    """Gaps along moves: at both ends, at ``CHORD_FRACTIONS`` and at the model's extremes.

    Measured at three places, then once more where the gap model through them is lowest
    and where it is highest (:func:`~.sampling.chord_extremes`), on the moves whose
    extreme could be the largest: within half of the largest gap so far (``top_mm`` and
    the three places'). ``joints``: the moves' ends under a machine's joint
    interpolation, as for :func:`~.sampling.move_gaps`.

    Returns ``gap`` (m, 7: end, three places, lowest, highest, end) and the three places'
    gaps, ``t`` and ``s`` (m, 3).
    """
    u = np.asarray(CHORD_FRACTIONS, dtype=float)
    m = len(gap_a)
    g3, t3, s3 = move_gaps(surface, cutter, ends, u, newton=2, refine_rim=True, joints=joints)
    low, u_low, high, u_high = chord_extremes(g3, u)
    top = max(float(np.abs(g3).max()), top_mm)
    g_star = np.zeros((m, 2))
    for col, (value, u_at) in enumerate(((low, u_low), (high, u_high))):
        sel = np.flatnonzero(np.abs(value) >= 0.5 * top)
        if sel.size:
            g_star[sel, col] = move_gaps(surface, cutter, ends.take(sel), u_at[sel, None],
                                         newton=2, refine_rim=True,
                                         joints=_joint_rows(joints, sel))[0][:, 0]
    gap = np.concatenate([gap_a[:, None], g3, g_star, gap_b[:, None]], axis=1)
    return gap, g3, t3, s3


def _joint_rows(joints: JointEnds | None, rows: NDArray[np.int64]) -> JointEnds | None:
    """The moves ``rows`` of moves' ends under joint interpolation (None stays None)."""
    return None if joints is None else (joints[0], joints[1][rows], joints[2][rows])


def _cusp_seeds(surface: ParametricSurface, ends: MoveEnds, g3: NDArray[np.float64],
                t3: NDArray[np.float64], s3: NDArray[np.float64], passes: NDArray[np.int32]
                ) -> tuple[NDArray[np.float64], ...]:
    """Where the scallop search starts: ``t``, ``s`` and pass of each seed.

    The cusps are highest where the moves stand highest: at the contacts (each move's
    first), and at the middle of the moves that stand above the surface there.
    """
    mid = int(np.argmin(np.abs(np.asarray(CHORD_FRACTIONS, dtype=float) - 0.5)))
    tc = np.concatenate([ends.t_a[:, None], t3[:, mid:mid + 1]], axis=1)
    sc = np.concatenate([ends.s_a[:, None], s3[:, mid:mid + 1]], axis=1)
    use = np.stack([np.ones(len(tc), dtype=bool), g3[:, mid] > 0.0], axis=1)
    seeds_t = np.mod(tc, 1.0)[use] if surface.closed_t else tc[use]
    return seeds_t, sc[use], np.broadcast_to(passes[:, None], use.shape)[use]


#: A flat or bull-nose contact's foot farther from its corner-circle centre than the
#: sample nearest to that centre by more than this (mm) is not its closest point: a
#: micrometre, above the Newton search's residual on the foot and far below any chord
#: tolerance (:func:`_contact_gaps`).
FOOT_SLACK_MM = 1e-6


def _contact_gaps(surface: ParametricSurface, cutter: Cutter, samples: SurfaceSamples,
                  tips_mm: NDArray[np.float64], axes: NDArray[np.float64],
                  seeds: NDArray[np.int64]) -> tuple[NDArray[np.float64], ...]:
    """Gap, ``t`` and ``s`` of the cutter at each location, searched from sample ``seeds``.

    A foot found farther from its cutter point ``K = X + (gap + r) n`` than the sample
    nearest to ``K`` is not its closest point (that sample is a surface point nearer to
    ``K``): round a thin edge a search started on the
    far side ends there, and a flat cutter's rim just clear of the near side then reads
    as cutting through the part. Those locations are searched again from the sample
    nearest to ``K`` (twice at most).
    """
    r = cutter.corner_radius_mm
    ball = cutter.kind is CutterKind.BALL
    gap, t, s = cutter_gap(surface, cutter, tips_mm, axes, samples.t[seeds], samples.s[seeds],
                           newton=BALL_CONTACT_NEWTON if ball else 6, refine_rim=True)
    if ball:
        return gap, t, s
    rows = np.arange(len(tips_mm))
    for _ in range(2):
        x, n = surface.points_and_normals(t[rows], s[rows])
        k = x + (gap[rows] + r)[:, None] * n
        near_mm, near = samples.tree.query(k, workers=-1)
        wrong = np.abs(gap[rows] + r) > near_mm + FOOT_SLACK_MM
        rows, near = rows[wrong], near[wrong]
        if not rows.size:
            break
        gap[rows], t[rows], s[rows] = cutter_gap(
            surface, cutter, tips_mm[rows], axes[rows], samples.t[near], samples.s[near],
            newton=6, refine_rim=True)
    return gap, t, s


@dataclass(frozen=True)
class ScallopMeasurement:
    """Height of the material left between passes, mm.

    Attributes
    ----------
    max_mm : float
        Largest height over the cut samples (0 when nothing was cut).
    t, s : float
        Where it is.
    interior_max_mm : float
        Largest height over samples more than a cutter diameter away, along the surface,
        from any uncut sample (excludes the slivers along the border of unreachable
        regions).
    uncut_fraction : float
        Area fraction of the surface left uncut (coarse grid).
    n_samples : int
        Seeds whose cusp was measured.
    n_cast : int
        Of them, those measured by ray casting (the others by the ball's estimate).
    """

    max_mm: float
    t: float
    s: float
    interior_max_mm: float
    uncut_fraction: float
    n_samples: int
    n_cast: int = 0


def _feed_segments(toolpath: Toolpath, joints: NDArray[np.float64] | None
                   ) -> tuple[NDArray[np.float64] | None, ...]:
    """Ends of the feed moves that cut: tips, axes, pass, joints (None: tip-linear).

    Rapids and plunges do not cut; a move's pass is its start's (else its end's, else -1).
    """
    k = toolpath.kinds[1:]
    cutting = (k == MoveKind.CUT) | (k == MoveKind.LINK) | (k == MoveKind.LEAD_IN) | (
        k == MoveKind.LEAD_OUT)
    i = np.flatnonzero(cutting)
    p, a = toolpath.positions_mm, toolpath.tool_axes
    owner = np.where(toolpath.pass_index[i] >= 0, toolpath.pass_index[i],
                     toolpath.pass_index[i + 1])
    ends = (None, None) if joints is None else (joints[i], joints[i + 1])
    return p[i], p[i + 1], a[i], a[i + 1], owner.astype(np.int64), *ends


def _piece_counts(a: NDArray[np.float64], b: NDArray[np.float64], aa: NDArray[np.float64],
                  ab: NDArray[np.float64], step: float, reach_mm: float, sag_mm: float,
                  joints: tuple[Machine, NDArray[np.float64], NDArray[np.float64]] | None
                  ) -> NDArray[np.int64]:
    """Pieces per move, so that the tip and the point ``reach_mm`` up the axis travel <= ``step``.

    Under joint interpolation also so that the straight pieces stay within about ``sag_mm``
    of the bowed path (the bow at mid-move, ``d``, falls as ``d / n^2`` over ``n`` pieces).
    """
    c_a, c_b = a + reach_mm * aa, b + reach_mm * ab
    length = np.maximum(np.linalg.norm(b - a, axis=1), np.linalg.norm(c_b - c_a, axis=1))
    count = np.ceil(length / step)
    if joints is not None:
        machine, q_a, q_b = joints
        tip, axis = forward(machine, 0.5 * (q_a + q_b))
        bow = np.maximum(np.linalg.norm(tip - 0.5 * (a + b), axis=1),
                         np.linalg.norm(tip + reach_mm * axis - 0.5 * (c_a + c_b), axis=1))
        count = np.maximum(count, np.ceil(np.sqrt(bow / sag_mm)))
    return np.maximum(count, 1).astype(np.int64)


def split_moves(a: NDArray[np.float64], b: NDArray[np.float64], aa: NDArray[np.float64],
                ab: NDArray[np.float64], step: float, reach_mm: float, sag_mm: float,
                joints: tuple[Machine, NDArray[np.float64], NDArray[np.float64]] | None = None
                ) -> tuple[NDArray[np.float64], ...]:
    """Split moves ``a -> b`` (tips, axes ``aa -> ab``) into straight pieces.

    Each move gets :func:`_piece_counts` pieces: the tip and the point ``reach_mm`` up the
    axis travel at most ``step`` mm per piece, and under joint interpolation the pieces
    stay within about ``sag_mm`` of the bowed path. Returns the pieces' start and end tips,
    start and end axes, and the move each piece belongs to (in move order).

    The piece ends as the control places them: tips linear and axes renormalized, or,
    with ``joints = (machine, q_a, q_b)``, the joints linear and the pose their forward
    kinematics (the tip bows off the chord where the rotary axes turn) inside the move,
    its own ends at the move's ends (the poses ``q_a``, ``q_b`` were solved for).
    """
    pieces = _piece_counts(a, b, aa, ab, step, reach_mm, sag_mm, joints)
    n = len(a)
    owner = np.repeat(np.arange(n), pieces)
    # piece j of a move of m pieces runs from the pose at u = j / m to (j + 1) / m: the
    # move's own ends, or one of its inner poses (placed once, shared by two pieces)
    inner_first = np.cumsum(pieces - 1) - (pieces - 1)
    inner_move = np.repeat(np.arange(n), pieces - 1)
    u = ((np.arange(inner_move.size) - inner_first[inner_move] + 1)
         / pieces[inner_move])
    if joints is None:
        tips, axes = move_poses(a[inner_move], aa[inner_move], b[inner_move],
                                ab[inner_move], u)
    else:
        machine, q_a, q_b = joints
        w = u[:, None]
        tips, axes = forward(machine, q_a[inner_move] * (1 - w) + q_b[inner_move] * w)
    (p0, p1), (x0, x1) = piece_ends(a, b, tips, pieces), piece_ends(aa, ab, axes, pieces)
    return p0, p1, x0, x1, owner


#: A ball's pieces near a point are sought first within this many widths of the cusp the
#: request leaves on a plane (``2 sqrt(h (2 R - h))``), plus half a piece's length: the
#: neighbouring passes on either side where the passes are planned for that cusp (farther
#: apart on convex parts: :func:`_ball_cusp_estimates` widens the search where it finds
#: no other pass).
NEAR_WIDTHS = 1.0


#: Straight pieces of a joint-interpolated move stay within this share of the requested
#: scallop of the bowed path.
PIECE_SAG_SHARE = 0.03

#: The scallop measurement's horizon, in requested scallops: a ray entering the cut volume
#: higher than this above the surface counts as uncut (a cusp that tall is a missed
#: strip, not a scallop to size), and the pieces farther than this are never searched.
HORIZON_SCALLOPS = 10.0
#: ... and at least this, mm: a tiny request does not bring the horizon down to the
#: heights a cut surface stands at anyway (chord tolerances of hundredths of a mm),
#: which would then read as uncut.
LEAST_HORIZON_MM = 0.05


def cusp_horizon_mm(scallop_mm: float) -> float:
    """The scallop measurement's horizon for the request ``h``: ``max(10 h, 0.05)`` mm.

    (:data:`HORIZON_SCALLOPS`, :data:`LEAST_HORIZON_MM`.)
    """
    return max(HORIZON_SCALLOPS * scallop_mm, LEAST_HORIZON_MM)


class CutVolume:
    """The material the toolpath removes, queried along surface normals.

    The feed moves of ``toolpath`` cut in pieces (module docstring; under ``machine``'s
    joint interpolation where the toolpath was checked for it). :meth:`pairs` gives the
    pieces near points, :meth:`height` a ray's entry into given pieces (``inf`` beyond
    ``horizon_mm``), :attr:`pass_of` each piece's pass and :meth:`cut` whether a ray
    enters within the horizon. ``scallop_mm`` (the request) sets how near a ball's
    nearby pieces lie (:data:`NEAR_WIDTHS`) and how straight a bowed move's pieces are
    (:data:`PIECE_SAG_SHARE`).
    """

    def __init__(self, toolpath: Toolpath, cutter: Cutter, horizon_mm: float,
                 scallop_mm: float, machine: Machine | None = None) -> None:
        self.cutter = cutter
        self.horizon = horizon_mm
        self.scallop_mm = scallop_mm
        joints = _checked_joints(toolpath, machine)
        a, b, xa, xb, owner, q_a, q_b = _feed_segments(toolpath, joints)
        interpolation = None if joints is None else (machine, q_a, q_b)
        sag = PIECE_SAG_SHARE * scallop_mm  # straight pieces on a bowed (joint) path
        big, r = cutter.radius_mm, cutter.corner_radius_mm
        self.ball = cutter.kind is CutterKind.BALL
        step = 0.125 * big
        p0, p1, x0, x1, piece = split_moves(a, b, xa, xb, step, big, sag, interpolation)
        self.reach = big + horizon_mm + 0.5 * step
        self.segment_reach = big + horizon_mm
        if self.ball:
            self.a, self.b = p0 + big * x0, p1 + big * x1  # centres
            mid = 0.5 * (self.a + self.b)
            self.piece_a, self.piece_b = self.a, self.b
            # centres within R + h of a surface point lie within sqrt(2 R h + h^2) of the
            # point R above it (plus a piece's half length and a margin for curvature)
            self.lift = big
            self.lateral = (np.sqrt(2.0 * big * horizon_mm + horizon_mm**2) + 0.5 * step
                            + 0.05 * big)
        else:
            # pieces with their end tips and axes (the cutter solid over their poses)
            self.tips0, self.tips1, self.axes0, self.axes1 = p0, p1, x0, x1
            mid = 0.5 * (p0 + p1) + r * 0.5 * (x0 + x1)
            self.piece_a, self.piece_b = p0 + r * x0, p1 + r * x1
            self.lift = r
            self.lateral = big + horizon_mm + 0.5 * step + 0.05 * big
        self.pass_of = owner[piece] if len(piece) else np.zeros(0, dtype=np.int64)
        self.cells = bin_samples(mid, self.reach) if len(mid) else None
        # a ball's nearby pieces (the cusp estimate, the uncut grid's first try): within
        # about the spacing of passes on a plane for the request (:data:`NEAR_WIDTHS`)
        self.near_mm = (NEAR_WIDTHS * 2.0 * np.sqrt(scallop_mm * (2.0 * big - scallop_mm))
                        + 0.5 * step)
        self.step_mm = step
        self._near_cells: SampleCells | None = None

    @property
    def near_cells(self) -> SampleCells:
        """The pieces' midpoints binned (when first asked) in cells twice :attr:`near_mm`.

        (Finer cells cost more to lay out over the part's box than they save;) and at least
        as many pieces as cells: a few pieces over a large part leave most cells empty.
        """
        if self._near_cells is None:
            mid = 0.5 * (self.piece_a + self.piece_b)
            sparse = float(np.prod(np.ptp(mid, axis=0) + self.near_mm) / len(mid)) ** (1 / 3)
            self._near_cells = bin_samples(mid, max(2.0 * self.near_mm, sparse))
        return self._near_cells

    def cut(self, q: NDArray[np.float64], n: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Rays along ``n`` from ``q`` that enter the removed material within the horizon.

        A ball's pieces within half :attr:`near_mm` of the point ``R`` up the ray (on the
        sheet of ball centres) are tried first: a ray one of them cuts is cut whatever the
        others do (the height is the lowest entry); the rest meet all their pieces
        (:meth:`height`).
        """
        out = np.zeros(len(q), dtype=bool)
        rest = np.arange(len(q))
        if self.ball and len(self.pass_of) and len(q):
            owner, item = pairs_within(self.near_cells, q + self.lift * n, 0.5 * self.near_mm)
            lo, hi, item = ray_ranges(owner, item, len(q))
            out = np.isfinite(self.height(q, n, lo, hi, item, first=True))
            rest = np.flatnonzero(~out)
        for i in range(0, len(rest), 100_000):
            rows = rest[i:i + 100_000]
            out[rows] = np.isfinite(self.height(q[rows], n[rows],
                                                *ray_ranges(*self.pairs(q[rows]), len(rows)),
                                                first=True))
        return out

    def pairs(self, q: NDArray[np.float64], radius: float | None = None
              ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Candidate (query, piece) pairs: piece centres within ``radius`` of each point.

        The default radius is the cutter's reach.
        """
        if self.cells is None:
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        owner, item = pairs_within(self.cells, q, self.reach if radius is None else radius)
        return owner, item

    def height(self, q: NDArray[np.float64], n: NDArray[np.float64], lo: NDArray[np.int64],
               hi: NDArray[np.int64], item: NDArray[np.int64], *, first: bool = False
               ) -> NDArray[np.float64]:
        """Entry distance along ``n`` into the removed material (inf: beyond the horizon).

        Ray ``i`` meets the pieces ``item[lo[i]:hi[i]]``. With ``first``, whether it
        enters within the horizon is all that counts: the first piece it enters there
        gives the height (finite, not the lowest), the others are not tried.
        """
        stop = self.horizon if first else 0.0
        if not self.ball:
            out = nearest_entries(q, n, lo, hi, item, self.tips0, self.tips1, self.axes0,
                                  self.axes1, corner_radius_mm=self.cutter.corner_radius_mm,
                                  radius_mm=self.cutter.radius_mm,
                                  flute_length_mm=self.cutter.flute_length_mm,
                                  horizon_mm=self.horizon, stop_mm=stop)
        else:
            out = capsule_entries(q, n, lo, hi, item, self.a, self.b, self.cutter.radius_mm,
                                  stop_mm=stop)
        return np.where(out > self.horizon, np.inf, out)

    def floor_over(self, centre: NDArray[np.float64], radius: NDArray[np.float64],
                   owner: NDArray[np.int64], item: NDArray[np.int64]) -> NDArray[np.float64]:
        """A lower bound of the entry for rays from anywhere near ``centre[owner]``.

        Pairs of points ``owner`` with pieces ``item``; the rays start within
        ``radius[owner]`` of the point. A point below the tip's plane by ``depth`` meets
        it at least ``depth`` up any ray (``n.a <= 1``; a ray not climbing never does),
        and points within ``radius`` of the centre lie at most ``radius`` deeper or
        shallower than it (compiled: :func:`.sweep_kernel.tip_plane_floors`).
        """
        return tip_plane_floors(centre, radius, owner, item, self.tips0, self.tips1,
                                self.axes0, self.axes1, self.cutter.radius_mm)


def _cusps(volume: CutVolume, surface: ParametricSurface, t: NDArray[np.float64],
           s0: NDArray[np.float64], s1: NDArray[np.float64], own: NDArray[np.int64]
           ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Cusp height and ``s`` between ``s0`` (a contact of pass ``own``) and ``s1``, fixed ``t``.

    ``nan`` where no other pass comes within the bracket; ``inf`` where the cusp is higher
    than the horizon.
    """
    m = len(t)
    f = _HeightDifference(volume, surface, t, *_bracket_pieces(volume, surface, t, s0, s1, own))
    # at its own contact a pass leaves nothing and the others leave more: f(s0) < 0 (where
    # it does not read so, within the search's tolerance, another pass touches there too:
    # -horizon stands in)
    f_tol = CUSP_HEIGHT_SHARE * volume.scallop_mm
    f_lo = f(s0, np.arange(m))
    covered = f_lo >= -f_tol
    f_lo[covered] = -volume.horizon
    f.end_f[covered, 0], f.end_h[covered, 0] = np.inf, 0.0
    lo, f_lo, hi, f_hi = _sign_change(f, s0, s1, f_lo, steps=3)
    result_h = np.full(m, np.nan)
    result_s = np.full(m, np.nan)
    act = np.flatnonzero(~np.isnan(hi))
    if not act.size:
        return result_h, result_s
    # the crossing, from the side where the own pass stands lower (-f >= 0); the ends'
    # heights are the own pass's and the other's there, each below the crest between
    # them: the higher is the cusp
    s_low, s_high = illinois_roots(lambda sv, rows: -f(sv, act[rows]), lo[act], hi[act],
                                   -f_lo[act], -f_hi[act], secant_steps=CUSP_SECANT_STEPS,
                                   bisect_steps=CUSP_BISECT_STEPS,
                                   x_tol=CUSP_S_SHARE * (hi[act] - lo[act]),
                                   f_tol=f_tol, either_end=True)
    high = f.end_h[act, 1] > f.end_h[act, 0]
    result_h[act] = f.end_h[act, high.astype(np.int64)]
    result_s[act] = np.where(high, s_high, s_low)
    return result_h, result_s


#: Ray ``i`` meets the pieces ``item[lo[i]:hi[i]]`` (:func:`~.sweep_kernel.ray_ranges`):
#: ``(lo, hi, item)``.
_RayRanges = tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]


def _bracket_pieces(volume: CutVolume, surface: ParametricSurface, t: NDArray[np.float64],
                    s0: NDArray[np.float64], s1: NDArray[np.float64], own: NDArray[np.int64]
                    ) -> tuple[_RayRanges, _RayRanges]:
    """The pieces that can reach the rays over each bracket, of its own pass and the others.

    The pieces that matter have their centres on the sheet ``lift`` above the surface,
    within ``lateral`` of the bracket; of those, the ones whose cutters come below the
    horizon somewhere over it (flat and bull-nose: a cheap bound first), within the
    cutter's reach of the bracket's chord on the surface (plus the chord's sag).

    Returns the ray ranges (:func:`~.sweep_kernel.ray_ranges`) of the seed's own pass and
    of the others.
    """
    m = len(t)
    mid, mid_n = surface.points_and_normals(t, 0.5 * (s0 + s1))
    ends = surface(t, s1) - surface(t, s0)
    half = 0.5 * np.linalg.norm(ends, axis=1)
    owner, item = volume.pairs(mid + volume.lift * mid_n, radius=volume.lateral + float(
        half.max()) if m else 0.0)
    p0, p1 = surface(t, s0), surface(t, s1)
    sag = np.linalg.norm(0.5 * (p0 + p1) - mid, axis=1)
    if not volume.ball:
        near = volume.floor_over(mid, half + sag, owner, item) <= volume.horizon
        owner, item = owner[near], item[near]
    dist = segment_distances(p0, p1, owner, volume.piece_a, volume.piece_b, item)
    near = dist <= volume.segment_reach + 2.0 * sag[owner]
    owner, item = owner[near], item[near]
    mine = volume.pass_of[item] == own[owner]
    return ray_ranges(owner[mine], item[mine], m), ray_ranges(owner[~mine], item[~mine], m)


class _HeightDifference:
    """``f(s) = h_own(s) - h_other(s)`` (clipped) along each seed's line of fixed ``t``.

    ``h_own`` is the height the seed's own pass leaves, ``h_other`` the other passes'
    (:meth:`CutVolume.height` over the pieces of :func:`_bracket_pieces`). Each call
    keeps, at the end of the bracket on its side (column 0: ``f <= 0``, 1: ``f > 0``),
    ``|f|`` in :attr:`end_f` and ``min(h_own, h_other)`` in :attr:`end_h`.
    """

    def __init__(self, volume: CutVolume, surface: ParametricSurface, t: NDArray[np.float64],
                 own: _RayRanges, other: _RayRanges) -> None:
        self.volume, self.surface, self.t = volume, surface, t
        self.own, self.other = own, other
        self.clip = 10.0 * volume.horizon + 1.0
        self.end_f = np.full((len(t), 2), np.inf)
        self.end_h = np.zeros((len(t), 2))

    def __call__(self, sv: NDArray[np.float64], active: NDArray[np.int64]
                 ) -> NDArray[np.float64]:
        """``f`` at ``sv`` for seeds ``active``."""
        x, nrm = self.surface.points_and_normals(self.t[active], sv)
        lo, hi, item = self.own
        h_own = self.volume.height(x, nrm, lo[active], hi[active], item)
        lo, hi, item = self.other
        h_other = self.volume.height(x, nrm, lo[active], hi[active], item)
        value = np.minimum(h_own, self.clip) - np.minimum(h_other, self.clip)
        side = (value > 0.0).astype(np.int64)
        self.end_f[active, side] = np.abs(value)
        self.end_h[active, side] = np.minimum(h_own, h_other)
        return value


def _sign_change(f: _HeightDifference, s0: NDArray[np.float64], s1: NDArray[np.float64],
                 f_lo: NDArray[np.float64], steps: int
                 ) -> tuple[NDArray[np.float64], ...]:
    """The first of ``steps`` even samples over ``(s0, s1]`` where ``f > 0``, per seed.

    Returns ``lo, f_lo`` (the last sample with ``f <= 0``, from ``s0`` and ``f_lo``
    there) and ``hi, f_hi`` (the first with ``f > 0``; ``nan``: none).
    """
    m = len(s0)
    lo, f_lo = s0.copy(), f_lo.copy()
    hi = np.full(m, np.nan)
    f_hi = np.full(m, np.nan)
    for j in range(1, steps + 1):
        sj = s0 + (s1 - s0) * j / steps
        open_ = np.flatnonzero(np.isnan(hi))
        if not open_.size:
            break
        fj = f(sj[open_], open_)
        found = fj > 0.0
        hi[open_[found]], f_hi[open_[found]] = sj[open_[found]], fj[found]
        lo[open_[~found]], f_lo[open_[~found]] = sj[open_[~found]], fj[~found]
    return lo, f_lo, hi, f_hi


#: The cusp search (:func:`_cusps`) stops where the two heights are within this share of
#: the requested scallop at an end of its bracket (the cusp's height then within about
#: half of it), ...
CUSP_HEIGHT_SHARE = 3e-3

#: ... or the bracket within this share of its first width (in ``s``) ...
CUSP_S_SHARE = 2.0 ** -24

#: ... after at most these regula falsi steps and then bisections
#: (:func:`~.roots.illinois_roots`).
CUSP_SECANT_STEPS = 8
CUSP_BISECT_STEPS = 16


#: Seeds whose cusp, as estimated from the passes' own geometry, exceeds the largest cusp
#: the ray cast found by this factor are ray cast too: the estimate errs by a few per cent
#: (of the cusps above half the largest, 98 % stand within 0.98 to 1.18 of the ray cast on
#: the dev blade, 0.99 to 1.002 on the R150 dome), so where it stands higher than that
#: the ray cast decides.
ESTIMATE_SHARE = 1.03

#: Share of how deep the ridge lies inside other tubes by which it sinks: where one side's
#: lower envelope drops by ``delta`` (the passes' own curving, a pass folding back, a
#: third pass), its crossing with the other side's, whose slopes across are about
#: opposite (``+-d / R``), drops by about half of it.
RIDGE_SINK_SHARE = 0.5

#: Seeds of the largest estimates ray cast (per group, at least): on planned passes the
#: largest cusp is among them, or one within a fraction of a per cent of it where the
#: cusps are all alike (the estimate then ranks seeds by its few per cent of error).
ESTIMATE_TOP = 1024

#: ... or this share of the seeds, when more.
ESTIMATE_TOP_SHARE = 0.01

#: Fewer seeds are all ray cast: the estimate would leave few to skip (it costs about a
#: fifteenth of a seed's ray cast per seed).
ESTIMATE_MIN_SEEDS = 2 * ESTIMATE_TOP


def _ball_cusp_estimates(volume: CutVolume, surface: ParametricSurface, seeds: _Seeds
                         ) -> NDArray[np.float64]:
    """Cusp height from each seed towards increasing ``s``, from two centre segments (ball).

    A ball sweeps the tubes of radius ``R`` round its centre's segments. Near the seed,
    ``P = Q + R n`` with ``Q`` its surface point, take the nearest segment of its own pass
    and the nearest of another pass on the ``+s`` side (``(C - P) . X_s > 0``), their points
    ``C1`` and ``C2`` nearest to ``P``, among the pieces whose midpoints lie within
    ``near_mm`` of ``P`` (:data:`NEAR_WIDTHS`; where no other pass lies there, within 4
    times that, and so on up to ``2 R`` and a piece's length: beyond, the tubes are apart).
    Across the own segment (direction ``u``) the two tubes are circles ``2 d`` apart (``d``
    half the across part ``D`` of ``C2 - C1``), meeting at
    ``X = C1 + D / 2 - sqrt(R^2 - d^2) v`` (``v`` across ``u`` and ``D``, pointing away
    from the surface): the bottom of the cusp's ridge
    (:func:`~.cusp_kernel.ridges`). Its height is ``(X - X(t, s_c)) . n(t, s_c)`` over the
    surface point one first-order step from the seed, ``s_c = s + (X - Q) . X_s / |X_s|^2``,
    less :data:`RIDGE_SINK_SHARE` of how deep ``X`` lies in a nearby tube of a third pass
    (passes closing up, links) or of the two passes' other pieces (their curving, a fold).

    Returns NaN where no other pass lies on that side within that reach or a
    segment has no length (the ray cast decides there), ``inf`` where the tubes do not
    meet (``d >= R``: material between the passes).
    """
    n_seed = len(seeds.t)
    out = np.full(n_seed, np.nan)
    if not n_seed or not len(volume.pass_of):
        return out
    x, inside, state = _ridges_widening(volume, seeds)
    out[state == RIDGE_OPEN] = np.inf
    ok = np.flatnonzero(state == RIDGE_FOUND)
    height = _ridge_heights(surface, seeds, ok, x[ok])
    # the two passes' own curving sinks the ridge into their neighbouring pieces (on the
    # R150 dome by 14 % of its height: the ray cast reads 6 % below X), a fold or a third
    # pass deeper
    out[ok] = height - RIDGE_SINK_SHARE * inside[ok].max(axis=1)
    return out


def _ridge_heights(surface: ParametricSurface, seeds: _Seeds, rows: NDArray[np.int64],
                   x: NDArray[np.float64]) -> NDArray[np.float64]:
    """Height of ridge points ``x`` over the surface near seeds ``rows``, mm.

    ``(X - X(t, s_c)) . n(t, s_c)`` over the surface point one first-order step from the
    seed, ``s_c = s + (X - Q) . X_s / |X_s|^2``.
    """
    xs = seeds.x_s[rows]
    s_c = np.clip(seeds.s[rows] + np.einsum("ij,ij->i", x - seeds.q[rows], xs)
                  / np.maximum(np.einsum("ij,ij->i", xs, xs), TINY), 0.0, 1.0)
    foot_c, n_c = surface.points_and_normals(seeds.t[rows], s_c)
    return np.einsum("ij,ij->i", x - foot_c, n_c)


def _torus_cusp_estimates(volume: CutVolume, surface: ParametricSurface, seeds: _Seeds
                          ) -> NDArray[np.float64]:
    """Cusp height from each seed towards increasing ``s`` for a flat or bull-nose cutter.

    The pieces of the seed's own pass and of the next pass on the ``+s`` side nearest to
    it (:func:`~.cusp_kernel.nearest_pieces`, from the own ring centre as the nearest
    piece's axis puts it: within :attr:`CutVolume.near_mm`, where none within 4 times
    that, and so on up to ``2 R`` and a piece's length), the poses of their passes that
    touch nearest the seed's contact (:func:`_contact_poses`), and the two passes'
    sections in the plane of the seed's line of ``t`` through its contact (normal
    ``X_s x n``: where the ray cast meets the ridge), each pass's prism along the way its
    cutter's point at the contact moves (:func:`_contact_way`;
    :func:`~.torus_profile.profile_ridges`: the ring's ellipse widened by ``r``, seen
    aslant where a way crosses the plane aslant, as at a move joint): where they meet is
    the bottom of the ridge ``X``, its height over the surface as for the ball
    (:func:`_ridge_heights`).

    Returns NaN where no next pass lies within that reach, the own piece has no length,
    a pass runs across that plane more steeply than
    :data:`~.torus_profile.LEAST_WAY_COSINE` or the sections do not meet nearest the
    surface (the ray cast decides there).
    """
    n_seed = len(seeds.t)
    out = np.full(n_seed, np.nan)
    if not n_seed or not len(volume.pass_of):
        return out
    cutter = volume.cutter
    big, r = cutter.radius_mm, cutter.corner_radius_mm
    a, e = volume.piece_a, volume.piece_b - volume.piece_a
    corner = seeds.q + r * seeds.n
    # the own ring centre as the axis of the piece whose ring centre is nearest puts it
    _, near = cKDTree(a + 0.5 * e).query(corner, workers=-1)
    inward, _ = radial_directions(seeds.n, unit(volume.axes0[near] + volume.axes1[near]))
    target = corner + (big - r) * inward
    found = np.full((n_seed, 2), -1, dtype=np.int64)
    todo = np.arange(n_seed)
    apart, limit = volume.near_mm, 2.0 * big + volume.step_mm
    while todo.size:
        found[todo] = nearest_pieces(target[todo], seeds.x_s[todo], seeds.pass_[todo],
                                     volume.near_cells, apart, a, e, volume.pass_of)
        todo = todo[(found[todo] < 0).any(axis=1)]
        if apart >= limit:
            break
        apart = min(4.0 * apart, limit)
    ok = np.flatnonzero((found >= 0).all(axis=1))
    own_c, own_axis, j_own, own_ok = _contact_poses(volume, found[ok, 0], corner[ok],
                                                    seeds.n[ok])
    next_c, next_axis, j_next, next_ok = _contact_poses(volume, found[ok, 1], corner[ok],
                                                        seeds.n[ok])
    live = own_ok & next_ok & (np.einsum("ij,ij->i", e[j_own], e[j_own]) > TINY)
    ok, j_own, j_next = ok[live], j_own[live], j_next[live]
    own_c, own_axis, next_c, next_axis = own_c[live], own_axis[live], next_c[live], next_axis[live]
    # the sections in the plane of the seed's line of t (where the ray cast meets the
    # ridge), each pass's prism along the way the cutter's point at the contact moves
    n = seeds.n[ok]
    x, met = profile_ridges(own_c, next_c, own_axis, next_axis, _contact_way(volume, n, j_own),
                            _contact_way(volume, n, j_next), n, through=seeds.q[ok],
                            across=unit(np.cross(seeds.x_s[ok], n)), radius_mm=big,
                            corner_radius_mm=r, flute_length_mm=cutter.flute_length_mm)
    out[ok[met]] = _ridge_heights(surface, seeds, ok[met], x[met])
    return out


def _contact_way(volume: CutVolume, normal: NDArray[np.float64], piece: NDArray[np.int64]
                 ) -> NDArray[np.float64]:
    """Unit way the cutter's point touching a surface of ``normal`` moves along ``piece``.

    The ring centre's way tilts off it as the axis turns, a radius ``R - r`` from the
    contact: ``e - (R - r) (w_b - w_a)`` with ``w`` the ring's inward directions at the
    piece's ends (:func:`~.cutters.radial_directions`).
    """
    ring = volume.cutter.radius_mm - volume.cutter.corner_radius_mm
    ring_a, _ = radial_directions(normal, volume.axes0[piece])
    ring_b, _ = radial_directions(normal, volume.axes1[piece])
    return unit(volume.piece_b[piece] - volume.piece_a[piece] - ring * (ring_b - ring_a))


#: A pass's pose whose contact lies nearest a seed's is sought this many pieces either
#: side of the piece nearest to it (:func:`_contact_poses`): a bull-nose with a lead
#: touches ``(R - r) cos(lead)`` ahead of its axis, two of them on zigzag passes ``2 R``
#: apart along them, 8 to 16 pieces of ``R / 8``.
CONTACT_WINDOW = 24

#: ... and found there only where its foot lies across the piece from the target (along
#: it within this share of a piece's length: a bend between pieces, not a pass's end).
CONTACT_ALONG_SHARE = 0.25


def _contact_poses(volume: CutVolume, piece: NDArray[np.int64], corner: NDArray[np.float64],
                   normal: NDArray[np.float64]
                   ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64],
                              NDArray[np.bool_]]:
    """The poses of the passes of ``piece`` whose contacts lie nearest the seeds'.

    A pose (ring centre ``C``, axis ``a``) touches a surface of normal ``n`` at the
    corner-circle centre ``C + (R - r) w``, ``w = -n_perp / |n_perp|``,
    ``n_perp = n - (n . a) a``: over the pieces of the pass within
    :data:`CONTACT_WINDOW` of ``piece``, the foot of ``corner + (R - r) n_perp / |n_perp|``
    (``a`` at the middle of ``piece``, then of the nearest) on the piece nearest to it. Where the
    neighbouring poses tilt alike, the sections across the pass met at those poses
    stand as the contacts do (a pose's contact can lie a radius ahead of its ring centre,
    where a curved pass has moved on). Returns ``C``, ``a`` (normalized-linear), the piece
    and False where the nearest lies at the window's edge or the pass ends short of the
    target (:data:`CONTACT_ALONG_SHARE`).
    """
    ring = volume.cutter.radius_mm - volume.cutter.corner_radius_mm
    a, e, pass_of = volume.piece_a, volume.piece_b - volume.piece_a, volume.pass_of
    m, shift = len(piece), np.arange(-CONTACT_WINDOW, CONTACT_WINDOW + 1)
    best = np.empty(m, dtype=np.int64)
    # the axis turns little over the window: the target as the piece's axis puts it
    inward, _ = radial_directions(normal, unit(volume.axes0[piece] + volume.axes1[piece]))
    target = corner + ring * inward
    for lo in range(0, m, 10_000):
        rows = slice(lo, lo + 10_000)
        cand = np.clip(piece[rows, None] + shift, 0, len(pass_of) - 1)
        near = target[rows, None]
        foot, _ = _foot_on(a[cand], e[cand], near)
        dist = np.einsum("ijk,ijk->ij", near - foot, near - foot)
        dist[pass_of[cand] != pass_of[piece[rows], None]] = np.inf
        best[rows] = np.take_along_axis(cand, np.argmin(dist, axis=1)[:, None], 1)[:, 0]
    edge = np.abs(best - piece) >= CONTACT_WINDOW
    axis_mid = unit(volume.axes0[best] + volume.axes1[best])
    inward, _ = radial_directions(normal, axis_mid)
    target = corner + ring * inward
    centre, f = _foot_on(a[best], e[best], target)
    # a foot at the pass's end short of the target: that pose's contact lies beyond it
    edge |= np.abs(np.einsum("ij,ij->i", target - centre, unit(e[best]))) > (
        CONTACT_ALONG_SHARE * volume.step_mm)
    return centre, move_axes(volume.axes0[best], volume.axes1[best], f), best, ~edge


def _foot_on(a: NDArray[np.float64], e: NDArray[np.float64], p: NDArray[np.float64]
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Nearest points to ``p`` on segments ``a + f e`` (``0 <= f <= 1``) and ``f``."""
    f = np.clip(np.einsum("...j,...j->...", p - a, e)
                / np.maximum(np.einsum("...j,...j->...", e, e), TINY), 0.0, 1.0)
    return a + f[..., None] * e, f


def _ridges_widening(volume: CutVolume, seeds: _Seeds) -> tuple[NDArray[np.float64], ...]:
    """The ridge between each seed's own pass and the next pass (:func:`~.cusp_kernel.ridges`).

    Among the pieces within :attr:`CutVolume.near_mm` of ``P = Q + R n``; where no other
    pass lies there, within 4 times that, and so on up to ``2 R`` and a piece's length (an
    other pass's piece whose midpoint lies farther from ``P`` leaves its tube apart from
    the own pass's: the tubes do not meet). Returns the ridge points, the depths inside
    the other tubes and the states (``RIDGE_*``).
    """
    n_seed = len(seeds.t)
    big = volume.cutter.radius_mm
    centre = seeds.q + big * seeds.n
    seg = volume.b - volume.a
    x = np.zeros((n_seed, 3))
    inside = np.zeros((n_seed, 2))
    state = np.full(n_seed, RIDGE_NO_PASS)
    todo = np.arange(n_seed)
    radius = volume.near_mm
    limit = 2.0 * big + volume.step_mm
    while todo.size:
        x[todo], inside[todo], state[todo] = ridges(
            centre[todo], seeds.n[todo], seeds.x_s[todo], seeds.pass_[todo],
            volume.near_cells, radius, volume.a, seg, volume.pass_of, big)
        todo = todo[state[todo] == RIDGE_NO_PASS]
        if radius >= limit:
            break
        radius = min(4.0 * radius, limit)
    return x, inside, state


def _largest_first(estimate: NDArray[np.float64], group: NDArray[np.bool_], count: int
                   ) -> NDArray[np.bool_]:
    """The ``count`` seeds of ``group`` with the largest finite estimates."""
    rows = np.flatnonzero(group & np.isfinite(estimate))
    if rows.size > count:
        rows = rows[np.argpartition(-estimate[rows], count - 1)[:count]]
    out = np.zeros(len(estimate), dtype=bool)
    out[rows] = True
    return out


class _OtherPasses:
    """Distance from contacts to the nearest contact of another pass (a k-d tree of all)."""

    def __init__(self, points: NDArray[np.float64], passes: NDArray[np.int64]) -> None:
        self.points, self.passes = points, passes
        self.tree = cKDTree(points) if len(points) else None

    def distance(self, rows: NDArray[np.int64]) -> NDArray[np.float64]:
        """For contacts ``rows``: the distance, mm (inf if none)."""
        out = np.full(len(rows), np.inf)
        if self.tree is None:
            return out
        n = len(self.points)
        todo = np.arange(len(rows))
        k = 16
        while todo.size and k <= 1024:
            dist, idx = self.tree.query(self.points[rows[todo]], k=min(k, n), workers=-1)
            dist, idx = dist.reshape(len(todo), -1), idx.reshape(len(todo), -1)
            other = self.passes[np.minimum(idx, n - 1)] != self.passes[rows[todo]][:, None]
            other &= np.isfinite(dist)
            found = other.any(axis=1)
            first = np.argmax(other, axis=1)
            out[todo[found]] = dist[found, first[found]]
            todo = todo[~found]
            if k >= n:
                break
            k *= 4
        return out


def _surface_reach(grid: NDArray[np.float64], sources: NDArray[np.bool_], closed: bool,
                   limit_mm: float) -> NDArray[np.float64]:
    """Distance over the surface from every node of the sample grid to the nearest source, mm.

    Shortest paths on the sample grid ``(n_t, n_s, 3)`` (its rows at ``t = i / (n_t - 1)``,
    columns likewise in ``s``), edges to the 8 neighbours weighted by their chord (the
    seam joined on closed sections), from every source node at once. Over a thin part
    this is the way round its edge, not through its thickness. Paths are followed up to
    ``limit_mm``: a distance beyond it may read ``inf``.
    """
    n_t, n_s = sources.shape
    node = np.arange(n_t * n_s).reshape(n_t, n_s)
    pairs = [(node[1:, :], node[:-1, :]), (node[:, 1:], node[:, :-1]),
             (node[1:, 1:], node[:-1, :-1]), (node[1:, :-1], node[:-1, 1:])]
    if closed:
        pairs.append((node[0, :], node[-1, :]))
    a = np.concatenate([p[0].ravel() for p in pairs])
    b = np.concatenate([p[1].ravel() for p in pairs])
    flat = grid.reshape(-1, 3)
    # a stored 0 is no edge to the graph: coincident nodes (a collapsed row) keep theirs
    weight = np.maximum(np.linalg.norm(flat[a] - flat[b], axis=1), LENGTH_SLACK_MM)
    graph = scipy.sparse.coo_matrix((weight, (a, b)), shape=(node.size, node.size)).tocsr()
    return scipy.sparse.csgraph.dijkstra(graph, directed=False,
                                         indices=np.flatnonzero(sources.ravel()),
                                         min_only=True, limit=limit_mm)


def _distance_from(reach: NDArray[np.float64], grid: NDArray[np.float64],
                   points: NDArray[np.float64], t: NDArray[np.float64],
                   s: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance over the surface from ``points`` (at ``t, s``) to the nearest source, mm.

    Through the best of the four grid nodes around each point (:func:`_surface_reach`).
    """
    n_t, n_s = grid.shape[:2]
    node = np.arange(n_t * n_s).reshape(n_t, n_s)
    flat = grid.reshape(-1, 3)
    i0 = np.clip(np.floor(t * (n_t - 1)).astype(np.int64), 0, n_t - 2)
    j0 = np.clip(np.floor(s * (n_s - 1)).astype(np.int64), 0, n_s - 2)
    best = np.full(len(points), np.inf)
    for di in (0, 1):
        for dj in (0, 1):
            k = node[i0 + di, j0 + dj]
            best = np.minimum(best, reach[k] + np.linalg.norm(points - flat[k], axis=1))
    return best


def measure_scallop(toolpath: Toolpath, surface: ParametricSurface, cutter: Cutter,
                    scallop_mm: float, chord: ChordMeasurement, *,
                    machine: Machine | None = None, chunk: int = 20_000,
                    estimate: bool = True, estimate_min_seeds: int = ESTIMATE_MIN_SEEDS,
                    estimate_top: int = ESTIMATE_TOP,
                    estimate_top_share: float = ESTIMATE_TOP_SHARE) -> ScallopMeasurement:
    """Measure the material left between passes (module docstring).

    With the 5-axis ``machine`` whose joint interpolation the toolpath was checked under,
    the cutter moves as that interpolation moves it (as in :func:`measure_chord`). The
    largest of the seeds' cusps (:func:`seed_cusps`), overall and away from uncut areas.

    Parameters
    ----------
    toolpath, surface, cutter
        What was cut, the design surface and the cutter.
    scallop_mm : float
        The request; sets the horizon (:func:`cusp_horizon_mm`).
    chord : ChordMeasurement
        From :func:`measure_chord` on the same toolpath: its contacts seed the search.
    chunk : int
        Seeds per vectorized batch.
    estimate : bool
        More than ``estimate_min_seeds`` seeds: estimate every seed's cusp from the
        passes' own geometry (:func:`_ball_cusp_estimates`, flat and bull-nose cutters
        :func:`_torus_cusp_estimates`) and ray-cast
        only the seeds of the largest estimates and those the estimate cannot tell;
        False ray-casts every seed (the full method).
    estimate_min_seeds, estimate_top, estimate_top_share
        Fewer seeds are all ray cast; else at least the ``estimate_top`` seeds of the
        largest estimates, or that share of the seeds when more (defaults
        :data:`ESTIMATE_MIN_SEEDS`, :data:`ESTIMATE_TOP`, :data:`ESTIMATE_TOP_SHARE`).
    """
    return _scallop_result(seed_cusps(
        toolpath, surface, cutter, scallop_mm, chord, machine=machine, chunk=chunk,
        estimate=estimate, estimate_min_seeds=estimate_min_seeds, estimate_top=estimate_top,
        estimate_top_share=estimate_top_share))


@dataclass(frozen=True)
class SeedCusps:
    """Each seed's cusp: where the search starts, the ball's estimate, the ray cast.

    One row per seed: the chord measurement's seeds short of ``s = 1``
    (:attr:`ChordMeasurement.seeds_t` and so on), in their order.

    Attributes
    ----------
    t, s : ndarray
        Where the search starts (a contact, or a mid-chord contact above the surface).
    pass_index : ndarray of int
        The seed's pass.
    estimate_mm : ndarray
        The estimate from the passes' own geometry, mm (``nan``: not estimated, or
        none stands; ``inf``: the tubes do not meet).
    cast : ndarray of bool
        The seeds ray cast.
    height_mm : ndarray
        The cusp the ray cast found, mm (``nan``: not cast, or no other pass within the
        bracket; ``inf``: above the horizon).
    cusp_s : ndarray
        Where it is, ``s`` at the seed's ``t`` (``nan`` likewise).
    bracket_s : ndarray
        Where the ray cast's bracket ends, ``s`` (``nan``: not cast).
    clear_of_uncut : ndarray of bool
        Cusps found farther than a cutter diameter, along the surface, from any uncut
        sample of the coarse grid.
    uncut_fraction : float
        Area fraction of the surface left uncut (coarse grid).
    """

    t: NDArray[np.float64]
    s: NDArray[np.float64]
    pass_index: NDArray[np.int64]
    estimate_mm: NDArray[np.float64]
    cast: NDArray[np.bool_]
    height_mm: NDArray[np.float64]
    cusp_s: NDArray[np.float64]
    bracket_s: NDArray[np.float64]
    clear_of_uncut: NDArray[np.bool_]
    uncut_fraction: float


def seed_cusps(toolpath: Toolpath, surface: ParametricSurface, cutter: Cutter,
               scallop_mm: float, chord: ChordMeasurement, *,
               machine: Machine | None = None, chunk: int = 20_000,
               estimate: bool = True, estimate_min_seeds: int = ESTIMATE_MIN_SEEDS,
               estimate_top: int = ESTIMATE_TOP,
               estimate_top_share: float = ESTIMATE_TOP_SHARE) -> SeedCusps:
    """The cusp searched from each seed (module docstring), seed by seed.

    Parameters as :func:`measure_scallop`, which reports the largest of these cusps.
    """
    h = float(scallop_mm)
    rho = cutter.corner_radius_mm if cutter.corner_radius_mm > h else cutter.radius_mm
    width = 2.0 * np.sqrt(h * (2.0 * rho - h))
    volume = CutVolume(toolpath, cutter, cusp_horizon_mm(h), h, machine)
    uncut = _UncutArea.on_grid(surface, volume, width)
    seeds, others = _Seeds.of(surface, chord)
    search = _CuspSearch(volume, surface, seeds, others, 3.0 * width, chunk)
    guess = np.full(len(seeds.t), np.nan)
    if estimate and len(seeds.t) > estimate_min_seeds:
        count = max(estimate_top, int(estimate_top_share * len(seeds.t)))
        guess = _cast_beyond_estimates(search, uncut, count)
    else:
        search.run(np.ones(len(seeds.t), dtype=bool))
    found = ~np.isnan(search.height)
    clear = found.copy()
    away = uncut.away(surface(seeds.t[found], search.s[found]), seeds.t[found],
                      search.s[found]) if found.any() else None
    if away is not None:
        clear[found] = away
    return SeedCusps(seeds.t, seeds.s, seeds.pass_, guess, search.cast, search.height,
                     search.s, search.bracket_s, clear, uncut.fraction)


@dataclass(frozen=True)
class _UncutArea:
    """The coarse grid's points no cutter comes near, and distances over the surface to them.

    ``grid`` holds the points ``(n_t, n_s, 3)``, ``uncut`` the uncut ones; ``reach`` the
    distance from each grid node to the nearest uncut one (:func:`_surface_reach`; None:
    nothing uncut), followed up to a cutter diameter (``diameter_mm``).
    """

    grid: NDArray[np.float64]
    uncut: NDArray[np.bool_]
    fraction: float
    reach: NDArray[np.float64] | None
    diameter_mm: float

    @classmethod
    def on_grid(cls, surface: ParametricSurface, volume: CutVolume, width_mm: float
                ) -> _UncutArea:
        """Grid spacing half the cutter radius along ``t``, ``width_mm`` across."""
        big = volume.cutter.radius_mm
        g = np.linspace(0.0, 1.0, 33)
        pts = surface(g, g, grid=True)
        len_t = np.linalg.norm(np.diff(pts, axis=0), axis=2).sum(axis=0).max() * 1.02
        len_s = np.linalg.norm(np.diff(pts, axis=1), axis=2).sum(axis=1).max() * 1.02
        n_t = int(np.ceil(len_t / (0.5 * big))) + 1
        n_s = int(np.ceil(len_s / width_mm)) + 1
        t, s = np.meshgrid(np.linspace(0.0, 1.0, n_t), np.linspace(0.0, 1.0, n_s),
                           indexing="ij")
        # the first partials only: points, normals and |X_t x X_s| = sqrt(E G - F^2)
        parts = surface.partials_many(t.ravel(), s.ravel(), ((0, 0), (1, 0), (0, 1)))
        q, n = parts[0, 0], outward_normals(surface, parts[1, 0], parts[0, 1])
        area = np.linalg.norm(np.cross(parts[1, 0], parts[0, 1]), axis=1)
        uncut = ~volume.cut(q, n)
        fraction = float(area[uncut].sum() / max(area.sum(), TINY))
        grid = q.reshape(n_t, n_s, 3)
        reach = (_surface_reach(grid, uncut.reshape(n_t, n_s), bool(surface.closed_t),
                                2.0 * big) if uncut.any() else None)
        return cls(grid, uncut, fraction, reach, 2.0 * big)

    def away(self, points: NDArray[np.float64], t: NDArray[np.float64],
             s: NDArray[np.float64]) -> NDArray[np.bool_] | None:
        """Points farther than a cutter diameter from the uncut area (None: none uncut)."""
        if self.reach is None:
            return None
        return _distance_from(self.reach, self.grid, points, t, s) > self.diameter_mm


class _Seeds(NamedTuple):
    """Where cusps are searched from: ``t, s``, pass, ``X_s``, surface point and normal."""

    t: NDArray[np.float64]
    s: NDArray[np.float64]
    pass_: NDArray[np.int64]
    x_s: NDArray[np.float64]
    q: NDArray[np.float64]
    n: NDArray[np.float64]
    rows: NDArray[np.int64]

    @classmethod
    def of(cls, surface: ParametricSurface, chord: ChordMeasurement
           ) -> tuple[_Seeds, _OtherPasses]:
        """The chord measurement's seeds short of ``s = 1`` (``rows`` among all of them).

        And the contacts of every seed (:class:`_OtherPasses`).
        """
        st, ss, sp = chord.seeds_t, chord.seeds_s, chord.seeds_pass
        if st.size:
            # one evaluation of the three partials: points, normals and X_s
            parts = surface.partials_many(st, ss, ((0, 0), (1, 0), (0, 1)))
            seed_q, x_s = parts[0, 0], parts[0, 1]
            seed_n = outward_normals(surface, parts[1, 0], x_s)
        else:
            seed_q = seed_n = x_s = np.zeros((0, 3))
        others = _OtherPasses(seed_q, sp)
        live = np.flatnonzero(ss < 1.0 - ROUND_OFF)
        return cls(*(a[live] for a in (st, ss, sp, x_s, seed_q, seed_n)), live), others


class _CuspSearch:
    """Cusps searched by ray casting from the seeds, each once (:func:`_cusps`).

    From a seed at ``s`` over 2.5 times the distance to the nearest contact of another
    pass (what the toolpath itself shows of the spacing; ``default_gap_mm`` where none),
    ``chunk`` seeds at a time. :attr:`height` and :attr:`s` hold the cusps found (``nan``:
    none or not cast), :attr:`cast` the seeds cast, :attr:`bracket_s` where their
    brackets end.
    """

    def __init__(self, volume: CutVolume, surface: ParametricSurface, seeds: _Seeds,
                 others: _OtherPasses, default_gap_mm: float, chunk: int) -> None:
        self.volume, self.surface, self.seeds, self.others = volume, surface, seeds, others
        self.default_gap_mm, self.chunk = default_gap_mm, chunk
        m = len(seeds.t)
        self.height = np.full(m, np.nan)
        self.s = np.full(m, np.nan)
        self.cast = np.zeros(m, dtype=bool)
        self.bracket_s = np.full(m, np.nan)

    def run(self, rows: NDArray[np.bool_]) -> None:
        """Ray cast the seeds ``rows`` not cast yet."""
        seeds = self.seeds
        todo = np.flatnonzero(rows & ~self.cast)
        self.cast[todo] = True
        gap = self.others.distance(seeds.rows[todo])
        gap = np.where(np.isfinite(gap), gap, self.default_gap_mm)
        speed = np.linalg.norm(seeds.x_s[todo], axis=1)
        s1 = np.minimum(seeds.s[todo] + 2.5 * gap / np.maximum(speed, TINY), 1.0)
        self.bracket_s[todo] = s1
        room = s1 > seeds.s[todo] + ROUND_OFF  # no room above (s in [0, 1]): no cusp
        # brackets of like length batched together: a batch meets the pieces within
        # reach of its longest bracket
        order = np.argsort(gap[room], kind="stable")
        todo, s1 = todo[room][order], s1[room][order]
        for lo in range(0, todo.size, self.chunk):
            sl = todo[lo:lo + self.chunk]
            self.height[sl], self.s[sl] = _cusps(self.volume, self.surface, seeds.t[sl],
                                                 seeds.s[sl], s1[lo:lo + self.chunk],
                                                 seeds.pass_[sl])


def _cast_beyond_estimates(search: _CuspSearch, uncut: _UncutArea, count: int
                           ) -> NDArray[np.float64]:
    """The cusps estimated first; the ray cast where the estimate cannot decide.

    Every seed's cusp from the passes' own geometry (:func:`_ball_cusp_estimates`,
    :func:`_torus_cusp_estimates`); then
    the ray cast where no estimate stands, at the ``count`` largest estimates, and
    wherever an estimate stands above the largest cusp the ray cast found by more than it
    errs (:data:`ESTIMATE_SHARE`; overall, and away from uncut areas as the seeds stand).
    Returns the estimates.
    """
    seeds = search.seeds
    estimates = _ball_cusp_estimates if search.volume.ball else _torus_cusp_estimates
    guess = estimates(search.volume, search.surface, seeds)
    groups = [np.ones(len(seeds.t), dtype=bool)]
    away = uncut.away(seeds.q, seeds.t, seeds.s)
    if away is not None:
        groups.append(away)
    first = ~np.isfinite(guess)
    for group in groups:
        first |= _largest_first(guess, group, count)
    search.run(first)
    for group in groups:
        measured = group & search.cast & np.isfinite(search.height)
        if measured.any():
            # an estimate above the largest cusp by more than it errs: cast it too
            top = float(search.height[measured].max())
            search.run(group & (guess >= ESTIMATE_SHARE * top))
        else:
            search.run(group)
    return guess


def _scallop_result(cusps: SeedCusps) -> ScallopMeasurement:
    """The largest cusp found, overall and away from the uncut area."""
    n_cast = int(cusps.cast.sum())
    found = ~np.isnan(cusps.height_mm)
    if not found.any():
        return ScallopMeasurement(0.0, float("nan"), float("nan"), 0.0, cusps.uncut_fraction,
                                  len(cusps.t), n_cast)
    ch, ct, cs = cusps.height_mm[found], cusps.t[found], cusps.cusp_s[found]
    k = int(np.argmax(ch))
    interior = np.where(cusps.clear_of_uncut[found], ch, -np.inf)
    return ScallopMeasurement(max_mm=float(ch[k]), t=float(ct[k]), s=float(cs[k]),
                              interior_max_mm=max(float(interior.max()), 0.0),
                              uncut_fraction=cusps.uncut_fraction, n_samples=len(cusps.t),
                              n_cast=n_cast)
