"""Start-up: commands load the heavy packages only where they use them (issue 27).

A behaviour test, not a timing test: a fresh interpreter runs ``toolpath --help``, a
command's ``--help`` or ``toolpath check`` and reports which of the heavy packages it
imported. Help loads none of them, not even numpy: a command module declares its parser
from numpy-free modules and loads its work in its handler (``streamline_cam.commands``).
"""

import json
import os
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("numba", "scipy", "matplotlib", "fastapi", "uvicorn")
#: What no help text needs: numpy, the service's event loop, the senders' serial ports.
NOT_FOR_HELP = (*HEAVY, "numpy", "asyncio", "serial", "pymodbus", "tqdm")
#: ``check`` reads the program with numpy; it needs no planner, post, emitter (a file is
#: checked as written), sender or service.
NOT_FOR_CHECK = (*HEAVY, "asyncio", "serial", "pymodbus", "tqdm", "gcode.post", "gcode.emitter",
                 "gcode.senders.job", "toolpath.planning.finishing", "toolpath.surface",
                 "streamline_cam.fit_report", "streamline_cam.service.config")
COMMANDS = sorted(info.name.replace("_", "-") for info in
                  pkgutil.iter_modules([str(ROOT / "streamline_cam" / "commands")]))

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


def _run(argv: list[str], cwd: Path, heavy: tuple[str, ...] = HEAVY) -> dict:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", PROBE, json.dumps(argv), json.dumps(heavy)],
                          cwd=cwd, env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


def test_every_command_is_asked_for_its_help():
    assert {"check", "plan", "post", "run", "send", "serve", "verify"} <= set(COMMANDS)


@pytest.mark.parametrize("argv", [["--help"], ["fit", "--help"], ["fit", "curve", "--help"],
                                  ["fit", "surface", "--help"], ["demo", "--help"],
                                  *([command, "--help"] for command in COMMANDS)],
                         ids=" ".join)
def test_help_loads_no_heavy_package_nor_numpy(argv, tmp_path):
    result = _run(argv, tmp_path, NOT_FOR_HELP)
    assert result == {"code": 0, "heavy": []}


@pytest.mark.parametrize("argv", [["plan", "--no-such-flag"], ["check", "x.nc"],
                                  ["post", "x.npz", "--machine", "m", "--coolant", "hot"],
                                  ["send", "x.nc", "--port", "p", "--mode", "fast"]],
                         ids=" ".join)
def test_a_bad_flag_is_refused_without_numpy(argv, tmp_path):
    result = _run(argv, tmp_path, NOT_FOR_HELP)
    assert result == {"code": 2, "heavy": []}


def test_check_loads_only_what_checking_needs(tmp_path):
    program = tmp_path / "part.nc"
    program.write_text("G21 G90\nG0 X0 Y0 Z5\nG1 X10 Y5 Z-1 F600\nM2\n", encoding="utf-8")
    result = _run(["check", str(program), "--machine", "grbl-router"], tmp_path, NOT_FOR_CHECK)
    assert result == {"code": 0, "heavy": []}


def test_a_planning_command_still_finds_the_planner(tmp_path):
    # the lazy package namespaces resolve every exported name
    code = ("import gcode, machines, toolpath, toolpath.planning, verification, simulator\n"
            "for package in (gcode, machines, toolpath, toolpath.planning, verification,\n"
            "                simulator):\n"
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


def test_the_machines_modules_stay_reachable_as_attributes():
    # before the lazy exports, ``import machines`` imported every module of the package
    code = ("import machines\n"
            "for name in ('axes', 'catalog', 'errors', 'kinematics', 'limits', 'machine',\n"
            "             'units'):\n"
            "    assert getattr(machines, name).__name__ == 'machines.' + name\n"
            "    assert name in dir(machines)\n"
            "print(machines.kinematics.forward.__module__)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "machines.kinematics"


def test_quiet_stage_bars_load_no_tqdm():
    # fails if tqdm is imported with the module (mutation: the import back at its top) or
    # a disabled bar is still made (mutation: drop the early return in StageBars.__call__)
    code = """
import sys
from streamline_cam.progress import StageBars
bars = StageBars(disable=True)
for stage in ("fit", "plan"):
    bars(stage, 0.0)
    bars(stage, 1.0)
bars.close()
print("tqdm" in sys.modules)
"""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["False"] and done.stderr == ""


def test_stage_bars_draw_each_stage(capsys):
    from streamline_cam.progress import StageBars

    bars = StageBars()
    bars("fit", 0.0)
    bars("fit", 1.0)
    bars("plan", 0.5)
    bars.close()
    err = capsys.readouterr().err
    assert "fit" in err and "100%" in err and "plan" in err and "50%" in err
