"""The job's side thread and numba's threading layers (:func:`streamline_cam.pipeline.in_thread`).

A job takes its verification's design samples in a side thread while it posts and checks
the program; both run compiled ``parallel=True`` kernels. Under numba's ``workqueue``
layer (where neither TBB nor the system's libgomp loads) two threads launching at once
abort the process, so there the side task runs in the caller's thread.
"""

import os
import subprocess
import sys
import textwrap
import threading

import pytest

from streamline_cam.pipeline import in_thread, kernels_threadsafe

_BOTH_THREADS = textwrap.dedent("""
    import numba, numpy as np
    from streamline_cam.pipeline import in_thread, kernels_threadsafe

    @numba.njit(parallel=True)
    def total(a):
        s = 0.0
        for i in numba.prange(a.size):
            s += np.sin(a[i])
        return s

    a = np.ones(2_000_000)
    total(a)

    def launches():
        for _ in range(40):
            total(a)
        return numba.threading_layer()

    pending = in_thread(launches, "side")
    launches()
    print(kernels_threadsafe(), pending())
""")


def _run(layer):
    env = dict(os.environ, NUMBA_THREADING_LAYER=layer)
    return subprocess.run([sys.executable, "-c", _BOTH_THREADS], env=env, capture_output=True,
                          text=True, timeout=180)


def test_under_the_workqueue_layer_the_side_task_runs_in_the_callers_thread():
    # without the fallback the two threads' launches abort the process ("Concurrent access
    # has been detected", exit -6)
    done = _run("workqueue")
    assert done.returncode == 0, done.stderr[-600:]
    assert done.stdout.split() == ["False", "workqueue"]


@pytest.mark.skipif(not kernels_threadsafe(), reason="no threadsafe numba layer here")
def test_a_threadsafe_layer_keeps_the_side_thread():
    names = []
    pending = in_thread(lambda: names.append(threading.current_thread().name) or 7, "side")
    assert pending() == 7 and names == ["side"]
    done = _run("default")
    assert done.returncode == 0, done.stderr[-600:]
    assert done.stdout.split()[0] == "True"


def test_a_task_run_in_place_hands_over_its_error(monkeypatch):
    import streamline_cam.pipeline as pipeline

    monkeypatch.setattr(pipeline, "kernels_threadsafe", lambda: False)
    names = []

    def fails():
        names.append(threading.current_thread().name)
        raise ValueError("bad samples")

    pending = in_thread(fails, "side")
    assert names == [threading.current_thread().name]  # ran before in_thread returned
    with pytest.raises(ValueError, match="bad samples"):
        pending()
    assert pending.seconds is not None


def test_serve_refuses_thread_workers_under_the_workqueue_layer(tmp_path):
    # two jobs' kernels in threads at once would abort the whole service mid-job
    env = dict(os.environ, NUMBA_THREADING_LAYER="workqueue")
    done = subprocess.run([sys.executable, "-m", "streamline_cam.cli", "serve", "--executor",
                           "thread", "--workers", "2", "--port", "0", "--data-dir",
                           str(tmp_path / "service")], env=env, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 2
    assert "--executor process" in done.stderr and "--workers 1" in done.stderr
