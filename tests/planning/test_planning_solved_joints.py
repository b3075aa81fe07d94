"""A plan's joints, solved once in its machine stage and handed on (issue 27).

Every reader of the carried joints (the machine stage, the measurement's joints, the
rotary rates, the post) must give what it gives when it solves them itself
(:func:`machines.kinematics.solve_inverse` of the whole path), and a path with other
points, or another machine, must not use them.
"""

import dataclasses

import numpy as np
import pytest

from gcode import emit_lines
from gcode.dialects import dialect_by_name
from gcode.post import post
from machines import load_machine
from machines.kinematics import solve_inverse
from toolpath.joint_refine import known_joints, path_joints, with_solved_joints
from toolpath.path import MoveKind, SolvedJoints
from toolpath.planning import SpherePatch, plan_finishing
from toolpath.planning.checks import machine_stage
from toolpath.planning.measure_joints import checked_joints
from toolpath.planning.options import FinishingOptions
from toolpath.planning.rotary_rate import rotary_rates


@pytest.fixture(scope="module")
def planned():
    machine = load_machine("trunnion-ac")
    path, _ = plan_finishing(SpherePatch(), "ball:6", scallop_mm=0.05, chord_tol_mm=0.02,
                             axis_mode="lead-tilt", lead_deg=10.0, machine=machine,
                             measure=False)
    return path, machine


def _bare(path):
    """The same path without carried joints (every reader then solves them itself)."""
    return dataclasses.replace(path, solved_joints=None)


def test_the_plan_carries_the_joints_of_its_own_points(planned):
    path, machine = planned
    known = known_joints(path, machine)
    assert known is not None
    full = solve_inverse(machine, path.positions_mm, path.tool_axes)
    np.testing.assert_array_equal(known.joints, full.joints)
    np.testing.assert_array_equal(known.in_cone, full.in_cone)
    np.testing.assert_array_equal(known.axis_error_deg, full.axis_error_deg)
    # kept through a change that leaves the points (the job adds its placement text),
    # holding the path's own arrays (no second copy of the points)
    renamed = dataclasses.replace(path, metadata={**path.metadata, "placement": "x"})
    assert known_joints(renamed, machine) is known
    assert renamed.solved_joints.positions_mm is renamed.positions_mm
    assert renamed.solved_joints.tool_axes is renamed.tool_axes


def test_other_points_or_another_machine_do_not_use_them(planned):
    path, machine = planned
    shifted = dataclasses.replace(path, positions_mm=path.positions_mm + np.array([0.0, 0.0, 5.0]))
    assert shifted.solved_joints is None and known_joints(shifted, machine) is None
    np.testing.assert_array_equal(
        path_joints(shifted, machine).joints,
        solve_inverse(machine, shifted.positions_mm, shifted.tool_axes).joints)
    turned = path.tool_axes.copy()
    i = int(np.flatnonzero((turned[1:] != turned[:-1]).any(axis=1))[0])
    turned[i] = turned[i + 1]  # one axis of another point: not the points solved
    assert dataclasses.replace(path, tool_axes=turned).solved_joints is None
    # joints given for other points are dropped when the path is made
    other = SolvedJoints("x", shifted.positions_mm, path.tool_axes,
                         known_joints(path, machine))
    assert dataclasses.replace(path, solved_joints=other).solved_joints is None
    longer = machine.with_tool_length(machine.tool_length + 10.0)
    assert known_joints(path, longer) is None
    np.testing.assert_array_equal(
        path_joints(path, longer).joints,
        solve_inverse(longer, path.positions_mm, path.tool_axes).joints)


def test_with_solved_joints_solves_a_bare_path_once(planned):
    path, machine = planned
    carried = with_solved_joints(_bare(path), machine)
    np.testing.assert_array_equal(known_joints(carried, machine).joints,
                                  known_joints(path, machine).joints)
    assert with_solved_joints(carried, machine) is carried


def test_the_planners_readers_give_what_they_solve_themselves(planned):
    path, machine = planned
    bare = _bare(path)
    np.testing.assert_array_equal(checked_joints(path, machine), checked_joints(bare, machine))
    assert rotary_rates(path, machine) == rotary_rates(bare, machine)
    opts = FinishingOptions(scallop_mm=0.05, chord_tol_mm=0.02, axis_mode="lead-tilt",
                            on_limit="report")
    assert machine_stage(path, machine, opts) == machine_stage(bare, machine, opts)


def test_rotary_rates_measure_the_joints_the_post_writes(planned):
    # the whole path's joints (branch and turns as the post has them), between the first
    # and the last cutting move
    path, machine = planned
    rates = rotary_rates(_bare(path), machine)
    cut = np.flatnonzero(path.kinds == MoveKind.CUT)
    joints = solve_inverse(machine, path.positions_mm, path.tool_axes).joints
    c = joints[cut[0]:cut[-1] + 1, machine.index("C")]
    assert rates.c_turn_deg == c[-1] - c[0]
    assert rates.axis in ("A", "C")


@pytest.mark.parametrize("checked", [True, False])
def test_the_post_writes_the_same_program_from_carried_joints(planned, checked):
    path, machine = planned
    if not checked:  # every move split by the rounds: only the first reads them
        path = dataclasses.replace(path, joints_checked_for=None)
    assert known_joints(path, machine) is not None
    dialect = dialect_by_name(machine.dialect)
    assert (emit_lines(post(path, machine), dialect)
            == emit_lines(post(_bare(path), machine), dialect))


def test_an_axis_whose_zero_changes_sign_drops_them(planned):
    # -0.0 and +0.0 compare equal but can put C on opposite branches (head-table-bc: C -180
    # and +180 for the axis (-0.5, -/+0.0, 0.866)): joints are kept for the very bits solved
    path, machine = planned
    axes = np.array(path.tool_axes)
    axes[0] = (-0.5, 0.0, np.sqrt(0.75))
    path = with_solved_joints(dataclasses.replace(path, tool_axes=axes), machine)
    assert known_joints(path, machine) is not None
    axes = np.array(path.tool_axes)
    axes[0, 1] = -0.0
    assert known_joints(dataclasses.replace(path, tool_axes=axes), machine) is None


def test_the_carried_joints_cannot_be_changed_in_place(planned):
    path, machine = planned
    known = known_joints(path, machine)
    with pytest.raises(ValueError):
        known.joints[:, 4] += 360.0
