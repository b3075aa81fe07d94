"""Chord error measured on a finished toolpath, independently of the planner.

Nothing here uses the planner's curvature formulas or its internal parameters: only the
toolpath's arrays (tips, axes, kinds, passes), the surface and the cutter solid.

**Chord error.** Every cutter location on a cutting move is first projected onto the
surface (Newton from the nearest of a grid of surface samples, sought within a reach
first: :func:`_nearest_samples`; a ball's, at every fourth
location along a run of moves, the others from those contacts interpolated, and from their
own nearest sample where the feet either side jumped or the foot found stands farther off
than theirs; a foot farther than the sample nearest its point is searched again from
there; on a sphere its centre's closest point, in closed form): its gap checks that it
touches. A flat or bull-nose cutter's lowest rim point is
sought finely everywhere (``refine_rim`` of :func:`~toolpath.planning.sampling.cutter_gap`).
Then the cutter is placed at ``u = 1/4, 1/2, 3/4`` of each move (tip linear,
axis normalized-linear, as a 5-axis control with tool-centre-point interpolation moves
it; for a toolpath checked under a 5-axis machine's joint interpolation, its joints
linear, as that machine moves it), and, on the
moves that could hold the largest deviation (a model extreme at least
half the largest sample), once more where a smooth model through those gaps is lowest and
where it is highest (a ball's search there starting on the parabola through its feet at
``u = 0, 1/2, 1``: :func:`_feet_between`); its signed
gap to the surface is measured: ``gap = dist(K, surface) - r`` with ``K`` the corner-circle
centre projected onto the surface. The cutter is placed at ``u = 1/2`` only where the
model's slopes at the ends are known: the gap is the distance of the cutter's lowest
point ``K*`` (a ball's centre; a flat or bull-nose cutter's lowest corner-circle point)
less ``r``, and by the envelope theorem its rate at an end is the distance's at ``K*``
held on the moving cutter, whose gradient is the unit normal ``n`` at the end's contact:
``g' = n . K*'`` exactly (:func:`_end_slopes`), so the two projections at ``1/4`` and
``3/4`` are not needed to fix the model. Under joint interpolation ``n . K*'`` is the
joints' gradient of ``n . K*`` (:func:`_contact_gradient`) times their rates
``q_b - q_a``: the gradient once per location (its normal is both moves' there), exact.
A flat or bull-nose move whose gap may have a kink (its ``K*`` jumps across the disc,
or a foot lies on the surface's open edge: :func:`_contact_jumps`) takes the three
places after all.

The contacts and the mid-chord contacts above the surface seed the scallop measurement
(:attr:`ChordMeasurement.seeds_t` and so on; :mod:`.measure`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from machines import Machine
from machines.kinematics import tool_point_gradient

from ..joint_refine import checked_moves
from ..path import MoveKind, Toolpath
from ..projection_kernel import seam_lerp_rows
from ..row_threads import query_workers
from ..surface import ParametricSurface, outward_normals
from ..tolerances import TINY
from ..vectors import row_lengths
from .cutters import Cutter, CutterKind
from .gouge import SurfaceSamples
from .local import project_to_surface
from .measure_joints import checked_joints
from .sampling import (
    CHORD_FRACTIONS,
    JointEnds,
    MoveEnds,
    chord_extremes,
    contact_end_slopes,
    cutter_gap,
    move_gaps,
    move_poses,
)

__all__ = ["BALL_CONTACT_NEWTON", "CONTACT_STRIDE", "DISC_CONTACT_NEWTON", "FOOT_SLACK_MM",
           "FOOT_SPREAD", "SEEDED_CONTACT_NEWTON", "ChordMeasurement", "measure_chord"]


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
    #: The seeds' surface points (mm), outward unit normals and ``X_s`` (mm per unit
    #: ``s``), (n, 3) each, as :meth:`~.cusp_search.SearchSeeds.of` needs them (empty:
    #: not given, evaluated there).
    seeds_q: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)), repr=False)
    seeds_n: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)), repr=False)
    seeds_x_s: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 3)),
                                           repr=False)
    #: The contact's ``t`` and ``s`` at each toolpath point ending a cutting move, ``nan``
    #: at the others (empty: not given); the uncut area's grid finds its pieces by them
    #: (:meth:`~.uncut_area.UncutArea.on_grid`).
    contact_t: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0), repr=False)
    contact_s: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0), repr=False)


#: A ball's contacts along a run of cutting moves are searched from the nearest surface
#: sample at every this many locations (and at the run's last); the others from those
#: contacts (:func:`_run_anchors`), unless the guard of :func:`_unsure_between` sends them
#: back to their own sample: the same feet, in about a quarter of the nearest-sample searches.
CONTACT_STRIDE = 4

#: A ball's undercut (gap above the surface) under this share of the largest gap is taken
#: as the projection's rounding (about 1e-12 of it on convex parts) and not followed up.
UNDERCUT_NOISE = 1e-6

#: Where the closest surface point moves continuously with the ball's centre, it moves at
#: most ``rho / (rho - d)`` times as far (``rho`` the surface's concave radius along the
#: motion, ``d`` the centre's distance, about the ball radius; on convex parts less than
#: the centre). Anchors' feet farther apart than this many times the centres' path between
#: them: the closest point jumped (across a groove, between two sheets) or the surface
#: curves concavely tighter than twice the distance, and seeds interpolated between those
#: feet can start in another local minimum's basin (:func:`_unsure_between`).
FOOT_SPREAD = 2.0

#: Newton steps for a ball's contact searched from the nearest surface sample, then more
#: while a step still moves the foot by over
#: :data:`~.local.CONVERGED_MM` (from the nearest sample, three leave the gap within
#: 1e-12 mm of six on the dev blade).
BALL_CONTACT_NEWTON = 3

#: Newton steps for a ball's contact searched from a seed its neighbours give (between
#: anchors: their feet interpolated; inside a move: its ends' feet interpolated), then
#: more while a step still moves the foot by over :data:`~.local.CONVERGED_MM` (the next
#: would move it by about that squared over the radius of curvature): such a seed lies
#: near the foot, and the fixed steps every point paid for beyond the first changed the
#: gaps by at most 1.4e-10 mm against six steps on bench_toolpath's rows (seeds' ``t``,
#: ``s`` by 3e-8).
SEEDED_CONTACT_NEWTON = 1

#: Newton steps for each disc point of a flat or bull-nose cutter's contact, searched
#: from the nearest surface sample (:func:`~.sampling.cutter_gap`: ``newton + 1`` fixed
#: steps), then more while a step still moves the foot by over
#: :data:`~.local.CONVERGED_MM`. The steps beyond those the feet still need changed no
#: gap: against six, the 30 bull-nose plans of ``bench_toolpath.py --sweep`` and the
#: real-like blades' flat and bull-nose jobs read the same figures to 1e-9 mm, and the
#: chord measure took 10-15 % less time (one step fewer took no less).
DISC_CONTACT_NEWTON = 2


def measure_chord(toolpath: Toolpath, surface: ParametricSurface, cutter: Cutter,
                  samples: SurfaceSamples, *, machine: Machine | None = None,
                  chunk: int = 100_000, contact_stride: int = CONTACT_STRIDE,
                  end_slopes: bool = True,
                  seeded_newton: int = SEEDED_CONTACT_NEWTON,
                  disc_newton: int = DISC_CONTACT_NEWTON) -> ChordMeasurement:
    """Measure the chord error of ``toolpath`` (module docstring).

    With the 5-axis ``machine`` whose joint interpolation the toolpath was checked under
    (``Toolpath.joints_checked_for``: the post then leaves them whole), the cutter inside
    each move is placed as that interpolation places it (the tip bows off the chord
    where rotary axes turn). ``contact_stride``: a ball's contacts searched from the
    nearest surface sample at every this many locations along a run of cutting moves,
    the others from theirs (:func:`_run_anchors`) unless their foot may be a wrong local
    one (:func:`_unsure_between`); 1: every one from its sample, the full method.
    ``end_slopes``: the gap model from its exact slopes at the ends and the gap at
    ``u = 1/2`` (module docstring; a flat or bull-nose move whose gap may have a kink
    from three gaps); False: every move's from the gaps at ``u = 1/4, 1/2, 3/4`` (the
    full method). ``seeded_newton``: the Newton steps
    every ball contact seeded by its neighbours' feet takes (between anchors, inside
    moves), then more while the foot still moves (:data:`SEEDED_CONTACT_NEWTON`; more
    steps: the full method). ``disc_newton``: likewise for a flat or bull-nose cutter's
    contact searches (:data:`DISC_CONTACT_NEWTON`; 6: the full method).
    """
    joints = checked_joints(toolpath, machine)
    move = _cutting_moves(toolpath)
    if not move.size:
        return ChordMeasurement(0.0, 0.0, 0.0, -1, 0.0, 0)
    contacts = _end_contacts(toolpath, surface, cutter, samples, move, chunk, contact_stride,
                             seeded_newton, disc_newton)
    contact = float(np.abs(contacts.gap).max())
    # under joint interpolation, d(n . C)/dq at every location, once: a location ends one
    # move and starts the next, with the same contact normal (:func:`_contact_gradient`)
    ball = cutter.kind is CutterKind.BALL
    gradient = None
    if joints is not None and end_slopes:
        gradient = _contact_gradient(machine, joints[contacts.points], cutter, contacts.normal,
                                     contacts.axes, None if ball else contacts.off_axis)
    worst = np.zeros(move.size)
    over = under = 0.0
    seeds: list[tuple[NDArray[np.float64], ...]] = []
    for rows, moved_by_joints in _interpolation_groups(toolpath, move, joints is not None):
        for lo in range(0, rows.size, chunk):
            at = rows[lo:lo + chunk]
            seg = move[at]
            ends, ia, ib = contacts.of_moves(toolpath, seg)
            interpolation = ((machine, joints[seg], joints[seg + 1]) if moved_by_joints
                             else None)
            slopes = off_axis = None
            if not ball:
                off_axis = (contacts.off_axis_rows(ia), contacts.off_axis_rows(ib))
            if end_slopes:
                # (tip-linear: read from the contacts where they lie, no rows gathered)
                slopes = (contacts.tip_linear_slopes(cutter.corner_radius_mm, ia)
                          if interpolation is None else
                          _end_slopes(cutter, ends, contacts.normal[ia], contacts.normal[ib],
                                      interpolation,
                                      None if gradient is None or not moved_by_joints
                                      else (gradient[ia], gradient[ib]), off_axis))
            gap, mid = _move_chunk_gaps(surface, cutter, ends, contacts.gap[ia],
                                        contacts.gap[ib], max(contact, over, under),
                                        interpolation, slopes, seeded_newton, samples,
                                        off_axis)
            worst[at] = np.abs(gap).max(axis=1)
            over = max(over, float(-gap.min()))
            under = max(under, float(gap.max()))
            seeds.append(_cusp_seeds(surface, contacts, ia, ends, mid,
                                     toolpath.pass_index[seg]))
    i = int(np.argmax(worst))
    contact_t = np.full(len(toolpath.kinds), np.nan)
    contact_s = contact_t.copy()
    contact_t[contacts.points], contact_s[contacts.points] = contacts.t, contacts.s
    seeds_t, seeds_s, seeds_p, seeds_q, seeds_n, seeds_x_s = (
        np.concatenate(column) for column in zip(*seeds, strict=True))
    return ChordMeasurement(max_mm=float(worst[i]), overcut_mm=max(over, 0.0),
                            undercut_mm=max(under, 0.0), worst_point=int(move[i] + 1),
                            contact_mm=contact, n_moves=int(move.size), seeds_t=seeds_t,
                            seeds_s=seeds_s, seeds_pass=seeds_p.astype(np.int64),
                            seeds_q=seeds_q, seeds_n=seeds_n, seeds_x_s=seeds_x_s,
                            contact_t=contact_t, contact_s=contact_s)


def _cutting_moves(toolpath: Toolpath) -> NDArray[np.int64]:
    """First points of the cutting moves from a point of a pass to a point of a pass."""
    kinds, passes = toolpath.kinds, toolpath.pass_index
    return np.flatnonzero((kinds[1:] == MoveKind.CUT) & (passes[1:] >= 0) & (passes[:-1] >= 0))


def _interpolation_groups(toolpath: Toolpath, move: NDArray[np.int64], checked: bool
                          ) -> list[tuple[NDArray[np.int64], bool]]:
    """The rows of ``move`` and whether the joints move them (else tip-linear).

    On a path checked under a machine's joint interpolation (``checked``) the post leaves
    the cutting moves of a pass whole (:func:`~toolpath.joint_refine.checked_moves`): the
    joints move them. A cutting move from one pass to the next (spiral linking) it splits
    until its tip keeps to the chord: tip-linear, as the cut volume places it
    (:class:`~.cut_volume.CutVolume`). One group where all are alike (the moves' order
    kept).
    """
    rows = np.arange(move.size)
    if not checked:
        return [(rows, False)]
    whole = checked_moves(toolpath.kinds, toolpath.pass_index).take(move)
    if whole.all():
        return [(rows, True)]
    return [(rows[whole], True), (rows[~whole], False)]


@dataclass(frozen=True)
class _EndContacts:
    """The contact of the cutter at every point ``points`` ending a cutting move.

    ``gap`` (mm), the contact's ``t``, ``s``, its surface point (mm), outward unit normal
    and ``X_s`` (mm per unit ``s``); the cutter's tip (mm) and axis there.
    """

    points: NDArray[np.int64]
    gap: NDArray[np.float64]
    t: NDArray[np.float64]
    s: NDArray[np.float64]
    point: NDArray[np.float64]
    normal: NDArray[np.float64]
    x_s: NDArray[np.float64]
    tips: NDArray[np.float64]
    axes: NDArray[np.float64]
    #: Where the contact's point ``K = X + (gap + r) n`` lies off the axis, in the disc's
    #: plane: ``K - tip - r a`` (mm; a flat or bull-nose cutter's, (0, 3) for a ball's).
    off_axis: NDArray[np.float64]

    def of_moves(self, toolpath: Toolpath, first: NDArray[np.int64]
                 ) -> tuple[MoveEnds, NDArray[np.int64], NDArray[np.int64]]:
        """Moves ``first -> first + 1``: their ends with the contacts, and the ends' rows."""
        ia = np.searchsorted(self.points, first)
        ib = ia + 1
        pos, axes = toolpath.positions_mm, toolpath.tool_axes
        # (``take`` gathers rows of (n, 3) arrays several times faster than indexing)
        after = first + 1
        ends = MoveEnds(pos.take(first, axis=0), pos.take(after, axis=0),
                        axes.take(first, axis=0), axes.take(after, axis=0),
                        self.t.take(ia), self.t.take(ib), self.s.take(ia), self.s.take(ib))
        return ends, ia, ib

    def tip_linear_slopes(self, corner_mm: float, first: NDArray[np.int64]
                          ) -> NDArray[np.float64]:
        """``g'(0)``, ``g'(1)`` along tip-linear moves from rows ``first``, mm per ``u``.

        :func:`_end_slopes` without joints: the same numbers, read where they lie (the
        rows ``first`` and ``first + 1`` end each move), no rows of the moves' ends
        gathered and interleaved.
        """
        return contact_end_slopes(corner_mm, self.tips, self.axes, self.normal,
                                  self.off_axis, first)

    def off_axis_rows(self, rows: NDArray[np.int64]) -> NDArray[np.float64]:
        """:attr:`off_axis` at ``rows`` ((0, 3) for a ball's contacts)."""
        return self.off_axis if not len(self.off_axis) else self.off_axis.take(rows, axis=0)


