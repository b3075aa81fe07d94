"""Start-up: commands load the heavy packages only where they use them (issue 27).

A behaviour test, not a timing test: a fresh interpreter runs ``toolpath --help`` or
``toolpath check`` and reports which of numba, scipy, matplotlib, fastapi it imported.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("numba", "scipy", "matplotlib", "fastapi", "uvicorn")

PROBE = """
import contextlib, io, json, sys
from streamline_cam.cli import main
argv = json.loads(sys.argv[1])
with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
    try:
        code = main(argv)
    except SystemExit as stop:
        code = stop.code
print(json.dumps({"code": code, "heavy": sorted(m for m in json.loads(sys.argv[2])
                                                if m in sys.modules)}))
"""


def _run(argv: list[str], cwd: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", PROBE, json.dumps(argv), json.dumps(HEAVY)],
                          cwd=cwd, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


@pytest.mark.parametrize("argv", [["--help"], ["check", "--help"], ["plan", "--help"],
                                  ["verify", "--help"], ["run", "--help"]])
def test_help_loads_no_heavy_package(argv, tmp_path):
    result = _run(argv, tmp_path)
    assert result == {"code": 0, "heavy": []}


def test_check_loads_no_heavy_package(tmp_path):
    program = tmp_path / "part.nc"
    program.write_text("G21 G90\nG0 X0 Y0 Z5\nG1 X10 Y5 Z-1 F600\nM2\n", encoding="utf-8")
    result = _run(["check", str(program), "--machine", "grbl-router"], tmp_path)
    assert result == {"code": 0, "heavy": []}


def test_a_planning_command_still_finds_the_planner(tmp_path):
    # the lazy package namespaces resolve every exported name
    code = ("import gcode, toolpath, toolpath.planning, verification, simulator\n"
            "for package in (gcode, toolpath, toolpath.planning, verification, simulator):\n"
            "    for name in package.__all__:\n"
            "        getattr(package, name)\n"
            "    assert set(package.__all__) <= set(dir(package))\n"
            "print(toolpath.plan_finishing.__module__)")
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                          text=True, timeout=120, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "toolpath.planning.finishing"


def test_an_unknown_name_is_an_attribute_error():
    import toolpath

    with pytest.raises(AttributeError, match="no attribute 'plan_everything'"):
        toolpath.plan_everything  # noqa: B018


def test_an_export_named_like_its_module_stays_the_export():
    import gcode.post  # noqa: F401  (the submodules loaded, as a planning command does)
    import verification.replay  # noqa: F401
    from gcode import post
    from verification import replay

    assert callable(post) and post.__module__ == "gcode.post"
    assert callable(replay) and replay.__module__ == "verification.replay"


def test_run_loads_the_senders_only_to_stream(tmp_path):
    # a job that fails on its points file has gone through the command's set-up
    probe = PROBE.replace("json.loads(sys.argv[2])", "sys.argv[2].split()")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, "-c", probe,
         json.dumps(["run", "missing.csv", "--quiet", "-o", str(tmp_path / "part.nc")]),
         "streamline_cam.streaming gcode.senders.grbl_sender"],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout.splitlines()[-1]) == {"code": 2, "heavy": []}
