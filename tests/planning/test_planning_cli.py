"""``toolpath plan``: report, toolpath file, PNG, progress bar and errors."""

import json

import numpy as np

from streamline_cam.cli import main
from toolpath.path import Toolpath
from toolpath.planning import EllipticBladeSurface, SpherePatch


def test_plan_writes_path_plot_and_report(tmp_path, capsys):
    src = tmp_path / "cap.json"
    src.write_text(json.dumps(SpherePatch(radius_mm=30.0, longitude_deg=(-10, 10),
                                          colatitude_deg=(30, 40)).to_dict()))
    out, png = tmp_path / "path.npz", tmp_path / "path.png"
    code = main(["plan", str(src), "--machine", "grbl-router", "--cutter", "ball:6",
                 "--scallop", "0.01", "--chord-tol", "0.01", "-o", str(out),
                 "--plot", str(png), "--json"])
    captured = capsys.readouterr()
    assert code == 0
    report = json.loads(captured.out)
    assert report["within_request"] and report["max_scallop_mm"] <= 0.01
    assert report["machine"] == "grbl-router"
    path = Toolpath.load(out)
    assert len(path) == report["n_points"] and path.metadata["cutter"] == "ball:6"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plan_five_axis_spiral_with_placement(tmp_path, capsys):
    src = tmp_path / "blade.json"
    blade = EllipticBladeSurface(semi_axes_hub_mm=(12.0, 3.0), semi_axes_tip_mm=(11.0, 2.5),
                                 z_range_mm=(100.0, 104.0))
    src.write_text(json.dumps(blade.to_dict()))
    out = tmp_path / "p.npz"
    code = main(["plan", str(src), "--machine", "trunnion-ac", "--scallop", "0.02",
                 "--axis", "lead-tilt", "--lead", "10", "--linking", "spiral",
                 "--rotate", "z:90", "--on-table", "--on-limit", "report", "-o", str(out)])
    text = capsys.readouterr().out
    assert code == 0 and "lead-tilt / spiral" in text and "trunnion-ac" in text
    path = Toolpath.load(out)
    # placed on the table: lowest cut 20 mm above it, rotated 90 deg about z
    cut = path.positions_mm[path.pass_index >= 0]
    assert abs(cut[:, 2].min() - 20.0) < 4.0
    assert np.ptp(cut[:, 1]) > np.ptp(cut[:, 0])  # the long semi-axis now along y


def test_plan_errors_are_one_line_exit_2(tmp_path, capsys):
    src = tmp_path / "old.json"
    data = SpherePatch().to_dict()
    data["format_version"] = 0
    src.write_text(json.dumps(data))
    assert main(["plan", str(src), "--machine", "grbl-router"]) == 2
    err = capsys.readouterr().err
    assert "old.json" in err and "format_version 0" in err
    good = tmp_path / "cap.json"
    good.write_text(json.dumps(SpherePatch().to_dict()))
    assert main(["plan", str(good), "--machine", "nope"]) == 2
    assert "unknown machine 'nope'" in capsys.readouterr().err
    assert main(["plan", str(good), "--machine", "grbl-router", "--scallop", "-1"]) == 2
    assert "scallop_mm" in capsys.readouterr().err
    assert main(["plan", str(good), "--machine", "grbl-router", "--cutter", "ball"]) == 2
    assert "DIAMETER" in capsys.readouterr().err
    assert main(["plan", str(tmp_path / "missing.json"), "--machine", "grbl-router"]) == 2
    assert "missing.json" in capsys.readouterr().err


def test_plan_of_a_part_facing_away_from_the_spindle_says_how_to_place_it(tmp_path, capsys):
    # a blade laid on its side: 6 % of its area faces further from +Z than the tilt joint
    # reaches; the planner leans those axes back toward +Z (up to 65 deg off
    # the lead and tilt) and still plans. The command warns and gives the upright setup
    # 'toolpath run' takes; planned that way, nothing faces away and nothing is leaned.
    import shlex

    from toolpath.planning.setup import rotation_from_spec

    src = tmp_path / "blade.json"
    blade = EllipticBladeSurface(semi_axes_hub_mm=(12.0, 3.0), semi_axes_tip_mm=(11.0, 2.5),
                                 z_range_mm=(0.0, 40.0))
    src.write_text(json.dumps(blade.to_dict()))
    common = ["plan", str(src), "--machine", "trunnion-ac", "--axis", "lead-tilt", "--lead",
              "10", "--scallop", "0.05", "--chord-tol", "0.05", "--no-measure",
              "--on-limit", "report", "--json"]
    main([*common, "--rotate", "x:30,y:90"])
    captured = capsys.readouterr()
    assert json.loads(captured.out)["tilt_leaned_points"] > 0
    warning = [line for line in captured.err.splitlines() if "not placed" in line]
    assert len(warning) == 1 and "faces further from +Z than the tilt joint" in warning[0]
    advised = warning[0].split("from the surface as saved, ")[1].split(" stands it")[0]
    flags = shlex.split(advised.replace(" without --rotate", ""))
    if "--rotate" in flags:
        rotation_from_spec(flags[flags.index("--rotate") + 1])  # a spec the flag reads
    main([*common, *flags])
    captured = capsys.readouterr()
    assert json.loads(captured.out)["tilt_leaned_points"] == 0
    assert "not placed" not in captured.err


def test_a_plan_beyond_the_tilt_joint_names_the_upright_setup(tmp_path, capsys):
    src = tmp_path / "blade.json"
    blade = EllipticBladeSurface(semi_axes_hub_mm=(12.0, 3.0), semi_axes_tip_mm=(11.0, 2.5),
                                 z_range_mm=(0.0, 40.0))
    src.write_text(json.dumps(blade.to_dict()))
    code = main(["plan", str(src), "--machine", "head-table-bc", "--axis", "lead-tilt",
                 "--scallop", "0.05", "--chord-tol", "0.05", "--no-measure",
                 "--rotate", "y:90"])
    err = capsys.readouterr().err
    assert code == 2 and "is below its minimum" in err
    assert "--on-table" in err and "stands it upright" in err


def test_the_advised_rotation_reads_back_as_the_rotation():
    from scipy.spatial.transform import Rotation

    from toolpath.planning.setup import rotation_from_spec, spec_from_rotation

    for matrix in Rotation.random(20, random_state=1).as_matrix():
        back = rotation_from_spec(spec_from_rotation(matrix))
        assert np.degrees(Rotation.from_matrix(back.T @ matrix).magnitude()) < 0.2
    assert spec_from_rotation(np.eye(3)) == ""
