"""The README's main command, end to end: fits, blade pipeline, stream into the simulator."""

import json

from streamline_cam.cli import main


def test_quick_demo_runs_the_pipeline_and_streams_exactly_once(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path), "--quick"]) == 0
    report = json.loads((tmp_path / "report.json").read_text())
    assert len(report["curves"]) == 6 and all(row["within_tol"] for row in report["curves"])
    blade = report["blade"]
    assert blade["fit"]["max_error_mm"] <= 0.01
    assert blade["plan"]["max_scallop_mm"] <= blade["plan"]["scallop_request_mm"]
    assert blade["check"]["errors"] == 0
    verified = blade["verify"]
    assert verified["max_scallop_mm"] <= 1.1 * blade["plan"]["scallop_request_mm"]
    assert (verified["max_gouge_mm"] or 0.0) <= 1.1 * blade["plan"]["chord_tol_mm"]
    stream = blade["stream"]
    assert stream["ok"] and stream["exactly_once"] and stream["rx_dropped_bytes"] == 0
    assert stream["executed_blocks"] > 1000 and stream["alarm"] is None
    for name in ("part.nc", "surface.json", "toolpath.npz", "fit.png", "part.journal",
                 "toolpath.png", "deviation.png", "passes_ts.png"):
        assert (tmp_path / "blade" / name).stat().st_size > 0
    assert "exactly_once True" in capsys.readouterr().out
