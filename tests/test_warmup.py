"""``toolpath warm-up``: the recorded jobs' kernels compiled without a job (issue 27)."""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from streamline_cam import warmup
from streamline_cam.background_compile import (
    CORNER_JOBS,
    RECORDED_JOBS,
    job_kernels,
    recorded_kernels,
)
from streamline_cam.cli import main
from toolpath import as_sections, read_sections
from toolpath.paper_examples import bundled_data_path

ROOT = Path(__file__).resolve().parents[1]


def test_the_recorded_jobs_cover_open_and_closed_blades_3_and_5_axis_and_corner_cutters():
    kinds = {(kind, job.axis_mode, as_sections(read_sections(bundled_data_path(job.blade))).closed,
              job.machine, job.cutter)
             for kind, jobs in RECORDED_JOBS.items() for job in jobs}
    # ball-nose 3-axis on the open development blade, 5-axis on it and round closed
    # sections; a bull-nose job for the flat and bull-nose cutters' kernels
    assert kinds == {("3", "3", False, "grbl-router", "ball:6"),
                     ("lead-tilt", "lead-tilt", False, "trunnion-ac", "ball:6"),
                     ("lead-tilt", "lead-tilt", True, "trunnion-ac", "ball:6"),
                     (CORNER_JOBS, "3", False, "grbl-router", "bull:8:1")}


def test_the_warm_up_compiles_every_recorded_kernel_once_stage_by_stage():
    kernels = recorded_kernels()
    every = {(k.module, k.name, json.dumps(k.args)) for mode in RECORDED_JOBS
             for k in job_kernels(mode, ("fit", "plan", "post", "check", "verify"))}
    assert len(kernels) == len(every)
    assert {(k.module, k.name, json.dumps(k.args)) for k in kernels} == every
    stages = [k.stage for k in kernels]
    assert stages == sorted(stages, key=["fit", "plan", "verify"].index)  # the verifier's too
    assert warmup.both_ends(5) == [0, 4, 1, 3, 2] and warmup.both_ends(0) == []
    assert sorted(warmup.both_ends(8)) == list(range(8))


def test_warm_up_is_a_documented_command(capsys):
    try:
        main(["warm-up", "--help"])
    except SystemExit as stop:
        assert stop.code == 0
    assert "compile" in capsys.readouterr().out


def test_kernels_a_failed_worker_pool_did_not_finish_compile_in_this_process(monkeypatch):
    ran, said = [], []
    kernels = recorded_kernels()[:3]

    def pool_that_breaks(workers, kernels_, pending, progress):
        progress.done(pending[0], "compiled", 1.0)  # the first kernel done in a worker
        pending.remove(pending[0])
        raise OSError("no /dev/shm")

    def compile_here(kernel, wait):
        ran.append(kernel)
        return "compiled", 0.5

    monkeypatch.setattr(warmup, "_in_processes", pool_that_breaks)
    monkeypatch.setattr(warmup, "warm_kernel", compile_here)
    warmup.warm_up(said.append, processes=2, kernels=kernels)
    assert sorted(ran) == sorted(kernels[1:])  # each kernel once: none lost, none repeated
    assert any("worker process failed (no /dev/shm)" in line for line in said)
    assert said[-1].startswith("warm-up: 3 compiled")


KERNEL_MODULE = '''
import os

import numba
from numba.extending import overload


@numba.njit(cache=True)
def inner(x):
    return x.sum()


@numba.njit(cache=True)
def outer(x):
    return inner(x) * 2.0


@numba.njit(cache=True)
def broken(x):
    return x.no_such_attribute


def die():
    pass


@overload(die)
def _die_while_compiling():
    os._exit(70)  # (as a crash in LLVM would: the process compiling is gone)


@numba.njit(cache=True)
def killer(x):
    die()
    return x.sum()
'''

# Warms up the module's kernels (one fails to compile, one is gone) in two processes, then
# calls the good ones here: they come from the cache.
WARM = '''
import json, sys
import numpy as np
from streamline_cam.background_compile import Kernel
from streamline_cam.warmup import warm_up

ARRAY = {"array": "float64", "ndim": 1, "layout": "C", "readonly": False}
kernels = [Kernel("kmod", name, (ARRAY,), stage)  # (arguments: name:stage)
           for name, stage in (entry.split(":") for entry in sys.argv[1:])]
if __name__ == "__main__":
    said = []
    warm_up(said.append, processes=2, kernels=kernels)
    import kmod
    value = kmod.outer(np.ones(3))
    hits = {name: sum(getattr(kmod, name).stats.cache_hits.values())
            for name in ("inner", "outer")}
    print(json.dumps({"said": said, "value": value, "hits": hits}))
'''


