"""The material a toolpath removes, queried along surface normals (the scallop's measure).

Only the toolpath's arrays, the cutter solid and, for a toolpath checked under a 5-axis
machine's joint interpolation, that machine. For a ball, exactly, the union of capsules
swept by the ball centre along each feed move (cut in pieces of ``R/8``, their ends placed
as the control places them: under a 5-axis machine's joint interpolation, by its forward
kinematics, within the passes; the leads and links, which the post splits until their tips
keep to their chords, tip-linear); for flat and bull-nose cutters, the union of the cutter
solid over the poses of each piece (tip linear, axis normalized-linear), the ray met at each
pose exactly and the earliest pose found by search (:mod:`.sweep_kernel`; a straight sweep
of the cutter's cross-section would carry its points ahead of and behind the contact under
``Q`` even where the axis turns them away, round a tight leading edge). Heights beyond the
horizon (10 times the request, at least 0.05 mm, :func:`cusp_horizon_mm`) count as *uncut*.
"""

from __future__ import annotations

from collections.abc import Iterator
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from machines import Machine
from machines.kinematics import forward

from ..joint_refine import checked_moves
from ..path import MoveKind, Toolpath
from ..tolerances import LENGTH_SLACK_MM, ROUND_OFF
from ..vectors import move_poses, row_lengths
from .clearance_kernel import (
    SampleCells,
    bin_samples,
    counts_within,
    pair_batches,
    pairs_within,
    points_box,
)
from .cutters import Cutter, CutterKind
from .measure_joints import checked_joints
from .sweep_kernel import (
    Motions,
    capsule_entries,
    centre_pieces,
    nearest_entries,
    piece_ends,
    piece_motions,
    ray_ranges,
    tip_plane_floors,
)

__all__ = ["HORIZON_SCALLOPS", "LEAST_HORIZON_MM", "NEAR_WIDTHS", "PIECE_SAG_SHARE",
           "CutVolume", "cusp_horizon_mm", "split_centres", "split_moves"]


def _feed_segments(toolpath: Toolpath, joints: NDArray[np.float64] | None
                   ) -> tuple[NDArray[np.float64] | None, ...]:
    """Ends of the feed moves that cut: tips, axes, pass, joints (None: tip-linear), start.

    Rapids and plunges do not cut; a move's pass is its start's (else its end's, else -1);
    ``start`` is the toolpath point each move leaves from.
    """
    k = toolpath.kinds[1:]
    cutting = (k == MoveKind.CUT) | (k == MoveKind.LINK) | (k == MoveKind.LEAD_IN) | (
        k == MoveKind.LEAD_OUT)
    i = np.flatnonzero(cutting)
    j = i + 1
    # (``take`` gathers rows of (n, k) arrays several times faster than indexing)
    p, a, pass_ = toolpath.positions_mm, toolpath.tool_axes, toolpath.pass_index
    start_pass = pass_.take(i)
    owner = np.where(start_pass >= 0, start_pass, pass_.take(j))
    ends = (None, None) if joints is None else (joints.take(i, axis=0), joints.take(j, axis=0))
    return (p.take(i, axis=0), p.take(j, axis=0), a.take(i, axis=0), a.take(j, axis=0),
            owner.astype(np.int64), *ends, i)


def _piece_counts(a: NDArray[np.float64], b: NDArray[np.float64], aa: NDArray[np.float64],
                  ab: NDArray[np.float64], step: float, reach_mm: float, sag_mm: float,
                  joints: tuple[Machine, NDArray[np.float64], NDArray[np.float64]] | None,
                  tip_linear: NDArray[np.bool_] | None = None) -> NDArray[np.int64]:
    """Pieces per move, so that the tip and the point ``reach_mm`` up the axis travel <= ``step``.

    Under joint interpolation (but the moves ``tip_linear``) also so that the straight
    pieces stay within about ``sag_mm`` of the bowed path (the bow at mid-move, ``d``,
    falls as ``d / n^2`` over ``n`` pieces).
    """
    c_a, c_b = a + reach_mm * aa, b + reach_mm * ab
    length = np.maximum(row_lengths(b - a), row_lengths(c_b - c_a))
    count = np.ceil(length / step)
    if joints is not None:
        machine, q_a, q_b = joints
        tip, axis = forward(machine, 0.5 * (q_a + q_b))
        bow = np.maximum(np.linalg.norm(tip - 0.5 * (a + b), axis=1),
                         np.linalg.norm(tip + reach_mm * axis - 0.5 * (c_a + c_b), axis=1))
        if tip_linear is not None:  # (few: worked out with the others, then dropped)
            bow[tip_linear] = 0.0
        count = np.maximum(count, np.ceil(np.sqrt(bow / sag_mm)))
    return np.maximum(count, 1).astype(np.int64)


