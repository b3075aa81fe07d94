"""The README's commands and Python, run exactly as written (PORT: a simulator started here)."""

import re
import shlex
from pathlib import Path

import pytest

from machines import load_machine
from simulator import run_simulator
from streamline_cam.cli import main

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")


def _block(after_heading: str, language: str) -> str:
    tail = README[README.index(after_heading):]
    match = re.search(rf"```{language}\n(.*?)```", tail, re.S)
    assert match, f"no {language} block after {after_heading!r}"
    return match.group(1)


def test_readme_starts_with_the_two_commands():
    first = re.search(r"```sh\n(.*?)```", README, re.S).group(1).splitlines()
    assert first[0].startswith("make demo") and first[1].startswith("make test")
    assert (ROOT / ".ci" / "run").read_text().strip().endswith("make test")


def test_readme_tour_runs_line_by_line(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "toolpath").symlink_to(ROOT / "toolpath")  # the README's relative data path
    lines = [ln for ln in _block("## The job, one command at a time", "sh").splitlines()
             if ln.startswith("toolpath ")]
    assert len(lines) >= 9
    machine = load_machine("grbl-router")
    g54 = (*machine.work_origin, 0.0, 0.0, 0.0)
    with run_simulator(machine, serial="tcp", speed="instant", baud=0,
                       work_offsets={1: g54}) as sim:
        port = sim.serial_url.rsplit(":", 1)[1]
        for line in lines:
            argv = shlex.split(line.replace("PORT", port))[1:]
            assert main(argv) == 0, f"README line failed: {line}\n{capsys.readouterr()}"
        assert sim.wait_idle(30.0)
        assert sim.snapshot()["alarm"] is None
    for name in ("blade.json", "blade.png", "path.npz", "part5.nc", "deviation.png",
                 "job/part.nc", "job.log"):
        assert (tmp_path / name).stat().st_size > 0, name


def test_readme_python_block_runs(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    namespace: dict = {}
    exec(compile(_block("## Python", "python"), "README.md", "exec"), namespace)
    assert namespace["surf"].max_error <= 0.01 and namespace["curve"].max_error <= 0.01


@pytest.mark.parametrize("command", ["plan", "post", "check", "gcode-info", "simulate", "send",
                                     "run", "serve", "verify", "demo", "fit"])
def test_every_command_of_the_tour_is_documented_in_help(command, capsys):
    with pytest.raises(SystemExit) as stop:
        main([command, "--help"])
    assert stop.value.code == 0 and "usage: toolpath" in capsys.readouterr().out