def _warm_up_kmod(folder, *kernels):
    """Run WARM on ``kernels`` (``name:stage``) of KERNEL_MODULE; its result and exit code."""
    (folder / "kmod.py").write_text(KERNEL_MODULE, encoding="utf-8")
    (folder / "warm.py").write_text(WARM, encoding="utf-8")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join((str(folder), str(ROOT))),
           "NUMBA_CACHE_DIR": str(folder / "cache")}
    done = subprocess.run([sys.executable, "warm.py", *kernels], cwd=folder, env=env,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, f"warm-up exit {done.returncode}: {done.stderr[-2000:]}"
    return json.loads(done.stdout.splitlines()[-1])


def test_a_kernel_that_fails_to_compile_is_reported_and_skipped(tmp_path):
    result = _warm_up_kmod(tmp_path, "inner:fit", "broken:plan", "outer:plan", "gone:verify")
    said = "\n".join(result["said"])
    assert "kmod.broken did not compile (TypingError" in said
    assert "kmod.gone did not compile (AttributeError" in said
    assert all(f"{stage} kernels done" in said for stage in ("fit", "plan", "verify"))
    assert result["said"][-1].startswith("warm-up: 2 compiled, 2 failed")
    # outer called from Python loads from the cache: the warm-up compiled it (and inner)
    assert result["value"] == 6.0 and result["hits"] == {"inner": 0, "outer": 1}


@pytest.mark.parametrize("order", [("killer", "inner", "outer"), ("inner", "killer", "outer")])
def test_a_kernel_whose_compile_kills_its_process_is_reported_and_skipped(tmp_path, order):
    # two workers: the killer alone in flight, or beside another kernel when it dies
    result = _warm_up_kmod(tmp_path, *(f"{name}:plan" for name in order))
    said = "\n".join(result["said"])
    assert "kmod.killer did not compile (the process compiling it died)" in said
    assert "worker process failed" not in said  # (nothing compiled in the warm-up's process)
    # inner is compiled by itself or, when outer's compile got there first, found cached
    assert re.match(r"warm-up: (2 compiled|1 cached, 1 compiled), 1 failed", result["said"][-1])
    assert result["value"] == 6.0 and result["hits"] == {"inner": 0, "outer": 1}


# Coarse jobs as a user runs them, counting what numba compiles for our kernels: a 5-axis
# ball-nose job, then a verified 3-axis bull-nose one.
JOBS = '''
import json, sys
from numba.core import event
from streamline_cam.cli import main

compiled = []


class Compiles(event.Listener):
    def on_start(self, ev):
        func = ev.data["dispatcher"].py_func
        compiled.append(f"{func.__module__}.{func.__qualname__}")

    def on_end(self, ev):
        pass


event.register("numba:compile", Compiles())
codes = [main(["run", sys.argv[1], "--machine", "trunnion-ac", "--axis", "lead-tilt",
               "--lead", "10", "--scallop", "0.05", "--chord-tol", "0.02", "--quiet",
               "-o", "job/part.nc"])]
ball_compiled = list(compiled)
codes.append(main(["run", sys.argv[1], "--cutter", "bull:8:1", "--scallop", "0.05",
                   "--chord-tol", "0.05", "--verify", "--quiet", "-o", "bull/part.nc"]))
print(json.dumps({"codes": codes, "compiled": [ball_compiled, compiled[len(ball_compiled):]]}))
'''


@pytest.mark.slow
def test_after_the_warm_up_ball_and_bull_nose_jobs_compile_nothing(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    warm = subprocess.run([sys.executable, "-m", "streamline_cam.cli", "warm-up"], cwd=tmp_path,
                          env=env, capture_output=True, text=True, timeout=1800)
    assert warm.returncode == 0, warm.stderr
    assert "did not compile" not in warm.stderr, warm.stderr
    blade = str(bundled_data_path("dev_blade_15x142.csv"))
    job = subprocess.run([sys.executable, "-c", JOBS, blade], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=1800)
    assert job.returncode == 0, job.stderr
    result = json.loads(job.stdout.splitlines()[-1])
    assert result["codes"] == [0, 0] and result["compiled"] == [[], []]


def test_the_warm_up_writes_the_modules_bytecode(tmp_path, monkeypatch):
    # fails if compile_modules writes nothing (mutation: skip its compile_dir call), or
    # writes one folder level only (mutation: compile_dir(..., maxlevels=0))
    import importlib.util

    package = tmp_path / "warmpkg"
    (package / "inner").mkdir(parents=True)
    modules = [package / "__init__.py", package / "a.py", package / "inner" / "__init__.py",
               package / "inner" / "b.py"]
    for module in modules:
        module.write_text("VALUE = 1\n", encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setattr(sys, "dont_write_bytecode", True)  # (as PYTHONDONTWRITEBYTECODE=1)
    assert warmup.compile_modules(("warmpkg",)) == []
    for module in modules:
        assert Path(importlib.util.cache_from_source(str(module))).is_file(), module


def test_the_warm_up_command_writes_the_bytecode_of_every_package(monkeypatch):
    # fails if the command does not call compile_modules (mutation: drop the call), or
    # its list leaves out a package the project installs
    import tomllib

    called = []
    monkeypatch.setattr(warmup, "compile_modules", lambda: called.append(True) or [])
    monkeypatch.setattr(warmup, "warm_up", lambda say=None: 0.0)
    assert main(["warm-up", "--quiet"]) == 0
    assert called == [True]
    with open(ROOT / "pyproject.toml", "rb") as file:
        find = tomllib.load(file)["tool"]["setuptools"]["packages"]["find"]
    assert set(warmup.PACKAGES) == {name.rstrip("*") for name in find["include"]}
