"""Splitting moves so the machine's joint interpolation stays on the planned tool-tip path.

A controller interpolates a block linearly in its *joints*. On a 5-axis machine that does not
move the tool tip along the straight chord the planner checked: with rotary axes turning, the
tip bows away from it (measured on the dev blade, 5-axis, before this step: up to 0.45 mm on
a block turning C by 21°, and gouges of 0.24 mm). For each move ``i -> i+1`` the tip at the
joint midpoint ``FK((q_i + q_{i+1}) / 2)`` is compared with the chord midpoint
``(p_i + p_{i+1}) / 2``; a move deviating by more than the tolerance gets a point on its chord
(tool axis: the normalized mean of its ends), and the check repeats. The deviation of a
segment shrinks about fourfold per halving, so a few rounds suffice.

A planner that already checked its cutting moves under this machine's joint interpolation
(against the surface, and sideways) sets the toolpath's ``joints_checked_for`` to
:func:`machine_key`; those moves (cutting, within one pass) are then left whole, and
only the others (leads, links, plunges) are split here.

The first round reads the joints the planner solved for the path
(:attr:`Toolpath.solved_joints`, :func:`known_joints`) instead of solving them again; a
round after a split decides C along the whole new path (the branch and unwrap rules of
:func:`machines.kinematics.solve_inverse` look along all of it) and computes the other
joints only for the new points and those whose C came out otherwise (``previous``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json

import numpy as np
from numpy.typing import NDArray

from machines import Machine
from machines.kinematics import InverseSolution, forward, solve_inverse

from .errors import InvalidParameterError
from .path import MoveKind, SolvedJoints, Toolpath
from .vectors import unit

__all__ = ["MAX_ROUNDS", "RAPID_TOLERANCE_MM", "checked_moves", "joint_path_deviation_mm",
           "joints_checked", "known_joints", "machine_key", "path_joints",
           "refine_for_joint_interpolation", "refine_with_joints", "with_solved_joints"]

#: Largest distance of a rapid's tool tip from its planned chord (on the clearance plane or
#: sphere) under joint interpolation, mm: a rotary swing otherwise sweeps the tool far off
#: the clearance, through the part.
RAPID_TOLERANCE_MM = 1.0
#: Halvings at most (a move is split into at most 2**MAX_ROUNDS pieces).
MAX_ROUNDS = 8
#: Fields of a machine its joint interpolation does not depend on (left out of
#: :func:`machine_key`: a definition read from another file, or speaking another dialect,
#: moves its joints the same).
NOT_KINEMATIC = ("name", "dialect", "connection", "description", "source")


def machine_key(machine: Machine) -> str:
    """The machine's name and a stable hash of what its joint interpolation depends on.

    ``name:hash``, the hash (SHA-256, 16 hex digits) of the kinematic type, the axes
    (letters, kinds, travel, rates, wrapping) and the geometry (tool length, work origin,
    rotary centre, C offset, head pivot, preferred tilt branch) as sorted JSON: the same
    in every run and on every computer, whatever file the definition was read from.
    """
    content = {name: value for name, value in dataclasses.asdict(machine).items()
               if name not in NOT_KINEMATIC}
    text = json.dumps(content, sort_keys=True, default=str)
    return f"{machine.name}:{hashlib.sha256(text.encode()).hexdigest()[:16]}"


def joints_checked(path: Toolpath, machine: Machine) -> bool:
    """Whether ``path``'s cutting moves were checked under ``machine``'s interpolation."""
    return path.joints_checked_for is not None and path.joints_checked_for == machine_key(
        machine)


def known_joints(path: Toolpath, machine: Machine) -> InverseSolution | None:
    """The joints ``path`` carries for ``machine`` (:attr:`Toolpath.solved_joints`), or None.

    They are ``solve_inverse(machine, path.positions_mm, path.tool_axes)`` as solved
    before: the path keeps them only for its very points, and they count only for a
    machine of the same :func:`machine_key`.
    """
    solved = path.solved_joints
    if solved is None or solved.machine_key != machine_key(machine):
        return None
    return solved.solution


def path_joints(path: Toolpath, machine: Machine) -> InverseSolution:
    """``path``'s joints on ``machine``: those it carries (:func:`known_joints`), else solved."""
    known = known_joints(path, machine)
    if known is not None:
        return known
    return solve_inverse(machine, path.positions_mm, path.tool_axes)


def with_solved_joints(path: Toolpath, machine: Machine) -> Toolpath:
    """``path`` carrying its joints on ``machine`` (solved here unless it carries them)."""
    if known_joints(path, machine) is not None:
        return path
    solution = solve_inverse(machine, path.positions_mm, path.tool_axes)
    return dataclasses.replace(path, solved_joints=SolvedJoints(
        machine_key(machine), path.positions_mm, path.tool_axes, solution))