def split_moves(a: NDArray[np.float64], b: NDArray[np.float64], aa: NDArray[np.float64],
                ab: NDArray[np.float64], step: float, reach_mm: float, sag_mm: float,
                joints: tuple[Machine, NDArray[np.float64], NDArray[np.float64]] | None = None,
                tip_linear: NDArray[np.bool_] | None = None) -> tuple[NDArray[np.float64], ...]:
    """Split moves ``a -> b`` (tips, axes ``aa -> ab``) into straight pieces.

    Each move gets :func:`_piece_counts` pieces: the tip and the point ``reach_mm`` up the
    axis travel at most ``step`` mm per piece, and under joint interpolation the pieces
    stay within about ``sag_mm`` of the bowed path. Returns the pieces' start and end tips,
    start and end axes, and the move each piece belongs to (in move order).

    The piece ends as the control places them: tips linear and axes renormalized, or,
    with ``joints = (machine, q_a, q_b)``, the joints linear and the pose their forward
    kinematics (the tip bows off the chord where the rotary axes turn) inside the move,
    its own ends at the move's ends (the poses ``q_a``, ``q_b`` were solved for); the moves
    ``tip_linear`` (a bool per move; None: none) tip-linear all the same (those the post
    splits until their tips keep to the chord, :func:`~toolpath.joint_refine.checked_moves`).
    """
    pieces, tips, axes = _inner_poses(a, b, aa, ab, step, reach_mm, sag_mm, joints,
                                      tip_linear)
    (p0, p1), (x0, x1) = piece_ends(a, b, tips, pieces), piece_ends(aa, ab, axes, pieces)
    return p0, p1, x0, x1, np.repeat(np.arange(len(a)), pieces)


def split_centres(a: NDArray[np.float64], b: NDArray[np.float64], aa: NDArray[np.float64],
                  ab: NDArray[np.float64], step: float, reach_mm: float, sag_mm: float,
                  joints: tuple[Machine, NDArray[np.float64], NDArray[np.float64]] | None
                  = None, tip_linear: NDArray[np.bool_] | None = None
                  ) -> tuple[NDArray[np.float64], ...]:
    """:func:`split_moves`' pieces as the points ``reach_mm`` up the axis (a ball's centres).

    The same pieces; their start and end points ``tip + reach_mm axis`` (the same numbers
    as :func:`split_moves`' tips and axes give), and the move each belongs to: a ball's
    pieces need no more, in one assembly of the pieces' ends instead of two. Tip-linear
    (no ``joints``), each point is placed once in a compiled loop
    (:func:`~.sweep_kernel.centre_pieces`), with no arrays of the inner poses.
    """
    a, b, aa, ab = (np.asarray(x, dtype=np.float64) for x in (a, b, aa, ab))
    if joints is None:
        pieces = _piece_counts(a, b, aa, ab, step, reach_mm, sag_mm, None)
        c0, c1 = centre_pieces(a, b, aa, ab, pieces, reach_mm)
        return c0, c1, np.repeat(np.arange(len(a)), pieces)
    pieces, tips, axes = _inner_poses(a, b, aa, ab, step, reach_mm, sag_mm, joints,
                                      tip_linear)
    c0, c1 = piece_ends(a + reach_mm * aa, b + reach_mm * ab, tips + reach_mm * axes, pieces)
    return c0, c1, np.repeat(np.arange(len(a)), pieces)


