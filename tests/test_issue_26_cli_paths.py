"""Issue 26: one clear line and exit status 2 for every bad output path, unreadable file, port.

``-o`` into a missing folder or under a file printed a Python traceback from ``fit
surface``, ``plan``, ``post`` and ``run``; a random-bytes ``.npz`` given to ``post`` got
numpy's ``allow_pickle`` message. Every command that writes now checks its outputs before
its work (``streamline_cam.cli_files``), and the toolpath and surface readers name the file.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from streamline_cam.background_compile import ENV_SWITCH
from streamline_cam.cli import main
from toolpath import MoveKind, Toolpath
from toolpath.paper_examples import bundled_data_path
from toolpath.planning.analytic import PlaneSurface

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Inputs of every command: curve and section CSVs, a surface, a toolpath, a program."""
    root = tmp_path_factory.mktemp("inputs")
    blade = bundled_data_path("dev_blade_15x142.csv").read_text().splitlines()
    sections = root / "four.csv"
    sections.write_text("\n".join([blade[0], *(r for r in blade[1:] if r.split(",")[0] in
                                                "0123")]) + "\n")
    surface = root / "plane.json"
    surface.write_text(json.dumps(PlaneSurface().to_dict()))
    path = root / "path.npz"
    Toolpath(np.array([[0.0, 0, 5], [0, 0, 0], [10, 0, 0]]), np.array([0.0, 0, 1]),
             np.array([MoveKind.RAPID, MoveKind.PLUNGE, MoveKind.CUT]),
             np.array([0.0, 300, 800]), np.array([-1, 0, 0])).save(path)
    program = root / "part.nc"
    program.write_text("G21 G90\nG0 Z5\nG1 Z0 F300\nG1 X10 F800\nM30\n")
    a_file = root / "a_file"
    a_file.write_text("not a folder")
    return {"curve": str(bundled_data_path("dev_half_profile_71.csv")),
            "sections": str(sections), "surface": str(surface), "path": str(path),
            "program": str(program), "file": a_file, "root": root}


COMMANDS = {  # argv before the output option, the output option
    "fit curve -o": (["fit", "curve", "{curve}"], "-o"),
    "fit curve --plot": (["fit", "curve", "{curve}"], "--plot"),
    "fit surface -o": (["fit", "surface", "{sections}"], "-o"),
    "fit surface --plot": (["fit", "surface", "{sections}"], "--plot"),
    "plan -o": (["plan", "{surface}", "--machine", "grbl-router"], "-o"),
    "plan --plot": (["plan", "{surface}", "--machine", "grbl-router"], "--plot"),
    "post -o": (["post", "{path}", "--machine", "grbl-router"], "-o"),
    "verify --plot": (["verify", "{program}", "--surface", "{surface}", "--machine",
                       "grbl-router", "--cutter", "ball:6"], "--plot"),
    "run -o": (["run", "{sections}"], "-o"),
    "send --journal": (["send", "{program}", "--port", "socket://127.0.0.1:1", "--machine",
                        "grbl-router"], "--journal"),
}


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("\n") == 1, err
    return err


@pytest.mark.parametrize("where", ["missing folder", "under a file", "a folder"])
@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_an_output_that_cannot_be_written_is_one_line_before_the_work(files, capsys, command,
                                                                       where):
    head, flag = COMMANDS[command]
    target = {"missing folder": files["root"] / "no_such_folder" / "out.x",
              "under a file": files["file"] / "out.x",
              "a folder": files["root"]}[where]
    if command == "run -o" and where == "missing folder":
        pytest.skip("run creates its output folder (it writes several files there)")
    argv = [part.format(**files) for part in head] + [flag, str(target)]
    assert main(argv) == 2
    err = _one_error_line(capsys)
    assert err.startswith(f"toolpath: error: {flag} {target}: cannot write")
    assert not (files["root"] / "no_such_folder").exists()


@pytest.mark.parametrize("argv", [["demo", "--out", "{file}/demo"],
                                  ["serve", "--data-dir", "{file}/data"]])
