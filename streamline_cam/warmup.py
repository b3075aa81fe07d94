"""Compile the kernels a job uses, once per install: ``toolpath warm-up`` (``make install``).

The planner's kernels (numba, ``cache=True``) are compiled on first use and kept in the
kernel cache (:mod:`toolpath.kernel_cache`: next to the sources, or a user cache folder
when the package folder is read-only), so the first job after an install pays for them
and every later process loads them. The warm-up compiles them ahead of time, without
running a job: the kernels the recorded jobs call, for the argument types they pass
(:data:`~.background_compile.KERNELS_FILE`: every axis mode, every stage from the fit to
the verifier; the kernels they call compile with them). They are shared among one process
per usable core, handed out from both ends of the list (the first stages' kernels and the
last stages' call few kernels in common, so two processes seldom need the same one at
once); each process takes the next kernel nobody has taken. A kernel the cache holds
already is skipped (not loaded); one that another process compiles at that moment (as a
kernel it calls) is checked again once that process is done. A line per stage as its
kernels are done shows the progress.

Nothing depends on it: a kernel it did not reach compiles when a job first calls it, and a
kernel that fails to compile (a stale record would be a bug) is reported and skipped.
:func:`load_kernels` is the per-process counterpart for long-lived workers (a Dask worker,
before its first job): one small job that loads the cached kernels in a second or two.
"""

from __future__ import annotations

import multiprocessing
import os
import tempfile
import time
from collections import Counter
from collections.abc import Callable, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Final

from .background_compile import (
    Kernel,
    compile_kernel,
    recorded_kernels,
    usable_cores,
    work_ahead,
)

__all__ = ["MAX_WARM_PROCESSES", "both_ends", "load_kernels", "warm_kernel", "warm_up"]


def both_ends(count: int) -> list[int]:
    """The indices ``0 .. count - 1`` from both ends in turn: 0, count - 1, 1, count - 2, ..."""
    order = []
    low, high = 0, count - 1
    while low <= high:
        order.append(low)
        if high != low:
            order.append(high)
        low, high = low + 1, high - 1
    return order


def warm_kernel(kernel: Kernel, wait: bool, meanwhile: Sequence[Kernel] = ()
                ) -> tuple[str, float]:
    """Compile ``kernel`` into the cache (:func:`~.background_compile.compile_kernel`).

    Returns what was done (``"compiled"``, ``"cached"``, with ``wait=False`` ``"busy"``, or
    ``"failed: ..."`` with the error) and the CPU seconds it took. While the compile waits
    for another process's compile of a kernel it calls, the first free kernels of
    ``meanwhile`` compile here (:func:`~.background_compile.work_ahead`; handed out later,
    they are found in the cache).
    """
    from toolpath.kernel_cache import working_while_waiting

    cpu = time.process_time()
    try:
        with working_while_waiting(work_ahead(meanwhile)):
            state = compile_kernel(kernel, wait=wait)
    except Exception as exc:  # (any error of numba's: reported, and the kernel skipped)
        reason = (str(exc).strip().splitlines() or [""])[0][:200]
        state = f"failed: {type(exc).__name__}: {reason}"
    return state, time.process_time() - cpu


