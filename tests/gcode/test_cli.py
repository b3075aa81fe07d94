"""python -m gcode parse|info: data on stdout, one-line errors on stderr, exit codes."""

import subprocess
import sys

from conftest import DATA

from gcode.__main__ import main


def test_info_reports_blocks_bounds_length_and_time(tmp_path, capsys):
    path = tmp_path / "p.nc"
    path.write_text("G21 G90\nG0 X0 Y0\nG1 X30 Y40 F600\nG4 P2\nM30\n")
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "blocks: 5" in out and "bounds X: 0 .. 30 mm" in out
    assert "length feed: 50 mm" in out and "time: 7 s" in out


def test_parse_lists_blocks_with_lines(capsys):
    assert main(["parse", str(DATA / "golden" / "grbl_3axis.nc"), "--dialect", "grbl"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("2: SetFeedMode(") and out[-1] == "19: ProgramEnd(rewind=True)"


def test_errors_go_to_stderr_on_one_line_with_nonzero_exit(capsys):
    bad = DATA / "bad" / "modal_group.nc"
    assert main(["parse", str(bad)]) == 1
    cap = capsys.readouterr()
    assert cap.out == ""
    assert cap.err.count("\n") == 1 and ":line 4: error 21 (MODAL_GROUP_VIOLATION)" in cap.err
    assert main(["info", str(DATA / "missing.nc")]) == 1
    assert main(["bogus"]) == 2


def test_module_entry_point_runs():
    bad = DATA / "bad" / "exponent_number.nc"
    res = subprocess.run([sys.executable, "-m", "gcode", "parse", str(bad)],
                         capture_output=True, text=True, check=False)  # fmt: skip
    assert res.returncode == 1 and "error 2 (BAD_NUMBER_FORMAT)" in res.stderr
