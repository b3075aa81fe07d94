"""A spiral's cutting moves from one pass to the next, measured as the post emits them.

Round a closed section a spiral runs each pass on into the next with a cutting move. On a
path checked under a 5-axis machine's joint interpolation the post leaves only the cutting
moves within a pass whole (:func:`toolpath.joint_refine.checked_moves`) and splits those
until their tips keep to the chord: the chord measure places them tip-linear, as the cut
volume does (:func:`toolpath.planning.chord_measure._interpolation_groups`).
"""

import numpy as np
import pytest

from machines import load_machine
from toolpath.joint_refine import checked_moves, joint_path_deviation_mm
from toolpath.path import MoveKind
from toolpath.planning import EllipticBladeSurface, plan_finishing
from toolpath.planning.chord_measure import _cutting_moves, _interpolation_groups


@pytest.fixture(scope="module")
def spiral():
    blade = EllipticBladeSurface(z_range_mm=(0.0, 12.0))
    machine = load_machine("trunnion-ac")
    path, _ = plan_finishing(blade, "ball:6", scallop_mm=0.1, chord_tol_mm=0.03,
                             axis_mode="lead-tilt", lead_deg=10.0, linking="spiral",
                             machine=machine, measure=False)
    return path, machine


def test_cross_moves_are_measured_tip_linear(spiral):
    path, machine = spiral
    move = _cutting_moves(path)
    kinds, passes = path.kinds, path.pass_index
    cross = passes[move + 1] != passes[move]
    assert cross.sum() >= 3 and (kinds[move + 1] == MoveKind.CUT).all()
    # the premise: the post splits them (their joints bow the tip off the chord)
    joints = path.to_machine(machine).joints
    deviation = joint_path_deviation_mm(machine, path.positions_mm, joints)
    assert deviation[move[cross]].max() > 0.002
    groups = dict((moved, rows) for rows, moved in _interpolation_groups(path, move, True))
    assert np.array_equal(np.sort(np.concatenate(list(groups.values()))),
                          np.arange(move.size))
    assert np.array_equal(groups[False], np.flatnonzero(cross))
    assert checked_moves(kinds, passes)[move[groups[True]]].all()
    # tip-linear paths (no machine) and paths with no such move: one group, in order
    (rows, moved), = _interpolation_groups(path, move, False)
    assert not moved and np.array_equal(rows, np.arange(move.size))