def _end_contacts(toolpath: Toolpath, surface: ParametricSurface, cutter: Cutter,
                  samples: SurfaceSamples, move: NDArray[np.int64], chunk: int,
                  stride: int, seeded_newton: int = SEEDED_CONTACT_NEWTON,
                  disc_newton: int = DISC_CONTACT_NEWTON) -> _EndContacts:
    """The contact of every cutter location on a cutting move ``move``, once.

    Seeded by the surface sample nearest to the cutter's centre (ball) or corner-circle
    centre on the axis (:func:`_contact_gaps`), ``chunk`` locations at a time. A ball's
    locations between the anchors :func:`_run_anchors` picks (every ``stride``-th) are
    seeded from the anchors' contacts instead, interpolated along the run (as
    :func:`~.sampling.move_gaps` seeds the points inside a move): a nearest-sample search of a
    point a radius off the surface costs several times its Newton search, which takes
    ``seeded_newton`` steps there, then more while the foot moves. Those whose
    foot may be a wrong local one (:func:`_unsure_between`) are then searched from their
    own nearest sample after all. Where the surface gives a ball centre's closest point
    in closed form (``closest_parameters``: a sphere), that is every location's seed (and
    its foot): no samples, no anchors.
    """
    pos, axes = toolpath.positions_mm, toolpath.tool_axes
    at_end = np.zeros(len(toolpath.kinds), dtype=bool)
    at_end[move] = at_end[move + 1] = True
    ends = np.flatnonzero(at_end)
    ball = cutter.kind is CutterKind.BALL
    lift = cutter.radius_mm if ball else cutter.corner_radius_mm
    tips, tool_axes = pos.take(ends, axis=0), axes.take(ends, axis=0)
    centres = tips + lift * tool_axes
    # a ball's contact is its centre's closest point: where the surface gives that in
    # closed form (a sphere), it is every location's own seed, exact
    closest = getattr(surface, "closest_parameters", None) if ball else None
    feet = closest(centres) if closest is not None and ends.size else None
    runs = _run_anchors(ends, move, centres, stride if ball and feet is None else 1)
    gap, t, s = np.empty(ends.size), np.empty(ends.size), np.empty(ends.size)

    def search_from_samples(rows: NDArray[np.int64]) -> None:
        t0, s0 = np.empty(rows.size), np.empty(rows.size)
        seeded = np.zeros(rows.size, dtype=bool)
        if feet is not None:
            seeded = feet[2][rows]
            t0[seeded], s0[seeded] = feet[0][rows[seeded]], feet[1][rows[seeded]]
        if not seeded.all():
            nearest = _nearest_samples(samples, centres[rows[~seeded]], lift)
            t0[~seeded], s0[~seeded] = samples.t[nearest], samples.s[nearest]
        for lo in range(0, rows.size, chunk):
            part = rows[lo:lo + chunk]
            gap[part], t[part], s[part] = _contact_gaps(
                surface, cutter, samples, tips[part], tool_axes[part],
                t0[lo:lo + chunk], s0[lo:lo + chunk], disc_newton)

    search_from_samples(runs.anchor)
    if not ball:
        _mend_from_neighbours(surface, cutter, tips, tool_axes, (gap, t, s),
                              _run_pairs(ends, move))
    between, before, after, w = runs.between, runs.before, runs.after, runs.w
    if between.size:
        t0 = seam_lerp_rows(t[before], t[after], w[:, None], bool(surface.closed_t)).ravel()
        s0 = s[before] + w * (s[after] - s[before])
        gap[between], t[between], s[between] = cutter_gap(
            surface, cutter, tips[between], tool_axes[between], t0, s0,
            newton=seeded_newton)
    point, normal, x_s = _points_normals_x_s(surface, t, s)
    unsure = _unsure_between(runs, centres, point, gap) if between.size else between
    if unsure.size:
        search_from_samples(unsure)
        point[unsure], normal[unsure], x_s[unsure] = _points_normals_x_s(surface, t[unsure],
                                                                         s[unsure])
    off_axis = (np.zeros((0, 3)) if ball
                else _off_axis(point, normal, gap, lift, tips, tool_axes))
    return _EndContacts(ends, gap, t, s, point, normal, x_s, tips, tool_axes, off_axis)


