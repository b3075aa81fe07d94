"""The Toolpath value a plan produces: validation, the .npz round trip, joints checked."""

import dataclasses

import numpy as np
import pytest

from machines import load_machine
from toolpath.errors import DataFileError, InvalidParameterError
from toolpath.joint_refine import (
    joint_path_deviation_mm,
    joints_checked,
    machine_key,
    refine_for_joint_interpolation,
    refine_with_joints,
)
from toolpath.path import LEGACY_JOINT_CHECKED_KEY, TOOLPATH_FORMAT_VERSION, MoveKind, Toolpath
from toolpath.planning import PlaneSurface, SpherePatch, plan_finishing


@pytest.fixture(scope="module")
def planned():
    plate = PlaneSurface(t_vector_mm=(20.0, 0.0, 0.0), s_vector_mm=(0.0, 6.0, 0.0))
    path, _ = plan_finishing(plate, "ball:6", scallop_mm=0.02, chord_tol_mm=0.01,
                             axis_mode="lead-tilt", lead_deg=5.0, measure=False)
    return path


def test_plan_output_is_a_valid_immutable_toolpath(planned):
    assert planned.kinds[0] == MoveKind.RAPID and planned.feeds_mm_per_min[0] == 0.0
    np.testing.assert_allclose(np.linalg.norm(planned.tool_axes, axis=1), 1.0, atol=1e-12)
    rapid = planned.kinds == MoveKind.RAPID
    assert np.all(planned.feeds_mm_per_min[~rapid] > 0.0)
    assert np.all(planned.pass_index[rapid] == -1)
    with pytest.raises(ValueError):
        planned.positions_mm[0, 0] = 1.0
    assert planned.metadata["cutter"] == "ball:6"
    assert planned.metadata["axis_mode"] == "lead-tilt"


def test_save_load_round_trip(planned, tmp_path):
    out = tmp_path / "path.npz"
    planned.save(out)
    back = Toolpath.load(out)
    for name in ("positions_mm", "tool_axes", "kinds", "feeds_mm_per_min", "pass_index"):
        np.testing.assert_array_equal(getattr(back, name), getattr(planned, name))
    assert back.metadata == planned.metadata
    assert back.length_mm == pytest.approx(planned.length_mm)


def test_toolpath_rejects_bad_arrays():
    pos = np.zeros((3, 3))
    axes = np.tile([0.0, 0.0, 1.0], (3, 1))
    kinds = np.array([MoveKind.RAPID, MoveKind.CUT, MoveKind.CUT])
    feeds = np.array([0.0, 100.0, 100.0])
    passes = np.array([-1, 0, 0])
    with pytest.raises(InvalidParameterError, match="unit vectors; point 1"):
        Toolpath(pos, np.array([[0, 0, 1.0], [0, 0, 2.0], [0, 0, 1.0]]), kinds, feeds, passes)
    with pytest.raises(InvalidParameterError, match="CUT at point 2 has no positive feed"):
        Toolpath(pos, axes, kinds, np.array([0.0, 100.0, 0.0]), passes)
    with pytest.raises(InvalidParameterError, match="non-finite value at point 1"):
        Toolpath(np.array([[0, 0, 0], [np.nan, 0, 0], [0, 0, 0.0]]), axes, kinds, feeds,
                 passes)


def test_load_refuses_other_files(tmp_path):
    bad = tmp_path / "bad.npz"
    np.savez(bad, positions_mm=np.zeros((1, 3)))
    with pytest.raises(DataFileError, match="not a toolpath file"):
        Toolpath.load(bad)


@pytest.fixture(scope="module")
def checked_on_machine():
    machine = load_machine("trunnion-ac")
    dome = SpherePatch()
    path, _ = plan_finishing(dome, "ball:6", scallop_mm=0.05, chord_tol_mm=0.02,
                             axis_mode="lead-tilt", lead_deg=10.0, machine=machine,
                             measure=False)
    return path, machine


