"""A cold job's later kernels compiled in a second process (issue 27).

Real processes on a kernel module of the test's own and an empty kernel cache: the helper
starts on a cold cache and compiles what it was given, not on a warm one, not when turned
off, and never outlives the job.
"""

import json
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

try:
    import fcntl
except ImportError:  # (Windows)
    fcntl = None

from streamline_cam.background_compile import (
    CORNER_JOBS,
    ENV_SWITCH,
    KERNELS_FILE,
    decode_type,
    encode_type,
    helper_order,
    job_kernels,
    recorded_jobs,
    usable_cores,
)

ROOT = Path(__file__).resolve().parents[1]
#: On one core no helper starts (it would only take turns with the job).
ONE_CORE = pytest.mark.skipif(usable_cores() < 2, reason="one core: no helper")

KERNEL_MODULE = '''
from typing import NamedTuple

import numba


class Pair(NamedTuple):
    a: float
    b: float


@numba.njit(cache=True)
def weight_sum(weights):
    return weights.sum()


@numba.njit(cache=True)
def total(pair, weights):
    return pair.a + pair.b * weight_sum(weights)
'''

# Runs a job around ``background_compile`` (argv: "wait" lets the helper finish, "raise"
# leaves the job by an error at once, "hang": see the killed job's test); prints whether the
# helper started, its exit code after the job, whether its process is gone, and whether the
# job then loaded the kernel (cache hits) or compiled it.
JOB = '''
import json, os, sys, time
import numpy as np
import toolpath  # noqa: F401  (the kernel cache's hook, as every command)
from streamline_cam.background_compile import Kernel, background_compile

kernel = Kernel("kernel_mod", "total", (
    {"tuple": ["float64", "float64"], "class": "kernel_mod:Pair"},
    {"array": "float64", "ndim": 1, "layout": "C", "readonly": False}), "plan")
helper = None
if sys.argv[1] == "hang":  # (the lock file of the kernel's callee, then wait for the test
    import kernel_mod      # to hold it)
    print(kernel_mod.weight_sum._cache._cache_file._index_path + ".lock", flush=True)
    sys.stdin.readline()
try:
    with background_compile([kernel]) as helpers:
        helper = helpers[0] if helpers else None  # (one kernel: one helper at most)
        assert len(helpers) <= 1
        if helper is not None and sys.argv[1] == "wait":
            helper.wait(timeout=120)  # (the helper ends by itself once it has compiled)
        if sys.argv[1] == "raise":
            raise RuntimeError("the job failed")
        if sys.argv[1] == "hang":  # (until the test kills this process)
            print(json.dumps({"helper": helper and helper.pid}), flush=True)
            while True:
                time.sleep(1.0)
except RuntimeError:
    pass
gone = True
if helper is not None:
    try:
        os.kill(helper.pid, 0)
        gone = False
    except ProcessLookupError:
        pass
import kernel_mod
value = kernel_mod.total(kernel_mod.Pair(1.0, 2.0), np.ones(3))
print(json.dumps({"started": helper is not None,
                  "code": None if helper is None else helper.returncode, "gone": gone,
                  "value": value, "hits": sum(kernel_mod.total.stats.cache_hits.values())}))
'''


def _job(folder: Path, how: str, **environ: str) -> dict:
    env = {name: value for name, value in os.environ.items() if name != ENV_SWITCH}
    env |= {"PYTHONPATH": os.pathsep.join((str(folder), str(ROOT))),
            "NUMBA_CACHE_DIR": str(folder / "cache"), **environ}
    done = subprocess.run([sys.executable, "-c", JOB, how], cwd=folder, env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout.splitlines()[-1])


@ONE_CORE
def test_a_cold_cache_starts_the_helper_a_warm_one_does_not(tmp_path):
    (tmp_path / "kernel_mod.py").write_text(KERNEL_MODULE, encoding="utf-8")
    cold = _job(tmp_path, "wait")
    # started on the empty cache, compiled the kernel for the job's types (the job then
    # loaded it), ended by itself, and is gone
    assert cold == {"started": True, "code": 0, "gone": True, "value": 7.0, "hits": 1}
    warm = _job(tmp_path, "wait")
    assert warm["started"] is False and warm["hits"] == 1


@ONE_CORE
def test_a_failed_job_stops_the_helper_and_the_switch_turns_it_off(tmp_path):
    (tmp_path / "kernel_mod.py").write_text(KERNEL_MODULE, encoding="utf-8")
    off = _job(tmp_path, "raise", **{ENV_SWITCH: "0"})
    assert off["started"] is False and off["hits"] == 0  # the job compiled it itself
    source = tmp_path / "kernel_mod.py"
    source.write_text(KERNEL_MODULE + "\n# changed\n", encoding="utf-8")
    later = time.time() + 10  # newer than the index on file systems with coarse times too
    os.utime(source, (later, later))
    failed = _job(tmp_path, "raise")  # a source newer than its cache index: cold
    assert failed["started"] is True and failed["gone"] is True
    assert failed["code"] is not None and failed["value"] == 7.0


class Rays(NamedTuple):
    origins: np.ndarray
    counts: np.ndarray


