"""toolpath post | check | gcode-info through streamline_cam.cli.main."""

from toolpaths import blade_5axis, pocket_3axis

from gcode import GRBL, parse
from streamline_cam.cli import main


def test_post_check_and_info_round_trip(tmp_path, capsys):
    npz, nc = tmp_path / "pocket.npz", tmp_path / "pocket.nc"
    pocket_3axis().save(npz)
    assert main(["post", str(npz), "--machine", "grbl-router", "-o", str(nc)]) == 0
    text = nc.read_text(encoding="ascii")
    assert text.startswith("G21\nG94G17G90\n(pocket 3-axis)\n") and "G3X20Y10I0J10" in text
    parse(text, GRBL)  # strict parse succeeds
    assert "lines for grbl-router" in capsys.readouterr().err

    assert main(["check", str(nc), "--machine", "grbl-router"]) == 0
    cap = capsys.readouterr()
    assert cap.out == "" and "0 error(s), 0 warning(s)" in cap.err

    assert main(["gcode-info", str(nc), "--machine", "grbl-router"]) == 0
    out = capsys.readouterr().out
    for want in ("blocks: ", "bounds X: -400 .. -370 mm", "length feed: ", "time: "):
        assert want in out
    assert "rapids not timed" not in out
    assert main(["gcode-info", str(nc)]) == 0
    out = capsys.readouterr().out
    assert "bounds X: 0 .. 30 mm" in out and "rapids not timed" in out


def test_post_five_axis_to_stdout_with_options(tmp_path, capsys):
    npz = tmp_path / "blade.npz"
    blade_5axis().save(npz)
    argv = ["post", str(npz), "--machine", "trunnion-ac", "--dialect", "fanuc", "--tool", "2",
            "--inch", "--coolant", "mist", "--no-arcs"]  # fmt: skip
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert out.startswith("%\nO0001 (blade 5-axis)\nN10 G20\n")
    assert "T2 M06" in out and "M07" in out and "G93" in out and out.endswith("%\n")


def test_post_refuses_a_five_axis_toolpath_for_grbl_in_one_stderr_line(tmp_path, capsys):
    npz = tmp_path / "blade.npz"
    blade_5axis().save(npz)
    assert main(["post", str(npz), "--machine", "grbl-router", "-o", str(tmp_path / "x.nc")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "5-axis toolpath refused for a 3-axis machine" in err
    assert not (tmp_path / "x.nc").exists()


def test_check_prints_one_line_per_issue_and_fails_on_errors(tmp_path, capsys):
    nc = tmp_path / "bad.nc"
    nc.write_text("G21 G90\nG0 X500\nG1 X0 A10 F100\nG1 X10 F9000\n")
    assert main(["check", str(nc), "--machine", "grbl-router"]) == 1
    out = capsys.readouterr().out.splitlines()
    assert [line.split(" ")[0] for line in out] == [f"{nc}:2:", f"{nc}:3:", f"{nc}:4:"]
    assert "error soft-limit" in out[0] and "error unsupported" in out[1]
    assert "warning feed-above-max-rate" in out[2]
    nc.write_text("G21 G90\nG1 X10 F9000\n")
    assert main(["check", str(nc), "--machine", "grbl-router"]) == 0  # warnings only


def test_missing_files_and_unknown_machines_exit_2(tmp_path, capsys):
    missing = str(tmp_path / "missing.nc")
    assert main(["check", missing, "--machine", "grbl-router"]) == 2
    assert main(["gcode-info", missing]) == 2
    assert main(["check", missing, "--machine", "no-such-machine"]) == 2
    err = capsys.readouterr().err
    assert "unknown machine 'no-such-machine'" in err
    assert main(["post", missing + ".npz", "--machine", "grbl-router"]) == 2