class _Progress:
    """Counts the kernels done per stage; a line when a stage's last one is done."""

    def __init__(self, kernels: Sequence[Kernel], say: Callable[[str], None]) -> None:
        self.kernels, self.say = kernels, say
        self.left = Counter(kernel.stage for kernel in kernels)
        self.states: Counter[str] = Counter()
        self.cpu_s = 0.0
        self.start = time.perf_counter()

    def opening(self, processes: int) -> str:
        stages = ", ".join(f"{stage} {count}" for stage, count in self.left.items())
        return (f"warm-up: compiling the {len(self.kernels)} kernels jobs call ({stages}) "
                f"in {processes} process{'es' if processes > 1 else ''} ...")

    def closing(self) -> str:
        counts = ", ".join(f"{count} {state}" for state, count in sorted(self.states.items()))
        return f"warm-up: {counts} (cpu {self.cpu_s:.1f} s in the compiling processes)"

    def done(self, index: int, state: str, cpu_s: float) -> None:
        kernel = self.kernels[index]
        self.cpu_s += cpu_s
        self.states[state if not state.startswith("failed") else "failed"] += 1
        if state.startswith("failed"):
            self.say(f"warm-up: {kernel.module}.{kernel.name} did not compile ({state[8:]}); "
                     "skipped: a job compiles it when it calls it")
        self.left[kernel.stage] -= 1
        if self.left[kernel.stage] == 0:
            self.say(f"warm-up: {kernel.stage} kernels done "
                     f"({time.perf_counter() - self.start:.1f} s)")


#: At most this many warm-up processes by default (one per usable core below that): the
#: recorded kernels keep about four busy, and each loads numba and the kernels' modules.
MAX_WARM_PROCESSES = 4


def warm_up(say: Callable[[str], None] | None = None, processes: int | None = None,
            kernels: Sequence[Kernel] | None = None) -> float:
    """Compile ``kernels`` (default: the recorded jobs') into the cache; returns the seconds.

    ``say`` gets the progress (a line at the start, one per stage as its kernels are done,
    one per kernel that failed), e.g. ``print``. Up to ``processes`` processes (default:
    one per usable core, :func:`~.background_compile.usable_cores`, at most
    :data:`MAX_WARM_PROCESSES`) share the kernels, taken from both ends of the list; one
    process compiles them here, in order.
    """
    say = say or (lambda _text: None)
    start = time.perf_counter()
    kernels = list(recorded_kernels() if kernels is None else kernels)
    workers = max(1, min(len(kernels), processes or min(usable_cores(), MAX_WARM_PROCESSES)))
    progress = _Progress(kernels, say)
    say(progress.opening(workers))
    pending = both_ends(len(kernels))
    if workers > 1:
        try:
            _in_processes(workers, kernels, pending, progress)
        except (OSError, BrokenProcessPool) as exc:  # (no /dev/shm, a worker killed)
            say(f"warm-up: a worker process failed ({exc}); the rest compiles here")
    for index in list(pending):
        progress.done(index, *warm_kernel(kernels[index], True))
        pending.remove(index)
    say(progress.closing())
    return time.perf_counter() - start


def _in_processes(workers: int, kernels: Sequence[Kernel], pending: list[int],
                  progress: _Progress) -> None:
    """Compile the kernels ``pending`` in ``workers`` processes; each done one leaves it.

    A kernel found busy (another worker compiles it as one its kernel calls) is handed out
    again, to wait for that compile and find it in the cache.
    """
    spawn = multiprocessing.get_context("spawn")  # (no fork of a process running numba)
    with ProcessPoolExecutor(max_workers=workers, mp_context=spawn,
                             initializer=_one_thread) as pool:
        def submit(index: int, wait: bool) -> None:
            later = [kernels[i] for i in pending[pending.index(index) + 1:]]
            running[pool.submit(warm_kernel, kernels[index], wait, later)] = index

        running: dict[Future, int] = {}
        for index in pending:
            submit(index, False)
        try:
            while running:
                done, _ = wait(running, return_when=FIRST_COMPLETED)
                for future in done:
                    index = running.pop(future)
                    state, cpu_s = future.result()
                    if state == "busy":
                        submit(index, True)
                        continue
                    progress.done(index, state, cpu_s)
                    pending.remove(index)
        except KeyboardInterrupt:
            pool.shutdown(wait=False, cancel_futures=True)
            raise


def _one_thread() -> None:
    """Compiled loops run on one thread in a warm-up process (the processes share the cores).

    (Read by numba when it loads, before the first kernel; compiled code does not depend
    on it.)
    """
    os.environ["NUMBA_NUM_THREADS"] = "1"


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