def joint_path_deviation_mm(machine: Machine, tips_mm: NDArray[np.float64],
                            joints: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance (mm) of each move's joint-midpoint tip from its chord midpoint, ``(n-1,)``."""
    if len(tips_mm) < 2:
        return np.zeros(0)
    return _moves_deviation(machine, tips_mm, joints, np.arange(len(tips_mm) - 1))


def _moves_deviation(machine: Machine, tips_mm: NDArray[np.float64],
                     joints: NDArray[np.float64], idx: NDArray[np.int64]
                     ) -> NDArray[np.float64]:
    """:func:`joint_path_deviation_mm` of the moves ``idx -> idx + 1``."""
    middle_tips, _ = forward(machine, 0.5 * (joints[idx] + joints[idx + 1]))
    return np.linalg.norm(middle_tips - 0.5 * (tips_mm[idx] + tips_mm[idx + 1]), axis=1)


def _deviation_again(machine: Machine, tips_mm: NDArray[np.float64],
                     joints: NDArray[np.float64],
                     last: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]
                     | None) -> NDArray[np.float64]:
    """:func:`joint_path_deviation_mm` of a path after a round of splits.

    ``last`` holds the previous round's joints, deviations and, per point now, the row it
    had then (-1 for a new point). A move between two points that were neighbours then,
    whose joints came out the same, has the same deviation (the same numbers in, the same
    out); only the others are computed (the new halves, and any whose joints moved).
    """
    if last is None or len(tips_mm) < 2:
        return joint_path_deviation_mm(machine, tips_mm, joints)
    old_joints, old_deviation, was = last
    old = was >= 0
    moved = np.ones(len(was), dtype=bool)  # new, or its joints came out otherwise
    moved[old] = (joints[old] != old_joints).any(axis=1)
    a, b = was[:-1], was[1:]
    same = (b == a + 1) & ~moved[:-1] & ~moved[1:]
    deviation = np.empty(len(tips_mm) - 1)
    deviation[same] = old_deviation[a[same]]
    again = np.flatnonzero(~same)
    if again.size:
        deviation[again] = _moves_deviation(machine, tips_mm, joints, again)
    return deviation


def refine_for_joint_interpolation(path: Toolpath, machine: Machine, tol_mm: float
                                   ) -> Toolpath:
    """``path`` with feed moves split until joint interpolation stays within ``tol_mm``.

    Rapids are split until they stay within :data:`RAPID_TOLERANCE_MM` of their planned
    chords (on the clearance plane or sphere, clear of the part): a rapid that turns the
    rotary axes otherwise sweeps the tool far off it (hundreds of mm when a joint swings
    round), through the part. On a 3-axis machine joint and tip interpolation agree and
    ``path`` is returned unchanged.
    """
    return refine_with_joints(path, machine, tol_mm)[0]


def checked_moves(kinds: NDArray[np.int64], passes: NDArray[np.int64]) -> NDArray[np.bool_]:
    """The moves ``i -> i + 1`` a planner checks under joint interpolation: cutting, in one pass.

    On a path checked for a machine (:func:`joints_checked`) these are left whole here and
    move as the joints interpolate them; the others (leads, links, plunges, rapids) are
    split until the tip keeps to their chords (module docstring).
    """
    return (kinds[1:] == MoveKind.CUT) & (passes[1:] == passes[:-1]) & (passes[1:] >= 0)


def refine_with_joints(path: Toolpath, machine: Machine, tol_mm: float
                       ) -> tuple[Toolpath, NDArray[np.float64] | None]:
    """:func:`refine_for_joint_interpolation`, and the joints of the path it returns.

    The joints are those its last round solved (``path.to_machine(machine).joints`` of the
    result, without solving them again); None on a 3-axis machine, for a path under two
    points, or where :data:`MAX_ROUNDS` ran out (the last round's points were split after
    its joints were solved).
    """
    if not (np.isfinite(tol_mm) and tol_mm > 0.0):
        raise InvalidParameterError(f"joint tolerance must be > 0 mm, got {tol_mm!r}")
    if not machine.kinematics.is_five_axis or len(path) < 2:
        return path, None
    final: NDArray[np.float64] | None = None
    tips, axes = path.positions_mm, path.tool_axes
    kinds, feeds, passes = path.kinds, path.feeds_mm_per_min, path.pass_index
    checked = joints_checked(path, machine)
    # the last round's joints and deviations, by the new rows of its points (-1: new)
    last: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]] | None = None
    # the first round's points are the path's own (their joints known, if the path carries
    # them); a later round's rows of the round before keep their joints where C came out
    # the same (solve_inverse's ``previous``)
    solution = known_joints(path, machine)
    for _ in range(MAX_ROUNDS):
        if solution is None or last is not None:
            solution = solve_inverse(machine, tips, axes, previous=None if last is None
                                     else (solution, last[2]))
        joints = solution.joints
        deviation = _deviation_again(machine, tips, joints, last)
        rapid = kinds[1:] == MoveKind.RAPID
        split = deviation > np.where(rapid, RAPID_TOLERANCE_MM, tol_mm)
        if checked:
            split &= ~checked_moves(kinds, passes)
        if not split.any():
            final = joints
            break
        at = np.flatnonzero(split)  # move at -> at + 1 gets a middle point
        new_tips = 0.5 * (tips[at] + tips[at + 1])
        new_axes = unit(axes[at] + axes[at + 1])
        where = at + 1
        old_rows = np.arange(len(tips))
        last = (joints, deviation, np.insert(old_rows, where, -1))
        tips = np.insert(tips, where, new_tips, axis=0)
        axes = np.insert(axes, where, new_axes, axis=0)
        kinds = np.insert(kinds, where, kinds[at + 1])
        feeds = np.insert(feeds, where, feeds[at + 1])
        passes = np.insert(passes, where, passes[at + 1])
    if len(tips) == len(path):
        return path, final
    metadata = {**path.metadata, "joint_refined_mm": f"{tol_mm:g}"}
    return Toolpath(tips, axes, kinds, feeds, passes, metadata,
                    joints_checked_for=path.joints_checked_for), final
