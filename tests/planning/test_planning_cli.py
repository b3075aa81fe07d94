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
