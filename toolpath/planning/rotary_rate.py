"""How fast the machine's rotary joints turn along the cut, and whether C turns one way.

Round a blade's leading and trailing edges the tool axis fans through up to 180 deg in a
few mm of path; the tool-axis turn rate (:mod:`~toolpath.planning.rate_limit`) bounds the
axis in the workpiece, but the joints turn faster near the machine's singular cone (the
rotary table spins to follow a small turn of an axis near its own). This module measures
the joints themselves, as the post writes them (the machine's inverse kinematics of the
whole path, unwrapped: those the path carries, :func:`~toolpath.joint_refine.path_joints`):
for each rotary joint ``q`` and cutting segment ``k`` (feed moves between
the first and the last cutting move) the rate ``|q_{k+1} - q_k| / L_k`` in deg per mm of
tool-tip path, and ``|dq| / L * f / 60`` in deg/s at the segment's programmed feed
``f`` (mm/min), against the axis' ``max_rate`` (deg/min / 60). Where a joint would
exceed its rate the post slows the move (:mod:`gcode.post`, ``max(60 L / f, slowest
axis)``): the feed there is ``min(f, 60 r_max / (dq / L))``, reported as the slowest.

A spiral round a closed blade turns the C table one way: ``c_one_way`` says whether
every step of C between the first and last cutting move has the sign of the total turn
(steps under :data:`STILL_DEG` count as still).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from machines import Machine

from ..joint_refine import path_joints
from ..path import MoveKind, Toolpath
from ..tolerances import LENGTH_SLACK_MM, LIMIT_SLACK

__all__ = ["STILL_DEG", "RotaryRates", "rotary_rates"]

#: A step of a rotary joint smaller than this (deg) counts as standing still.
STILL_DEG = 1e-6


@dataclass(frozen=True)
class RotaryRates:
    """The fastest rotary joint along the cut and the C table's sense of turn.

    Attributes
    ----------
    axis : str
        Letter of the joint that turns fastest (per mm of path).
    max_deg_per_mm : float
        Its largest turn per mm of tool-tip path, deg/mm.
    max_deg_per_s : float
        Largest turn rate of any rotary joint at the programmed feed, deg/s.
    axis_at_s : str
        The joint of ``max_deg_per_s``.
    limit_deg_per_s : float
        That joint's rate limit (``max_rate / 60``), deg/s.
    point : int
        Toolpath point where the largest deg/s is reached (end of the segment).
    n_slowed : int
        Cutting moves the post slows so that no rotary joint exceeds its rate.
    slowest_feed_mm_per_min : float
        The lowest tool-tip feed that leaves along the cut, mm/min.
    feed_mm_per_min : float
        The programmed cutting feed (the largest along the cut), mm/min.
    c_one_way : bool or None
        The C (or other continuous) table turns one way from the first to the last
        cutting move; None without a rotary table.
    c_turn_deg : float
        C's net turn over that stretch, deg (signed).
    """

    axis: str
    max_deg_per_mm: float
    max_deg_per_s: float
    axis_at_s: str
    limit_deg_per_s: float
    point: int
    n_slowed: int
    slowest_feed_mm_per_min: float
    feed_mm_per_min: float
    c_one_way: bool | None
    c_turn_deg: float

    @property
    def within_limit(self) -> bool:
        """The fastest joint stays within its rate limit at the programmed feed."""
        return self.max_deg_per_s <= self.limit_deg_per_s * (1.0 + LIMIT_SLACK)

    def describe(self) -> str:
        """One line for the reports."""
        text = (f"{self.axis} {self.max_deg_per_mm:.3f} deg/mm of path max; {self.axis_at_s} "
                f"{self.max_deg_per_s:.1f} deg/s at the programmed "
                f"{self.feed_mm_per_min:g} mm/min (limit {self.limit_deg_per_s:.1f} deg/s")
        if self.within_limit:
            text += ")"
        else:
            text += (f"; the post slows {self.n_slowed} moves to keep it, down to "
                     f"{self.slowest_feed_mm_per_min:.0f} mm/min)")
        if self.c_one_way is not None:
            text += (f"; C turns {'one way' if self.c_one_way else 'back and forth'}, "
                     f"{self.c_turn_deg:+.1f} deg in all")
        return text


def rotary_rates(path: Toolpath, machine: Machine) -> RotaryRates | None:
    """Measure the rotary joints along ``path`` on ``machine``.

    The joints are the whole planned path's (:func:`path_joints`), taken between its first
    and last cutting move: C's branch and turns follow from the moves before the first cut,
    as on the machine, not from a solve of the cutting stretch alone. The post may still
    insert points (joint-interpolation refinement) that move C a little inside the
    singular cone; the report describes the planned path.

    None when the machine has no rotary joint or the path no two cutting moves.
    """
    rotary = [k for k, a in enumerate(machine.axes) if a.kind.value == "rotary"]
    cutting = np.flatnonzero(path.kinds == MoveKind.CUT)
    if not rotary or cutting.size < 2:
        return None
    first, last = int(cutting[0]), int(cutting[-1])
    joints = path_joints(path, machine).joints[first:last + 1]
    feeds = path.feeds_mm_per_min[first + 1:last + 1]
    lengths = path.segment_lengths_mm[first:last]
    steps = np.abs(np.diff(joints[:, rotary], axis=0))
    moving = lengths > LENGTH_SLACK_MM
    per_mm = np.where(moving[:, None], steps / np.where(moving, lengths, 1.0)[:, None], 0.0)
    per_s = per_mm * np.where(feeds > 0.0, feeds, 0.0)[:, None] / 60.0
    limits = np.array([machine.axes[k].max_rate / 60.0 for k in rotary])
    j_mm = int(np.argmax(per_mm.max(axis=0)))
    share = per_s / limits
    at, j_s = np.unravel_index(int(np.argmax(share)), share.shape)
    over = share.max(axis=1)
    fed = feeds > 0.0
    slowed = np.where(over > 1.0, feeds / np.maximum(over, 1.0), feeds)
    table = [k for k in rotary if machine.axes[k].letter == "C"]
    c_one_way, c_turn = None, 0.0
    if table:
        c = joints[:, table[0]]
        dc = np.diff(c)
        c_turn = float(c[-1] - c[0])
        sense = np.sign(c_turn) if abs(c_turn) > STILL_DEG else 0.0
        moved = dc[np.abs(dc) > STILL_DEG]
        c_one_way = bool(moved.size == 0 or (sense != 0.0 and (np.sign(moved) == sense).all()))
    return RotaryRates(
        axis=machine.axes[rotary[j_mm]].letter,
        max_deg_per_mm=float(per_mm[:, j_mm].max()),
        max_deg_per_s=float(per_s[at, j_s]), axis_at_s=machine.axes[rotary[j_s]].letter,
        limit_deg_per_s=float(limits[j_s]), point=int(first + at + 1),
        n_slowed=int((fed & (over > 1.0 + LIMIT_SLACK)).sum()),
        slowest_feed_mm_per_min=float(slowed[fed].min()) if fed.any() else 0.0,
        feed_mm_per_min=float(feeds.max()),
        c_one_way=c_one_way, c_turn_deg=c_turn)