#: The nearest sample of a point ``lift`` off the surface is first sought within
#: ``lift`` and this many sample spacings (:func:`_nearest_samples`).
NEAREST_REACH_SPACINGS = 1.0


def _nearest_samples(samples: SurfaceSamples, points: NDArray[np.float64], lift_mm: float
                     ) -> NDArray[np.int64]:
    """The index of the sample nearest to each point (a cutter point ``lift_mm`` off).

    A cutter location's point stands about ``lift_mm`` off the surface, whose samples lie
    :attr:`~.gouge.SurfaceSamples.spacing_mm` apart: the nearest sample is first sought
    within ``lift_mm`` and :data:`NEAREST_REACH_SPACINGS` spacings, among the samples'
    cells (:meth:`~.gouge.SurfaceSamples.nearest`: those the gouge check binned, no k-d
    tree to build); the nearest sample within that reach is the nearest of all. The
    points with none there (lifted higher) are asked of the k-d tree without a reach:
    the same samples as one unbounded query (of two as near, either).
    """
    nearest = samples.nearest(points, lift_mm + NEAREST_REACH_SPACINGS * samples.spacing_mm)
    missed = np.flatnonzero(nearest < 0)
    if missed.size:
        nearest[missed] = samples.tree.query(points[missed], k=1,
                                             workers=query_workers(missed.size))[1]
    return nearest