def _inner_poses(a: NDArray[np.float64], b: NDArray[np.float64], aa: NDArray[np.float64],
                 ab: NDArray[np.float64], step: float, reach_mm: float, sag_mm: float,
                 joints: tuple[Machine, NDArray[np.float64], NDArray[np.float64]] | None,
                 tip_linear: NDArray[np.bool_] | None = None
                 ) -> tuple[NDArray[np.int64], NDArray[np.float64], NDArray[np.float64]]:
    """Pieces per move (:func:`_piece_counts`) and the tips and axes of the inner poses.

    Move after move, its ``pieces - 1`` inner poses at ``u = j / pieces`` (as
    :func:`split_moves` places them).
    """
    pieces = _piece_counts(a, b, aa, ab, step, reach_mm, sag_mm, joints, tip_linear)
    n = len(a)
    # piece j of a move of m pieces runs from the pose at u = j / m to (j + 1) / m: the
    # move's own ends, or one of its inner poses (placed once, shared by two pieces)
    inner_first = np.cumsum(pieces - 1) - (pieces - 1)
    inner_move = np.repeat(np.arange(n), pieces - 1)
    u = ((np.arange(inner_move.size) - inner_first[inner_move] + 1)
         / pieces[inner_move])
    # each move's rows once per inner pose: x[inner_move], in a third of its time
    def per_inner(x: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.repeat(x, pieces - 1, axis=0)

    if joints is None:
        tips, axes = move_poses(per_inner(a), per_inner(aa), per_inner(b), per_inner(ab), u)
    else:
        machine, q_a, q_b = joints
        w = u[:, None]
        tips, axes = forward(machine, per_inner(q_a) * (1 - w) + per_inner(q_b) * w)
        if tip_linear is not None:  # those of the moves ``tip_linear`` (few) placed anew
            rows = np.flatnonzero(per_inner(tip_linear))
            move = inner_move[rows]
            tips[rows], axes[rows] = move_poses(a[move], aa[move], b[move], ab[move], u[rows])
    return pieces, tips, axes


#: A ball's pieces near a point are sought first within this many widths of the cusp the
#: request leaves on a plane (``2 sqrt(h (2 R - h))``), plus half a piece's length: the
#: neighbouring passes on either side where the passes are planned for that cusp (farther
#: apart on convex parts: :func:`~.cusp_estimates.ball_cusp_estimates` widens the search
#: where it finds no other pass).
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


def _half_longest(a: NDArray[np.float64], b: NDArray[np.float64], step_mm: float) -> float:
    """Half the longest of the pieces ``a -> b``, and at least half ``step_mm``, mm."""
    if not len(a):
        return 0.5 * step_mm
    d = b - a
    return 0.5 * max(step_mm, float(np.sqrt(np.max(np.einsum("ij,ij->i", d, d)))))


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
        joints = checked_joints(toolpath, machine)
        a, b, xa, xb, owner, q_a, q_b, start = _feed_segments(toolpath, joints)
        interpolation = None if joints is None else (machine, q_a, q_b)
        # the moves the post splits until their tips keep to the chord (leads, links):
        # tip-linear, as the program moves them (its tip within the joint tolerance), not as
        # their joints would carry the cutter unsplit (through the part, on a link that
        # turns the rotary axes)
        tip_linear = (None if joints is None else
                      ~checked_moves(toolpath.kinds, toolpath.pass_index).take(start))
        sag = PIECE_SAG_SHARE * scallop_mm  # straight pieces on a bowed (joint) path
        big, r = cutter.radius_mm, cutter.corner_radius_mm
        self.ball = cutter.kind is CutterKind.BALL
        step = 0.125 * big
        self.segment_reach = big + horizon_mm
        if self.ball:  # the centres' pieces
            self.a, self.b, piece = split_centres(a, b, xa, xb, step, big, sag, interpolation,
                                                 tip_linear)
            self.piece_a, self.piece_b = self.a, self.b
            # centres within R + h of a surface point lie within sqrt(2 R h + h^2) of the
            # point R above it (plus a piece's half length and a margin for curvature)
            self.lift = big
            half = _half_longest(self.a, self.b, step)
            self.lateral = np.sqrt(2.0 * big * horizon_mm + horizon_mm**2) + half + 0.05 * big
        else:
            # pieces with their end tips and axes (the cutter solid over their poses)
            p0, p1, x0, x1, piece = split_moves(a, b, xa, xb, step, big, sag, interpolation,
                                                 tip_linear)
            self.tips0, self.tips1, self.axes0, self.axes1 = p0, p1, x0, x1
            self.piece_a, self.piece_b = p0 + r * x0, p1 + r * x1
            self.lift = r
            half = _half_longest(self.piece_a, self.piece_b, step)
            self.lateral = big + horizon_mm + half + 0.05 * big
        # a piece cuts within the horizon only within R + h of its segment: its midpoint
        # within that and half its length (a piece may run longer than ``step``: a ball's
        # centres where the axis turns fast along a short move)
        self.reach = self.segment_reach + half
        self.pass_of = owner.take(piece) if len(piece) else np.zeros(0, dtype=np.int64)
        self._move_start, self._piece_move = start, piece
        self._cells: SampleCells | None = None
        self._piece_vectors: NDArray[np.float64] | None = None
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
            # (a ball's midpoints are its pieces' own, as binned in :attr:`cells`)
            mid = 0.5 * (self.piece_a + self.piece_b)
            lo, hi = points_box(mid)  # numpy's ptp(axis=0) of (n, 3) runs ten times slower
            sparse = float(np.prod(hi - lo + self.near_mm) / len(mid)) ** (1 / 3)
            self._near_cells = bin_samples(mid, max(2.0 * self.near_mm, sparse))
        return self._near_cells

    @property
    def cells(self) -> SampleCells | None:
        """The pieces' midpoints binned (when first asked) in cells of the cutter's reach.

        None without pieces. (A ball's rays over a bracket meet their pieces in
        :attr:`near_cells`: these are binned only where a ray meets every piece within the
        cutter's reach, as :meth:`cut`'s last search.)
        """
        if self._cells is None and len(self.pass_of):
            self._cells = bin_samples(self._midpoints(), self.reach)
        return self._cells

    def _midpoints(self, pieces: NDArray[np.int64] | None = None) -> NDArray[np.float64]:
        """Each piece's midpoint, mm, as :attr:`cells` bins it (worked out when binned, not kept).

        A ball's centre segment's; a flat or bull-nose cutter's corner-circle centre at the
        middle pose. Of the ``pieces`` alone where given.
        """
        def ends(x: NDArray[np.float64]) -> NDArray[np.float64]:
            return x if pieces is None else x.take(pieces, axis=0)

        if self.ball:
            return 0.5 * (ends(self.a) + ends(self.b))
        r = self.cutter.corner_radius_mm
        return 0.5 * (ends(self.tips0) + ends(self.tips1)) + r * 0.5 * (ends(self.axes0)
                                                                          + ends(self.axes1))

    @property
    def piece_vectors(self) -> NDArray[np.float64]:
        """Each piece's ``piece_b - piece_a``, mm (worked out once, when first asked)."""
        if self._piece_vectors is None:
            self._piece_vectors = self.piece_b - self.piece_a
        return self._piece_vectors

    @property
    def move_starts(self) -> NDArray[np.int64]:
        """Each feed move's first toolpath point (the moves :attr:`piece_move` numbers)."""
        return self._move_start

    @property
    def piece_move(self) -> NDArray[np.int64]:
        """Each piece's feed move (rising: a move's pieces run on in order)."""
        return self._piece_move

    def cut(self, q: NDArray[np.float64], n: NDArray[np.float64],
            candidate: NDArray[np.int64] | None = None) -> NDArray[np.bool_]:
        """Rays along ``n`` from ``q`` that enter the removed material within the horizon.

        Each ray's ``candidate`` piece (-1: none), if given, is tried first where its
        midpoint lies within the cutter's reach of the ray's origin (a piece the last search
        meets too; a flat or bull-nose cutter's flank may reach farther). A ball's rays try
        the pieces within half :attr:`near_mm` of the point ``R`` up the ray (on the sheet
        of ball centres): a ray one of them cuts is cut whatever the others do (the height
        is the lowest entry); the rest meet all their pieces within the cutter's reach
        (:meth:`height`). So the rays cut are those the last search alone would find.

        The rays are counted their pieces within the reach before they seek the near ones:
        a ray with none (an uncut area's: half the grid's rays over a blade left uncut
        underneath) is uncut without a search. But those their candidate missed seek the
        near pieces first: a pass runs by them, a neighbour's piece likely cuts them.
        """
        out = np.zeros(len(q), dtype=bool)
        if not len(self.pass_of):
            return out
        missed = (np.zeros(0, dtype=np.int64) if candidate is None else
                  self._candidates_cut(q, n, candidate, out))
        near = np.zeros(len(q), dtype=bool)  # (the rays a ball's near pieces were tried on)
        if self.ball:
            # first those their candidate missed: a pass runs by, a neighbour's piece
            # likely cuts them (where all are, the reach's cells are never binned)
            self._near_pieces_cut(q, n, missed, out)
            near[missed] = True
        rest = np.flatnonzero(~out)
        for i in range(0, len(rest), 100_000):
            rows = rest[i:i + 100_000]
            # a ray with no piece's midpoint within the reach enters none within the horizon
            # (an uncut area's rays, most of these): counted first, the others alone are
            # searched, among the near pieces (those not tried yet), then all within reach
            rows = rows[counts_within(self.cells, q.take(rows, axis=0), self.reach) > 0]
            if self.ball:
                self._near_pieces_cut(q, n, rows[~near[rows]], out)
                rows = rows[~out[rows]]
            q_rows, n_rows = q.take(rows, axis=0), n.take(rows, axis=0)
            pairs = self._enterable(q_rows, n_rows, *self.pairs(q_rows))
            out[rows] = np.isfinite(self.height(q_rows, n_rows, *ray_ranges(*pairs, len(rows)),
                                                first=True))
        if self.ball:  # dropped: a ball's later searches seldom meet the reach's cells
            # (a coarse request's bracket search whose radius reaches them bins them again)
            self._cells = None
        return out

    def _enterable(self, q: NDArray[np.float64], n: NDArray[np.float64],
                   owner: NDArray[np.int64], item: NDArray[np.int64]
                   ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """The pairs of rays ``q + l n`` (rows ``owner``) and pieces ``item`` a ray can enter.

        Under one tool axis ``a`` for every piece (3 axes), a flat or bull-nose cutter lies
        on its tip plane's upper side at each pose, ``(x - T) . a >= 0``, the tip ``T``
        moving linearly along a piece: a ray not climbing (``n . a <= 0``) from below both
        its end tips' planes (``q . a`` under the lower, :attr:`lowest_tip_mm`) never
        enters the piece. Those pairs are dropped before the search (which would skip them
        one by one, :func:`~.sweep_kernel.nearest_entries`' tip-plane bound: the same
        rays cut). Under a thin part the rays of its far side point away from the
        cutters over it and meet hundreds of their pieces within the reach each (lying
        dev blade, bull:8:1, 3 axes, scallop 0.01 mm, chord 0.1 mm: 4,286 of the uncut
        grid's 5,326 rays searched, 631,243 of their 832,390 pairs). Other cutters and
        turning axes: every pair.
        """
        lowest = self.lowest_tip_mm
        if lowest is None or not len(item):
            return owner, item
        axis = self.axes0[0]
        height = q @ axis
        climbing = n @ axis > 0.0
        keep = climbing[owner] | (height[owner] >= lowest[item] - LENGTH_SLACK_MM)
        return owner[keep], item[keep]

    @cached_property
    def lowest_tip_mm(self) -> NDArray[np.float64] | None:
        """Each piece's lower end tip's height along the one tool axis, mm (worked out once).

        None for a ball, or where the pieces' axes differ by more than round-off (a
        5-axis toolpath's).
        """
        if self.ball or not len(self.pass_of):
            return None
        axis = self.axes0[0]
        if max(float(np.abs(self.axes0 - axis).max()),
               float(np.abs(self.axes1 - axis).max())) > ROUND_OFF:
            return None
        return np.minimum(self.tips0 @ axis, self.tips1 @ axis)

    def _candidates_cut(self, q: NDArray[np.float64], n: NDArray[np.float64],
                        candidate: NDArray[np.int64], out: NDArray[np.bool_]
                        ) -> NDArray[np.int64]:
        """Rays cut by their ``candidate`` piece (within the reach) marked in ``out``.

        Returns the rays whose candidate was tried and missed them.
        """
        rows = np.flatnonzero(candidate >= 0)
        # (the distance as the cells' count works it out: the same pieces within reach)
        off = self._midpoints(candidate.take(rows)) - q.take(rows, axis=0)
        rows = rows[off[:, 0] * off[:, 0] + off[:, 1] * off[:, 1] + off[:, 2] * off[:, 2]
                    <= self.reach * self.reach]
        # in the pieces' order (each ray's result is its own, whatever the order): the
        # pieces are then read from memory in turn, not at random (a grid's rows
        # cross the passes; 0.4 times the time on the R150 dome's 140,000 rays)
        rows = rows[np.argsort(candidate[rows], kind="stable")]
        one = np.arange(rows.size)
        # (``take`` gathers rows of (n, 3) arrays several times faster than indexing)
        cut = np.isfinite(self.height(q.take(rows, axis=0), n.take(rows, axis=0), one,
                                      one + 1, candidate.take(rows), first=True))
        out[rows] = cut
        return rows[~cut]

    def _near_pieces_cut(self, q: NDArray[np.float64], n: NDArray[np.float64],
                         rows: NDArray[np.int64], out: NDArray[np.bool_]) -> None:
        """A ball's rays ``rows`` cut by a piece within half :attr:`near_mm` of ``q + R n``.

        Marked in ``out``. (A ray that enters a piece within the horizon passes within
        ``R`` of its centre segment there, so within the reach of its midpoint: a ray with
        none there finds none here either.)
        """
        if not rows.size:
            return
        owner, item = pairs_within(self.near_cells, q.take(rows, axis=0)
                                   + self.lift * n.take(rows, axis=0), 0.5 * self.near_mm)
        out[rows] = np.isfinite(self.height(q.take(rows, axis=0), n.take(rows, axis=0),
                                            *ray_ranges(owner, item, rows.size), first=True))

    def pairs(self, q: NDArray[np.float64], radius: float | None = None
              ) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """Candidate (query, piece) pairs: piece centres within ``radius`` of each point.

        The default radius is the cutter's reach. A ball's pieces within less (a bracket's
        rays, :func:`~.cusp_search._bracket_pieces`) are met in :attr:`near_cells` (the
        estimate's, binned anyway: the same pairs whatever the cells, without binning the
        reach's cells for a few brackets).
        """
        if not len(self.pass_of):
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
        if radius is None:
            radius = self.reach
        return pairs_within(self._cells_for(radius), q, radius)

    def pair_batches(self, q: NDArray[np.float64], radius: float, most_pairs: int
                     ) -> Iterator[tuple[NDArray[np.int64], NDArray[np.int64]]]:
        """:meth:`pairs` a run of consecutive points at a time, about ``most_pairs`` a run.

        (:func:`~.clearance_kernel.pair_batches`: the owners index the whole ``q``.)
        """
        if len(self.pass_of):
            yield from pair_batches(self._cells_for(radius), q, radius, most_pairs)

    def _cells_for(self, radius: float) -> SampleCells | None:
        """The cells :meth:`pairs` meets pieces within ``radius`` in."""
        return self.near_cells if self.ball and radius < self.reach else self.cells

    def height(self, q: NDArray[np.float64], n: NDArray[np.float64], lo: NDArray[np.int64],
               hi: NDArray[np.int64], item: NDArray[np.int64], *, first: bool = False
               ) -> NDArray[np.float64]:
        """Entry distance along ``n`` into the removed material (inf: beyond the horizon).

        Ray ``i`` meets the pieces ``item[lo[i]:hi[i]]``. With ``first``, whether it
        enters within the horizon is all that counts: the first piece it enters there
        gives the height (finite, not the lowest: an entry at one of that piece's sampled
        poses), the others are not tried.
        """
        stop = self.horizon if first else 0.0
        if not self.ball:
            out = nearest_entries(q, n, lo, hi, item, self.tips0, self.tips1, self.axes0,
                                  self.axes1, corner_radius_mm=self.cutter.corner_radius_mm,
                                  radius_mm=self.cutter.radius_mm,
                                  flute_length_mm=self.cutter.flute_length_mm,
                                  horizon_mm=self.horizon, stop_mm=stop,
                                  motions=self.motions)
        else:
            out = capsule_entries(q, n, lo, hi, item, self.a, self.b, self.cutter.radius_mm,
                                  stop_mm=stop)
        return np.where(out > self.horizon, np.inf, out)

    @cached_property
    def motions(self) -> Motions:
        """Flat and bull-nose: how fast each piece's poses move (when first asked).

        :func:`.sweep_kernel.piece_motions`, once for all the rays :meth:`height` casts.
        """
        return piece_motions(self.tips0, self.tips1, self.axes0, self.axes1,
                             self.cutter.radius_mm)

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