def test_joints_checked_is_a_typed_field_kept_by_the_file(checked_on_machine, tmp_path):
    # what the post acts on is the field, not header text; the file keeps it
    path, machine = checked_on_machine
    assert path.joints_checked_for == machine_key(machine)
    assert joints_checked(path, machine)
    assert all(machine.name not in v for v in path.metadata.values())
    path.save(tmp_path / "checked.npz")
    back = Toolpath.load(tmp_path / "checked.npz")
    assert back.joints_checked_for == path.joints_checked_for
    assert back.metadata == path.metadata
    # a plan without a machine is checked for none
    plain = Toolpath(path.positions_mm, path.tool_axes, path.kinds, path.feeds_mm_per_min,
                     path.pass_index, path.metadata)
    plain.save(tmp_path / "plain.npz")
    assert Toolpath.load(tmp_path / "plain.npz").joints_checked_for is None


def test_machine_key_depends_on_kinematics_not_on_the_file_or_dialect():
    machine = load_machine("trunnion-ac")
    key = machine_key(machine)
    assert key.startswith("trunnion-ac:")
    assert machine_key(dataclasses.replace(machine, source="/elsewhere/m.toml",
                                           dialect="fanuc", description="copy")) == key
    assert machine_key(machine.with_tool_length(machine.tool_length + 10.0)) != key
    assert machine_key(dataclasses.replace(machine, preferred_tilt_sign=-1
                                           * machine.preferred_tilt_sign)) != key


def test_the_post_leaves_checked_cutting_moves_whole_and_splits_the_others(
        checked_on_machine, tmp_path):
    path, machine = checked_on_machine
    tol = 1e-4  # finer than the plan's check: unchecked cutting moves get split
    whole = refine_for_joint_interpolation(path, machine, tol)
    unchecked = dataclasses.replace(path, joints_checked_for=None)
    split = refine_for_joint_interpolation(unchecked, machine, tol)

    def cut_moves(p):
        return int(((p.kinds[1:] == MoveKind.CUT) & (p.pass_index[1:] == p.pass_index[:-1])
                    & (p.pass_index[1:] >= 0)).sum())

    assert cut_moves(whole) == cut_moves(path) < cut_moves(split)
    assert whole.joints_checked_for == path.joints_checked_for
    # an old file kept a fingerprint in the metadata: read, not trusted (the post splits)
    arrays = {name: getattr(path, name) for name in (
        "positions_mm", "tool_axes", "kinds", "feeds_mm_per_min", "pass_index")}
    meta = {**path.metadata, LEGACY_JOINT_CHECKED_KEY: "trunnion-ac:0123456789ab"}
    np.savez_compressed(tmp_path / "old.npz", format_version=np.array(TOOLPATH_FORMAT_VERSION),
                        metadata_keys=np.array(list(meta), dtype=str),
                        metadata_values=np.array(list(meta.values()), dtype=str), **arrays)
    old = Toolpath.load(tmp_path / "old.npz")
    assert old.joints_checked_for is None and LEGACY_JOINT_CHECKED_KEY not in old.metadata
    np.testing.assert_array_equal(old.positions_mm, path.positions_mm)
    assert len(refine_for_joint_interpolation(old, machine, tol)) == len(split)


def test_the_refinement_hands_on_the_joints_of_the_path_it_returns(checked_on_machine):
    path, machine = checked_on_machine
    unchecked = dataclasses.replace(path, joints_checked_for=None)
    tol = 1e-3
    refined, joints = refine_with_joints(unchecked, machine, tol)
    assert len(refined) > len(path)  # (rounds of splits: deviations carried over between them)
    np.testing.assert_array_equal(joints, refined.to_machine(machine).joints)
    deviation = joint_path_deviation_mm(machine, refined.positions_mm, joints)
    assert deviation[refined.kinds[1:] != MoveKind.RAPID].max() <= tol
    # where the rounds run out, no joints: the last round's points were split after them
    assert refine_with_joints(unchecked, machine, 1e-6)[1] is None
