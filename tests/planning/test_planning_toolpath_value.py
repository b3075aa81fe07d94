"""The Toolpath value a plan produces: validation, and the .npz round trip."""

import numpy as np
import pytest

from toolpath.errors import DataFileError, InvalidParameterError
from toolpath.path import MoveKind, Toolpath
from toolpath.planning import PlaneSurface, plan_finishing


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