def test_output_folders_under_a_file_are_one_line(files, capsys, argv):
    argv = [part.format(**files) for part in argv]
    assert main(argv) == 2
    err = _one_error_line(capsys)
    assert f"{files['file']} is a file, not a folder" in err


@pytest.mark.parametrize("content", [bytes(range(256)) * 4, b"PK\x03\x04broken zip",
                                     b'{"kind": "analytic_plane"}'])
def test_unreadable_toolpath_files_are_one_line_naming_the_file(tmp_path, capsys, content):
    bad = tmp_path / "bad.npz"
    bad.write_bytes(content)
    assert main(["post", str(bad), "--machine", "grbl-router"]) == 2
    err = _one_error_line(capsys)
    assert err.startswith(f"toolpath: error: {bad}: not a toolpath file")
    assert "pickle" not in err


def test_a_damaged_npz_archive_is_one_line(tmp_path, capsys, files):
    good = (tmp_path / "x.npz")
    data = bytearray(open(files["path"], "rb").read())
    data[60:120] = b"\xff" * 60  # inside the first member's compressed data
    good.write_bytes(bytes(data))
    assert main(["post", str(good), "--machine", "grbl-router"]) == 2
    assert f"{good}: " in _one_error_line(capsys)


@pytest.mark.parametrize("argv", [
    ["plan", "{bin}", "--machine", "grbl-router"],
    ["verify", "{program}", "--surface", "{bin}", "--machine", "grbl-router",
     "--cutter", "ball:6"],
    ["gcode-info", "{bin}"],
    ["fit", "surface", "{bin}"],
    ["verify", "{bin}", "--surface", "{surface}", "--machine", "grbl-router",
     "--cutter", "ball:6"],
    ["post", "{path}", "--machine", "{bin}"],
])
def test_binary_input_files_are_one_line_naming_the_file(tmp_path, capsys, files, argv):
    binary = tmp_path / "random.bin"
    binary.write_bytes(bytes(range(255, -1, -1)))
    argv = [part.format(bin=binary, **files) for part in argv]
    assert main(argv) == 2
    assert str(binary) in _one_error_line(capsys)


def test_an_empty_port_number_is_one_line(files, capsys):
    assert main(["send", files["program"], "--port", "socket://127.0.0.1:",
                 "--machine", "grbl-router"]) == 2
    assert "--port 'socket://127.0.0.1:'" in _one_error_line(capsys)


@pytest.mark.parametrize("port", ["99999", "-1", "x"])
def test_a_port_out_of_range_is_refused_by_serve(capsys, port):
    with pytest.raises(SystemExit) as stop:  # argparse: usage error, exit 2
        main(["serve", "--port", port])
    assert stop.value.code == 2
    err = capsys.readouterr().err  # argparse: the usage, then the error
    assert "Traceback" not in err
    assert err.splitlines()[-1].endswith(f"expected a port number 0-65535, got '{port}'")


@pytest.mark.parametrize(("content", "said"), [
    (bytes(range(255, -1, -1)), "points.csv: cannot read the file"),
    (b"section,x,y,z\n0,0,0,0\n0,1,0,0\n1,0,0,1\n1,1,0,1\n", "at least 4 sections, got 2"),
])
def test_bad_points_for_run_on_a_cold_kernel_cache_are_one_line(tmp_path, content, said):
    """``run`` reads and checks its points before its compile helpers start and say so.

    A process of its own on an empty kernel cache: with a warm one nothing is said of
    compiling, so an in-process test passes either way.
    """
    points = tmp_path / "points.csv"
    points.write_bytes(content)
    env = {name: value for name, value in os.environ.items() if name != ENV_SWITCH}
    env |= {"PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    done = subprocess.run([sys.executable, "-m", "streamline_cam.cli", "run", str(points),
                           "-o", str(tmp_path / "job" / "part.nc")],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 2
    assert "Traceback" not in done.stderr and done.stderr.count("\n") == 1, done.stderr
    assert done.stderr.startswith("toolpath: error: ") and said in done.stderr, done.stderr
    assert not (tmp_path / "job").exists()