def test_argument_types_survive_json():
    from numba import typeof

    values = [np.zeros((2, 3)), np.zeros(4, dtype=np.int64)[::2], np.zeros(3, dtype=bool),
              1.5, 3, True, Rays(np.zeros((2, 3)), np.zeros(2, dtype=np.int64)),
              Rays(np.zeros(3), np.zeros(3)), (1.0, 2.0)]
    readonly = np.zeros(3)
    readonly.flags.writeable = False
    for value in [*values, readonly]:
        kind = typeof(value)
        assert decode_type(json.loads(json.dumps(encode_type(kind)))) == kind, kind
    with pytest.raises(ValueError, match="not recorded"):
        encode_type(typeof("text"))


def test_helpers_start_inside_the_list_and_come_back_to_its_front():
    kernels = list("abcdefgh")
    # one helper: from half way to the end, then back; the job takes them from the front
    assert helper_order(kernels) == list("efghdcba")
    # three helpers start a quarter apart; each still gets every kernel (it skips taken ones)
    orders = [helper_order(kernels, i, 3) for i in range(3)]
    assert [order[0] for order in orders] == ["c", "e", "g"]
    assert all(sorted(order) == kernels for order in orders)
    assert helper_order([]) == []


def test_a_plan_is_given_its_later_kernels_and_a_5_axis_one_its_axis_kernels():
    plan5 = job_kernels("lead-tilt", ("plan",))
    plan3 = job_kernels("3", ("plan",))
    assert plan5 and plan3 and {k.stage for k in plan5} == {"plan"}
    names5, names3 = {k.name for k in plan5}, {k.name for k in plan3}
    assert "_limit_passes" in names5 and "_limit_passes" not in names3
    assert {k.stage for k in job_kernels("3", ("plan", "verify"))} == {"plan", "verify"}
    assert job_kernels("no such mode", ("plan",)) == []


def test_a_flat_or_bull_nose_job_is_given_the_corner_cutters_kernels_too():
    stages = ("fit", "plan", "post", "check", "verify")
    keys = lambda kernels: [(k.module, k.name, json.dumps(k.args)) for k in kernels]  # noqa: E731
    for mode in ("3", "lead-tilt"):
        ball = keys(job_kernels(mode, stages))
        assert keys(job_kernels(mode, stages, "ball:6")) == ball
        for cutter in ("bull:8:1", "FLAT:10", " flat : 6 "):
            corner = job_kernels(mode, stages, cutter)
            # the ball-nose job's kernels and the bull-nose job's others, each once,
            # stage by stage in the job's order
            assert len(set(keys(corner))) == len(corner)
            assert set(keys(corner)) == set(ball) | set(keys(job_kernels(CORNER_JOBS, stages)))
            assert len(corner) > len(ball)
            assert [stages.index(k.stage) for k in corner] == sorted(
                stages.index(k.stage) for k in corner)
            names = {k.name for k in corner}
            # the planner's torus contact and both near searches of swept cutters
            assert {"_window_nearest", "_nearest_entries"} <= names
    # asked in another order, listed in that order
    asked = [k.stage for k in job_kernels("3", ("verify", "plan"), "bull:8:1")]
    assert asked == sorted(asked, reverse=True) and set(asked) == {"plan", "verify"}


@pytest.mark.slow
def test_the_recorded_kernels_are_current():
    """Fails after a change to the kernels a job calls: rerun the command it names."""
    def calls(jobs: dict) -> dict[str, set]:
        # which kernels with which types; the order within a stage follows threads, and
        # the stage that first calls a kernel shared by two is a matter of timing
        return {mode: {(k["module"], k["name"], json.dumps(k["args"], sort_keys=True))
                       for k in kernels}
                for mode, kernels in jobs.items()}

    recorded = calls(json.loads(KERNELS_FILE.read_text(encoding="utf-8"))["jobs"])
    now = calls(recorded_jobs()["jobs"])
    assert now == recorded, (
        {mode: {"new": now[mode] - recorded.get(mode, set()),
                "gone": recorded.get(mode, set()) - now[mode]} for mode in now},
        f"python -m streamline_cam.background_compile --record {KERNELS_FILE}")


def _running(pid: int) -> bool:
    """Whether process ``pid`` runs (a zombie left to a parent that does not reap is not)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state not in ("Z", "X")


@ONE_CORE
@pytest.mark.skipif(fcntl is None or not Path("/proc/self/stat").exists(),
                    reason="flock and /proc")
def test_a_killed_job_s_helper_ends_by_itself(tmp_path):
    import signal
    import time

    (tmp_path / "kernel_mod.py").write_text(KERNEL_MODULE, encoding="utf-8")
    env = {name: value for name, value in os.environ.items() if name != ENV_SWITCH}
    env |= {"PYTHONPATH": os.pathsep.join((str(tmp_path), str(ROOT))),
            "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    job = subprocess.Popen([sys.executable, "-c", JOB, "hang"], cwd=tmp_path, env=env,
                           stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    lock = os.open(job.stdout.readline().strip(), os.O_RDWR | os.O_CREAT)
    try:
        # this test holds the compile lock of the kernel's callee: the helper, compiling the
        # kernel, waits for it, still running when the job dies
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            job.stdin.write("go\n")
            job.stdin.flush()
            helper = json.loads(job.stdout.readline())["helper"]
            assert helper is not None and _running(helper)
        finally:
            job.send_signal(signal.SIGKILL)  # (no clean-up in the job: its pipe just closes)
            job.wait(timeout=60)
        deadline = time.monotonic() + 60.0  # (a bound, not a timing assertion)
        while _running(helper) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not _running(helper)
    finally:
        os.close(lock)