def _points_normals_x_s(surface: ParametricSurface, t: NDArray[np.float64],
                        s: NDArray[np.float64]) -> tuple[NDArray[np.float64], ...]:
    """Surface points, outward unit normals and ``X_s`` at ``t``, ``s`` (one evaluation)."""
    parts = surface.partials_many(t, s, ((0, 0), (1, 0), (0, 1)))
    return parts[0, 0], outward_normals(surface, parts[1, 0], parts[0, 1]), parts[0, 1]


def _unsure_between(runs: _Runs, centres: NDArray[np.float64], feet: NDArray[np.float64],
                    gap: NDArray[np.float64]) -> NDArray[np.int64]:
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
    Rows index ``centres``, the feet's points ``feet`` and ``gap`` (every location).
    """
    between, before, after = runs.between, runs.before, runs.after
    here = centres.take(between, axis=0)

    def apart(a: NDArray[np.float64], rows: NDArray[np.int64]) -> NDArray[np.float64]:
        d = a - feet.take(rows, axis=0)  # (row norms by einsum: a third of norm's time)
        return np.sqrt(np.einsum("ij,ij->i", d, d))

    own = apart(here, between)
    # the run's locations are consecutive rows: between - 1 and between + 1 are on it
    nearer = np.zeros(between.size, dtype=bool)
    for other in (before, after, between - 1, between + 1):
        nearer |= apart(here, other) < own - FOOT_SLACK_MM
    spread = apart(feet.take(after, axis=0), before)
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


def _run_pairs(ends: NDArray[np.int64], move: NDArray[np.int64]) -> NDArray[np.int64]:
    """Rows ``j`` of ``ends`` joined to row ``j + 1`` by a cutting move (the same run)."""
    if ends.size < 2:
        return np.zeros(0, dtype=np.int64)
    joined = np.zeros(int(ends[-1]) + 1, dtype=bool)
    joined[move] = True
    return np.flatnonzero(joined[ends[:-1]] & (ends[1:] == ends[:-1] + 1))


#: Rounds of :func:`_mend_from_neighbours`: a mended contact is offered on to its own
#: neighbours, this many locations along the run at most.
NEIGHBOUR_ROUNDS = 8

#: A flat or bull-nose contact's gap above a run neighbour's by more than this (mm) is
#: searched again from the neighbour's contact (:func:`_mend_from_neighbours`): a tenth
#: of a micrometre, above the searches' spread between neighbours that both touch
#: (1e-5 mm round dev_rotor_dca's leading edge) and far below any chord tolerance.
GAP_JUMP_MM = 1e-4


def _mend_from_neighbours(surface: ParametricSurface, cutter: Cutter,
                          tips_mm: NDArray[np.float64], axes: NDArray[np.float64],
                          found: tuple[NDArray[np.float64], ...], pairs: NDArray[np.int64]
                          ) -> None:
    """Flat and bull-nose contacts whose foot a run neighbour's contact shows wrong, searched again.

    ``found``: every location's gap, ``t``, ``s`` (:func:`_contact_gaps`), mended in place;
    ``pairs``: rows ``j`` whose location ``j + 1`` follows on the same run
    (:func:`_run_pairs`). Where two sheets of the surface pass within a sample spacing of
    each other (the sides of open sections meeting at a blunt trailing edge, 0.06-0.13 mm
    apart on the dev blade), the nearest sample can lie on the other sheet, and the
    contact search stays there: a foot whose normal faces away reads the cutter as
    cutting through the part (0.196 mm on the dev blade's flat:6 3-axis job at a pass's
    end over the trailing edge, where the surface rises 0.006 mm into the cutter at most).
    The sample guard of :func:`_contact_gaps` cannot see it: the wrong foot stands nearer
    than any sample. So the cutter point ``K = X + (gap + r) n`` of each contact is also
    projected from each run neighbour's contact: a foot nearer to ``K`` than its own (by
    more than :data:`FOOT_SLACK_MM`) shows its own is not ``K``'s closest point, and the
    location is searched again from there. And a gap above a run neighbour's by more
    than :data:`GAP_JUMP_MM` may have missed the disc's lowest point (its rim dipping
    between the samples the search took, round an edge tighter than the disc): it is
    searched again from the neighbour's contact and the lower reading kept, unless it
    reads below the neighbour's by as much (dev_rotor_dca's
    5-axis flat:6 job at scallop 0.01 mm: a pose over the leading edge, searched from the
    surface sample nearest its disc's centre, on the hub edge, read 0.036 mm of undercut
    between neighbours that touch; from a neighbour's contact it touches too). Mended
    locations are offered on to their
    neighbours, for :data:`NEIGHBOUR_ROUNDS` rounds or until none is mended.
    """
    gap, t, s = found
    r = cutter.corner_radius_mm
    todo = np.ones(len(gap), dtype=bool)
    for _ in range(NEIGHBOUR_ROUNDS):
        mended = np.zeros(len(gap), dtype=bool)
        for src, dst in ((pairs, pairs + 1), (pairs + 1, pairs)):
            live = todo[src] | todo[dst]
            src, dst = src[live], dst[live]
            if not src.size:
                continue
            x, n = surface.points_and_normals(t[dst], s[dst])
            k = x + (gap[dst] + r)[:, None] * n
            t1, s1, d1 = project_to_surface(surface, k, t[src], s[src], iterations=6)
            wrong = d1 < np.abs(gap[dst] + r) - FOOT_SLACK_MM
            rows = dst[wrong]
            if rows.size:
                gap[rows], t[rows], s[rows] = cutter_gap(
                    surface, cutter, tips_mm[rows], axes[rows], t1[wrong], s1[wrong],
                    newton=6, refine_rim=True)
                mended[rows] = True
            # a reading above its neighbour's may have missed the disc's lowest point
            higher = gap[dst] > gap[src] + GAP_JUMP_MM
            rows = dst[higher]
            if rows.size:
                g2, t2, s2 = cutter_gap(surface, cutter, tips_mm[rows], axes[rows],
                                        t[src[higher]], s[src[higher]], newton=6,
                                        refine_rim=True)
                # (lower, not below the neighbour's by the jump: the far sheet's foot of a
                # blunt edge reads through the part from there)
                lower = (g2 < gap[rows] - FOOT_SLACK_MM) & (g2 >= gap[src[higher]] - GAP_JUMP_MM)
                rows = rows[lower]
                gap[rows], t[rows], s[rows] = g2[lower], t2[lower], s2[lower]
                mended[rows] = True
        if not mended.any():
            return
        todo = mended


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
    arc = np.concatenate([[0.0], np.cumsum(row_lengths(np.diff(centres, axis=0)))])
    span = arc[after] - arc[before]
    w = np.where(span > 0.0, (arc[between] - arc[before]) / np.where(span > 0.0, span, 1.0),
                 (between - before) / (after - before))
    return _Runs(np.flatnonzero(anchor), between, before, after, w, span)


def _move_chunk_gaps(surface: ParametricSurface, cutter: Cutter, ends: MoveEnds,
                     gap_a: NDArray[np.float64], gap_b: NDArray[np.float64], top_mm: float,
                     joints: JointEnds | None, slopes: NDArray[np.float64] | None,
                     seeded_newton: int = SEEDED_CONTACT_NEWTON,
                     samples: SurfaceSamples | None = None,
                     off_axis: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
                     ) -> tuple[NDArray[np.float64], tuple[NDArray[np.float64], ...]]:
    """Gaps along moves: at both ends, inside, and at the model's extremes.

    Measured at ``CHORD_FRACTIONS`` (with the ends' ``slopes`` ``g'(0)``, ``g'(1)``, at
    ``u = 1/2`` only; a flat or bull-nose move that :func:`_contact_jumps` marks, at
    ``1/4`` and ``3/4`` too, its model from the three gaps: ``off_axis``, the ends' lowest
    points off the axis, tells), then once more where the gap model through them is lowest
    and where it is highest (:func:`~.sampling.chord_extremes`), on the moves whose
    extreme could be the largest: within half of the largest gap so far (``top_mm`` and
    the places measured). ``joints``: the moves' ends under a machine's joint
    interpolation, as for :func:`~.sampling.move_gaps`. A ball's Newton search takes
    ``seeded_newton`` steps and more while its foot moves (seeded between the ends'
    feet), a flat or bull-nose cutter's two; with ``samples``, its feet checked against
    them (:func:`_inside_gaps`).

    Returns ``gap`` (m, k + 4, or k + 6 for a flat or bull-nose cutter with slopes: end,
    the k places, the places 1/4 and 3/4 (0 where not measured), lowest, highest, end) and
    the gap, ``t`` and ``s`` at ``u = 1/2`` (m,).
    """
    u = np.asarray((0.5,) if slopes is not None else CHORD_FRACTIONS, dtype=float)
    m = len(gap_a)
    ball = cutter.kind is CutterKind.BALL
    newton = seeded_newton if ball else 2
    g3, t3, s3 = _inside_gaps(surface, cutter, samples, ends, np.broadcast_to(u, (m, u.size)),
                              newton, joints)
    low, u_low, high, u_high = chord_extremes(g3, u, end_slopes=slopes)
    # where a flat or bull-nose contact jumps across the disc, its slopes do not hold:
    # those moves' models from three gaps, as without slopes
    quarters = np.zeros((m, 0))
    if slopes is not None and not ball and m:
        jumped = _contact_jumps(surface, cutter, ends, off_axis, (g3[:, 0], t3[:, 0], s3[:, 0]),
                                joints)
        quarters = np.zeros((m, 2))
        if jumped.size:
            u_q = np.broadcast_to(np.array([CHORD_FRACTIONS[0], CHORD_FRACTIONS[2]]),
                                  (jumped.size, 2))
            quarters[jumped] = _inside_gaps(surface, cutter, samples, ends.take(jumped), u_q,
                                            newton, _joint_rows(joints, jumped))[0]
            three = np.column_stack([quarters[jumped, 0], g3[jumped, 0], quarters[jumped, 1]])
            low[jumped], u_low[jumped], high[jumped], u_high[jumped] = chord_extremes(three)
    top = max(float(np.abs(g3).max()), float(np.abs(quarters).max(initial=0.0)), top_mm)
    # (a ball's undercuts are resolved as its overcuts, within half of their own largest:
    # the model's from its slopes has no samples at 1/4 and 3/4 to show them)
    # (gaps under UNDERCUT_NOISE of the largest are the projection's rounding: a pass that
    # only overcuts has its model's highest point at an end, where it is known already)
    tops = (top, top if slopes is None else max(float(high.max()), float(g3.max()),
                                                float(quarters.max(initial=0.0)),
                                                UNDERCUT_NOISE * top))
    g_star = np.zeros((m, 2))
    for col, (value, u_at) in enumerate(((low, u_low), (high, u_high))):
        sel = np.flatnonzero(np.abs(value) >= 0.5 * tops[col])
        if sel.size:
            those = ends.take(sel)
            start = None if slopes is None or not ball else _feet_between(
                those, t3[sel, 0], s3[sel, 0], u_at[sel], bool(surface.closed_t))
            g_star[sel, col] = _inside_gaps(surface, cutter, samples, those, u_at[sel, None],
                                            newton, _joint_rows(joints, sel), start)[0][:, 0]
    gap = np.concatenate([gap_a[:, None], g3, quarters, g_star, gap_b[:, None]], axis=1)
    mid = int(np.argmin(np.abs(u - 0.5)))
    return gap, (g3[:, mid], t3[:, mid], s3[:, mid])


def _inside_gaps(surface: ParametricSurface, cutter: Cutter, samples: SurfaceSamples | None,
                 ends: MoveEnds, u: NDArray[np.float64], newton: int,
                 joints: JointEnds | None,
                 start: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
                 ) -> tuple[NDArray[np.float64], ...]:
    """:func:`~.sampling.move_gaps` at ``u`` (m, k), a flat or bull-nose cutter's checked.

    The search inside a move starts between its ends' feet; over a tight edge (the
    small circles of a blunt leading edge) a disc point's search from there can end in
    another sheet's local minimum, whose normal faces away: 2.84 mm of overcut read on
    dev_rotor_blunt's flat:6 3-axis job inside a 0.0006 mm move whose ends touch. With
    ``samples``, the flat and bull-nose feet are checked against them as the contacts'
    are (:func:`_mend_from_samples`, at the same poses). Returns ``gap, t, s`` (m, k).
    """
    found = move_gaps(surface, cutter, ends, u, newton=newton, refine_rim=True,
                      joints=joints, start=start)
    if samples is not None and cutter.kind is not CutterKind.BALL and found[0].size:
        tips, axes = move_poses(ends, np.ascontiguousarray(u, dtype=float), joints)
        flat = tuple(np.ascontiguousarray(x).ravel() for x in found)
        _mend_from_samples(surface, cutter, samples, tips, axes, flat)
        found = tuple(x.reshape(u.shape) for x in flat)
    return found


#: A flat or bull-nose contact whose point on the cutter turns round the axis by more than
#: this between a move's end and its middle is taken as jumped across the disc
#: (:func:`_contact_jumps`), deg.
CONTACT_TURN_DEG = 30.0

#: ... or whose point stands within this of the axis (mm): a face level with the surface,
#: whose lowest point is anywhere on it.
LEVEL_OFF_AXIS_MM = 1e-3


def _contact_jumps(surface: ParametricSurface, cutter: Cutter, ends: MoveEnds,
                   off_axis: tuple[NDArray[np.float64], NDArray[np.float64]],
                   middle: tuple[NDArray[np.float64], ...], joints: JointEnds | None
                   ) -> NDArray[np.int64]:
    """Moves whose flat or bull-nose gap may have a kink: their end slopes do not hold.

    The slopes of :func:`_end_slopes` hold where the contact's point ``K*`` moves
    continuously along the cutter and its foot is a closest point inside the surface.
    Where the surface lies almost level under the disc, or two of its points stand lowest
    (round a tight edge, over a crest), ``K*`` jumps and the gap has a kink. ``K*`` off
    the axis (``off_axis`` at the ends; at the middle from its gap, ``t``, ``s``:
    ``middle``) turning by more than :data:`CONTACT_TURN_DEG` from either end to the
    middle, or one of them within :data:`LEVEL_OFF_AXIS_MM` of the axis (a face level
    with the surface, whose lowest point is anywhere on it), marks the move; so does a foot on an
    open edge of the surface at either end or the middle (there the distance's gradient
    is not the normal, and the gap's sign flips where the foot leaves the edge).
    """
    gap, t, s = middle
    on_edge = np.zeros(len(gap), dtype=bool)
    for tt, ss in ((ends.t_a, ends.s_a), (t, s), (ends.t_b, ends.s_b)):
        on_edge |= (ss <= 0.0) | (ss >= 1.0)
        if not surface.closed_t:
            on_edge |= (tt <= 0.0) | (tt >= 1.0)
    tips, axes = move_poses(ends, np.full((len(gap), 1), 0.5), joints)
    off_mid = _off_axis(*surface.points_and_normals(t, s), gap, cutter.corner_radius_mm,
                        tips, axes)
    cos_limit = np.cos(np.radians(CONTACT_TURN_DEG))
    mid_len = row_lengths(off_mid)
    jumped = on_edge | (mid_len < LEVEL_OFF_AXIS_MM)
    for off in off_axis:
        length = row_lengths(off)
        cos = np.einsum("ij,ij->i", off, off_mid) / np.maximum(length * mid_len, TINY)
        jumped |= (length < LEVEL_OFF_AXIS_MM) | (cos < cos_limit)
    return np.flatnonzero(jumped)


def _off_axis(point: NDArray[np.float64], normal: NDArray[np.float64],
              gap: NDArray[np.float64], corner_mm: float, tips: NDArray[np.float64],
              axes: NDArray[np.float64]) -> NDArray[np.float64]:
    """Where a contact's point ``K = X + (gap + r) n`` lies off the axis: ``K - P - r a``.

    ``point``, ``normal``: the foot ``X`` and its unit normal; ``tips``, ``axes``: the
    pose's ``P`` and ``a``; ``corner_mm``: ``r``. Returns (m, 3), mm.
    """
    return point + gap[:, None] * normal + corner_mm * (normal - axes) - tips


def _feet_between(ends: MoveEnds, t_mid: NDArray[np.float64], s_mid: NDArray[np.float64],
                  u: NDArray[np.float64], closed: bool
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Where a ball's search at ``u`` along each move starts: its three feet's parabola.

    The feet of the centre at ``u = 0, 1/2, 1`` (the contacts and the middle's ``t_mid``,
    ``s_mid``) are known; the parameters through them quadratic in ``u`` (Lagrange,
    ``t`` unwrapped within half a turn of the first foot on ``closed`` surfaces, then
    folded) leave the seed off the foot by the third derivative of the foot's path
    times ``u (u - 1/2)(u - 1) / 6``, where the ends' chord alone leaves the second's
    times ``u (1 - u) / 2``: the Newton search from there mostly stops after its first
    step (:data:`SEEDED_CONTACT_NEWTON`; then more while the foot moves), on the same
    foot. Returns ``t``, ``s`` (m, 1).
    """
    la, lm, lb = 2.0 * (u - 0.5) * (u - 1.0), 4.0 * u * (1.0 - u), 2.0 * u * (u - 0.5)
    dt_mid, dt_b = t_mid - ends.t_a, ends.t_b - ends.t_a
    if closed:
        dt_mid, dt_b = dt_mid - np.round(dt_mid), dt_b - np.round(dt_b)
    t = ends.t_a + lm * dt_mid + lb * dt_b
    s = la * ends.s_a + lm * s_mid + lb * ends.s_b
    return (np.mod(t, 1.0) if closed else t)[:, None], s[:, None]


def _end_slopes(cutter: Cutter, ends: MoveEnds, normal_a: NDArray[np.float64],
                normal_b: NDArray[np.float64], joints: JointEnds | None,
                gradient: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None,
                off_axis: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
                ) -> NDArray[np.float64]:
    """``g'(0)``, ``g'(1)`` of the cutter's gap along each move, mm per unit ``u`` (m, 2).

    By the envelope theorem the rate of the distance at the contact's point ``K*`` held
    on the moving cutter: ``n . dK*/du``, ``n`` the unit normal at that end's contact
    (``normal_a``, ``normal_b``), ``K*`` off the axis by ``off_axis`` (the ends' rows of
    :attr:`_EndContacts.off_axis`; None: on it, a ball's centre). Tip-linear: exactly
    (:func:`~.sampling.contact_end_slopes`); under the machine's ``joints``, linear in
    ``u`` at the rates ``q_b - q_a``: ``d(n . K*)/dq . (q_b - q_a)``, exactly, with
    ``gradient`` the ends' ``d(n . K*)/dq`` (:func:`_contact_gradient`;
    :func:`measure_chord` gives it, once per location; computed here when not given): no
    poses inside the move.
    """
    m = len(normal_a)
    if joints is None:
        tips = np.stack([ends.tips_a, ends.tips_b], axis=1).reshape(-1, 3)
        axes = np.stack([ends.axes_a, ends.axes_b], axis=1).reshape(-1, 3)
        normals = np.stack([normal_a, normal_b], axis=1).reshape(-1, 3)
        off = (np.zeros((0, 3)) if off_axis is None
               else np.stack(off_axis, axis=1).reshape(-1, 3))
        return contact_end_slopes(cutter.corner_radius_mm, tips, axes, normals, off,
                                  np.arange(0, 2 * m, 2))
    machine, q_a, q_b = joints
    if gradient is None:
        no_off = (None, None) if off_axis is None else off_axis
        gradient = (_contact_gradient(machine, q_a, cutter, normal_a, ends.axes_a, no_off[0]),
                    _contact_gradient(machine, q_b, cutter, normal_b, ends.axes_b, no_off[1]))
    rate = q_b - q_a
    out = np.empty((m, 2))
    out[:, 0] = np.einsum("ij,ij->i", gradient[0], rate)
    out[:, 1] = np.einsum("ij,ij->i", gradient[1], rate)
    return out


def _contact_gradient(machine: Machine, joints: NDArray[np.float64], cutter: Cutter,
                      normals: NDArray[np.float64], axes: NDArray[np.float64],
                      off_axis: NDArray[np.float64] | None) -> NDArray[np.float64]:
    """``d(n . K*)/dq`` per location, ``K*`` the contact's point held on the cutter.

    ``K* = P + r a + d`` (``d = off_axis``, in the disc's plane; None: a ball's centre,
    on the axis): its rate is ``(P + r a)' + w x d`` for the cutter's turn ``w``, whose
    part about the axis moves ``K*`` along the disc (where the distance is stationary)
    and whose rest is ``a x a'``, so ``n . K*' = n . (P + r a)' - (n . a)(a' . d)``:
    :func:`~machines.kinematics.tool_point_gradient` of ``n`` at ``r`` up the axis, less
    ``n . a`` times that of ``d`` at 1 less at 0 (``a' . d``).
    """
    r = cutter.corner_radius_mm
    gradient = tool_point_gradient(machine, joints, r, normals)
    if off_axis is not None and len(off_axis):
        turn = (tool_point_gradient(machine, joints, 1.0, off_axis)
                - tool_point_gradient(machine, joints, 0.0, off_axis))
        gradient -= np.einsum("ij,ij->i", normals, axes)[:, None] * turn
    return gradient


def _joint_rows(joints: JointEnds | None, rows: NDArray[np.int64]) -> JointEnds | None:
    """The moves ``rows`` of moves' ends under joint interpolation (None stays None)."""
    return None if joints is None else (joints[0], joints[1][rows], joints[2][rows])


def _cusp_seeds(surface: ParametricSurface, contacts: _EndContacts, first: NDArray[np.int64],
                ends: MoveEnds, mid: tuple[NDArray[np.float64], ...],
                passes: NDArray[np.int32]) -> tuple[NDArray[np.float64], ...]:
    """Where the scallop search starts: ``t``, ``s``, pass, point, normal and ``X_s``.

    The cusps are highest where the moves stand highest: at the contacts (each move's
    first, rows ``first`` of ``contacts``), and at the middle of the moves that stand
    above the surface there (``mid``: the gap, ``t`` and ``s`` at ``u = 1/2``).
    """
    g_mid, t_mid, s_mid = mid
    is_above = g_mid > 0.0
    above = np.flatnonzero(is_above)
    m = len(g_mid)
    if not above.size:  # the contacts alone, in order (every move cuts into the surface)
        return (np.mod(ends.t_a, 1.0) if surface.closed_t else ends.t_a.copy(),
                ends.s_a.copy(), passes.copy(),
                *(frame.take(first, axis=0)
                  for frame in (contacts.point, contacts.normal, contacts.x_s)))
    # each move's contact, then its middle where that stands above the surface: the
    # contacts' rows among the seeds (after the middles of the moves before), and the
    # middles' right after theirs
    at = np.arange(m) + np.cumsum(is_above) - is_above
    mid_at = at[above] + 1
    n = m + above.size
    t_above = np.mod(t_mid[above], 1.0) if surface.closed_t else t_mid[above]
    seeds_t, seeds_s, seeds_pass = np.empty(n), np.empty(n), np.empty(n, dtype=passes.dtype)
    seeds_t[at] = np.mod(ends.t_a, 1.0) if surface.closed_t else ends.t_a
    seeds_t[mid_at] = t_above
    seeds_s[at], seeds_s[mid_at] = ends.s_a, s_mid[above]
    seeds_pass[at], seeds_pass[mid_at] = passes, passes[above]
    frames = []
    for contact, at_mid in zip((contacts.point, contacts.normal, contacts.x_s),
                               _points_normals_x_s(surface, t_above, s_mid[above]),
                               strict=True):
        frame = np.empty((n, 3))
        frame[at], frame[mid_at] = contact[first], at_mid
        frames.append(frame)
    return (seeds_t, seeds_s, seeds_pass, *frames)


#: A flat or bull-nose contact's foot farther from its corner-circle centre than the
#: sample nearest to that centre by more than this (mm) is not its closest point: a
#: micrometre, above the Newton search's residual on the foot and far below any chord
#: tolerance (:func:`_contact_gaps`).
FOOT_SLACK_MM = 1e-6


def _contact_gaps(surface: ParametricSurface, cutter: Cutter, samples: SurfaceSamples,
                  tips_mm: NDArray[np.float64], axes: NDArray[np.float64],
                  t0: NDArray[np.float64], s0: NDArray[np.float64],
                  disc_newton: int = DISC_CONTACT_NEWTON) -> tuple[NDArray[np.float64], ...]:
    """Gap, ``t`` and ``s`` of the cutter at each location, searched from ``(t0, s0)``.

    A flat or bull-nose cutter's disc points take ``disc_newton`` Newton steps, then
    more while the foot moves (:data:`DISC_CONTACT_NEWTON`).

    A foot found farther from its cutter point ``K = X + (gap + r) n`` than the sample
    nearest to ``K`` is not its closest point (that sample is a surface point nearer to
    ``K``): round a thin edge a search started on the
    far side ends there, and a flat cutter's rim just clear of the near side then reads
    as cutting through the part. Those locations are searched again from the sample
    nearest to ``K`` (twice at most).
    """
    ball = cutter.kind is CutterKind.BALL
    gap, t, s = cutter_gap(surface, cutter, tips_mm, axes, t0, s0,
                           newton=BALL_CONTACT_NEWTON if ball else disc_newton,
                           refine_rim=True)
    if not ball:
        _mend_from_samples(surface, cutter, samples, tips_mm, axes, (gap, t, s))
    return gap, t, s


def _mend_from_samples(surface: ParametricSurface, cutter: Cutter, samples: SurfaceSamples,
                       tips_mm: NDArray[np.float64], axes: NDArray[np.float64],
                       found: tuple[NDArray[np.float64], ...]) -> None:
    """Flat and bull-nose gaps whose foot a surface sample shows wrong, searched again.

    ``found``: the gap, ``t``, ``s`` of each pose, mended in place. A foot farther from
    its cutter point ``K = X + (gap + r) n`` than the sample nearest to ``K`` is not its
    closest point (that sample is a surface point nearer to ``K``): those poses are
    searched again from that sample (twice at most; :func:`_contact_gaps`).
    """
    gap, t, s = found
    r = cutter.corner_radius_mm
    rows = np.arange(len(tips_mm))
    for _ in range(2):
        x, n = surface.points_and_normals(t[rows], s[rows])
        k = x + (gap[rows] + r)[:, None] * n
        near_mm, near = samples.tree.query(k, workers=query_workers(len(k)))
        wrong = np.abs(gap[rows] + r) > near_mm + FOOT_SLACK_MM
        rows, near = rows[wrong], near[wrong]
        if not rows.size:
            return
        gap[rows], t[rows], s[rows] = cutter_gap(
            surface, cutter, tips_mm[rows], axes[rows], samples.t[near], samples.s[near],
            newton=6, refine_rim=True)
