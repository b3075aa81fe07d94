"""``toolpath verify``: report on stdout, one summary line on stderr, exit status by gouge."""

import json

from verify_programs import zigzag_raster

from gcode import GRBL, emit_text
from streamline_cam.cli import main
from toolpath.planning.analytic import PlaneSurface


def _files(tmp_path, shift=None):
    nc, surface = tmp_path / "part.nc", tmp_path / "plane.json"
    program = zigzag_raster([0.0, 0.8, 1.6, 2.4, 3.2], -5.0, 15.0, shift=shift)
    nc.write_text(emit_text(program, GRBL), encoding="ascii")
    plane = PlaneSurface((0.0, 0.0, 0.0), (10.0, 0.0, 0.0), (0.0, 3.2, 0.0))
    surface.write_text(json.dumps(plane.to_dict()), encoding="utf-8")
    return str(nc), str(surface)


def test_a_clean_program_exits_0_and_writes_the_map(tmp_path, capsys):
    nc, surface = _files(tmp_path)
    png = tmp_path / "dev.png"
    argv = ["verify", nc, "--surface", surface, "--machine", "grbl-router", "--cutter",
            "ball:6", "--spacing", "0.1", "--plot", str(png)]
    assert main(argv) == 0
    cap = capsys.readouterr()
    assert "gouge: none deeper than 0.002 mm" in cap.out and "scallop: " in cap.out
    assert cap.err.count("\n") == 1 and ": ok: deepest gouge 0.0000 mm" in cap.err
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_gouge_deeper_than_the_limit_exits_1_and_names_the_line(tmp_path, capsys):
    nc, surface = _files(tmp_path, shift={2: -0.05})
    argv = ["verify", nc, "--surface", surface, "--machine", "grbl-router", "--cutter",
            "ball:6", "--spacing", "0.1", "--json"]
    assert main(argv) == 1
    cap = capsys.readouterr()
    data = json.loads(cap.out)
    line = data["max_gouge"]["line"]
    text = open(nc).read().splitlines()
    assert "Y1.6" in text[line - 2] and "Z-0.05" in text[line - 2]  # the plunge into the pass
    assert data["max_gouge_mm"] > 0.04 and data["gouging_blocks"][0]["line"] == line
    assert "FAIL: deepest gouge 0.05" in cap.err and f"at line {line}" in cap.err
    assert main([*argv[:-1], "--gouge-limit", "0.1"]) == 0


def test_bad_input_is_one_stderr_line_and_exit_2(tmp_path, capsys):
    nc, surface = _files(tmp_path)
    base = ["verify", nc, "--surface", surface, "--machine", "grbl-router", "--cutter"]
    for argv in ([*base, "bull:6:4"], [*base, "ball:six"],
                 ["verify", str(tmp_path / "missing.nc"), *base[2:], "ball:6"],
                 ["verify", nc, "--surface", nc, "--machine", "grbl-router", "--cutter",
                  "ball:6"]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("toolpath: error: ")


def test_flat_and_bull_nose_cutters_are_verified(tmp_path, capsys):
    nc, surface = _files(tmp_path)
    for spec in ("flat:6", "bull:6:1"):
        argv = ["verify", nc, "--surface", surface, "--machine", "grbl-router", "--cutter",
                spec, "--spacing", "0.2", "--json"]
        assert main(argv) == 0
        data = json.loads(capsys.readouterr().out)
        assert data["cutter"] == spec and data["max_gouge"] is None
