"""Compile the kernels a job uses, once per install: ``toolpath warm-up`` (``make install``).

The planner's kernels (numba, ``cache=True``) are compiled on first use and kept in the
kernel cache (:mod:`toolpath.kernel_cache`: next to the sources, or a user cache folder
when the package folder is read-only), so the first job after an install pays for them
and every later process loads them. The warm-up runs that first job ahead of time: two
small jobs on bundled blades at coarse settings (3-axis on ``grbl-router``: the development
blade, open sections, verified; 5-axis on ``trunnion-ac``: the propeller blade, closed
sections, a spiral), which compile every kernel a job reaches for the argument types jobs
pass. The two jobs run at once, one process each (on a machine of one core, one after the
other): the kernel cache lets one process compile each kernel while the other waits and
loads it, so the jobs share the compiling. :func:`load_kernels` is the per-process
counterpart for long-lived workers (a Dask worker, before its first job): one small job
that loads the cached kernels in a second or two. Nothing depends on either: a kernel it did
not reach compiles when a job first calls it, and a warm-up job that stops (bad data would
be a bug) is reported and skipped.
"""

from __future__ import annotations

import multiprocessing
import os
import tempfile
import time
import warnings
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Final

from gcode.errors import GCodeError
from machines.errors import MachineError
from toolpath.errors import ToolpathError
from toolpath.paper_examples import bundled_data_path

__all__ = ["COARSE", "WARM_JOBS", "load_kernels", "warm_up"]

#: The warm-up's jobs: (label, bundled blade, machine, axis mode, verify). Coarse settings
#: (COARSE): the kernels matter here, not the figures. One verification reaches the
#: verifier's code; a second (5-axis) compiles nothing more and ran 9-12 s. Run at once, the
#: 3-axis job compiles most of the shared planner kernels (it reaches them sooner) while
#: the 5-axis one compiles its tool-axis kernels.
WARM_JOBS = (("3-axis", "dev_blade_15x142.csv", "grbl-router", "3", True),
             ("5-axis", "dev_prop_7x100.csv", "trunnion-ac", "lead-tilt", False))
COARSE = {"scallop_mm": 0.05, "chord_tol_mm": 0.02}


def warm_up(say: Callable[[str], None] | None = None, processes: int | None = None) -> float:
    """Run the warm-up jobs in a temporary folder; returns the seconds taken.

    ``say`` gets one line as each job starts and ends (progress), e.g. ``print``. The jobs
    run at once in up to ``processes`` processes (default: one per core, at most one per
    job): compiling is single-threaded, and the kernel cache has each kernel compiled by
    one process while the others wait for it and load it
    (:func:`toolpath.kernel_cache.hook_numba`), so the jobs share the compiling.
    """
    say = say or (lambda _text: None)
    start = time.perf_counter()
    workers = max(1, min(len(WARM_JOBS), processes or os.cpu_count() or 1))
    with tempfile.TemporaryDirectory(prefix="toolpath-warm-up-") as folder:
        for i, (label, name, machine, _axis_mode, verify) in enumerate(WARM_JOBS, 1):
            say(f"warm-up {i}/{len(WARM_JOBS)}: {label} job on {machine} ({name}: fit, plan, "
                f"post, check{', verify' if verify else ''}) ...")
        pending = set(range(len(WARM_JOBS)))
        if workers > 1:
            try:
                _in_processes(workers, folder, say, pending)
            except (OSError, BrokenProcessPool) as exc:  # (no /dev/shm, a worker killed)
                say(f"warm-up: a worker process failed ({exc}); the rest runs here")
        for i in sorted(pending):
            say(_warm_job(i, folder))
    return time.perf_counter() - start


def _in_processes(workers: int, folder: str, say: Callable[[str], None],
                  pending: set[int]) -> None:
    """Run the jobs ``pending`` at once in ``workers`` processes; each done one leaves it."""
    spawn = multiprocessing.get_context("spawn")  # (no fork of a process running numba)
    with ProcessPoolExecutor(max_workers=workers, mp_context=spawn,
                             initializer=_one_thread) as pool:
        futures = {pool.submit(_warm_job, i, folder): i for i in sorted(pending)}
        try:
            for done in as_completed(futures):
                say(done.result())
                pending.discard(futures[done])
        except KeyboardInterrupt:
            pool.shutdown(wait=False, cancel_futures=True)
            raise


def _one_thread() -> None:
    """Compiled loops run on one thread in a warm-up process (the processes share the cores).

    (Read by numba when it loads, before the job; the compiled code does not depend on it.)
    """
    os.environ["NUMBA_NUM_THREADS"] = "1"


def _warm_job(index: int, folder: str) -> str:
    """Run warm-up job ``index`` (of :data:`WARM_JOBS`) under ``folder``; its progress line."""
    from .pipeline import JobRequest, run_job

    label, name, machine, axis_mode, verify = WARM_JOBS[index]
    head = f"warm-up {index + 1}/{len(WARM_JOBS)}: {label}"
    job_start, job_cpu = time.perf_counter(), time.process_time()
    request = JobRequest(bundled_data_path(name), machine=machine, axis_mode=axis_mode,
                         **COARSE)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # figures of coarse settings do not matter here
        try:
            result = run_job(request, Path(folder) / label, verify=verify)
        except (ToolpathError, GCodeError, MachineError) as exc:
            return f"{head} stopped ({exc}); what it did not reach compiles on first use"
    stages = ", ".join(f"{stage} {seconds:.1f}"
                       for stage, seconds in result.report["seconds"].items())
    return (f"{head} done in {time.perf_counter() - job_start:.1f} s, cpu "
            f"{time.process_time() - job_cpu:.1f} s ({stages} s)")


#: The job of :func:`load_kernels`: a coarse plan on a small blade-like strip, enough to
#: load (or, the first time on a machine, compile) the compiled kernels a job calls.
_STRIP_OPTIONS: Final = {"scallop_mm": 0.5, "chord_tol_mm": 0.05}


def _strip_sections() -> str:
    """Five sections of 40 points of a twisted, cambered strip, as ``section,x,y,z`` CSV."""
    import numpy as np

    u = np.linspace(0.0, 1.0, 40)
    lines = ["section,x,y,z"]
    for j in range(5):
        twist = np.radians(4.0 * j)
        x, y = 40.0 * u - 20.0, 3.0 * np.sin(np.pi * u) * (1.0 - 0.05 * j) + 0.5 * j
        xr, yr = np.cos(twist) * x - np.sin(twist) * y, np.sin(twist) * x + np.cos(twist) * y
        lines += [f"{j},{a:.6f},{b:.6f},{10.0 * j:.6f}" for a, b in zip(xr, yr, strict=True)]
    return "\n".join(lines) + "\n"


def load_kernels() -> float:
    """Load the compiled kernels into this process once; returns the seconds it took.

    Runs one coarse job on a small strip in a scratch folder: numba loads each kernel
    from its on-disk cache (or compiles it) at its first call, so the first real job in a
    fresh process would otherwise pay for it (about 2 s with the cache, minutes without).
    """
    from .pipeline import JobRequest, run_job

    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="toolpath-warm-") as folder:
        sections = Path(folder) / "warm-up.csv"
        sections.write_text(_strip_sections(), encoding="utf-8")
        run_job(JobRequest(sections, **_STRIP_OPTIONS), Path(folder) / "out")
    return time.perf_counter() - start
