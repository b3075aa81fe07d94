"""Compile the kernels a job uses, once per install: ``toolpath warm-up`` (``make install``).

The planner's kernels (numba, ``cache=True``) are compiled on first use and kept in the
kernel cache (:mod:`toolpath.kernel_cache`: next to the sources, or a user cache folder
when the package folder is read-only), so the first job after an install pays for them and
every later process loads them. The warm-up compiles them ahead of time, without running a
job: the kernels the recorded jobs call, for the argument types they pass
(:data:`~.background_compile.KERNELS_FILE`: every axis mode and cutter kind, every stage
from the fit to the verifier; the kernels they call compile with them). They are shared
among one process per usable core, handed out from both ends of the list (the first
stages' kernels and the last stages' call few kernels in common, so two processes seldom
need the same one at once); each process takes the next kernel nobody has taken. A kernel
the cache holds already is skipped (not loaded); one that another process compiles at that
moment (as a kernel it calls) is checked again once that process is done. A line per stage
as its kernels are done shows the progress.

Nothing depends on it: a kernel it did not reach compiles when a job first calls it, and a
kernel that fails to compile (a stale record would be a bug) is reported and skipped; so is
one whose compile kills its process (a crash in numba or LLVM): never compiled again here,
where it would end the warm-up (:func:`_in_processes` finds which kernel it was).
:func:`load_kernels` is the per-process counterpart for long-lived workers (a Dask worker,
before its first job): one small job that loads the cached kernels in a second or two.
"""

from __future__ import annotations

import json
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
    encode_type,
    recorded_kernels,
    usable_cores,
    work_ahead,
)

__all__ = ["MAX_WARM_PROCESSES", "PACKAGES", "both_ends", "compile_modules", "load_kernels",
           "warm_kernel", "warm_up"]

#: The packages whose modules the warm-up byte-compiles (:func:`compile_modules`).
PACKAGES: Final = ("toolpath", "verification", "gcode", "machines", "simulator", "streamline_cam")


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
        except (OSError, BrokenProcessPool) as exc:  # (no /dev/shm; one died, not compiling)
            say(f"warm-up: a worker process failed ({exc}); the rest compiles here")
    for index in list(pending):
        progress.done(index, *warm_kernel(kernels[index], True))
        pending.remove(index)
    say(progress.closing())
    return time.perf_counter() - start


def _in_processes(workers: int, kernels: Sequence[Kernel], pending: list[int],
                  progress: _Progress) -> None:
    """Compile the kernels ``pending`` in ``workers`` processes; each done one leaves it.

    A worker process that dies (a compile that crashed it, the pool then unusable) takes
    the kernel it was compiling along: that kernel is reported and skipped, the kernels not
    done yet go on in a new pool. Which kernel it was: each worker keeps, in a file of its
    own, the recorded kernels it is compiling at the moment (:func:`_start_worker`); the
    innermost of each worker's were being compiled when the pool broke. One such kernel is
    the culprit; of several (one per worker), each is compiled again alone in a pool of one
    process, and the one that kills that process is the culprit. Raises BrokenProcessPool
    when a worker died compiling none (the caller compiles the rest itself), OSError when
    no process could start.
    """
    alone: list[int] = []
    with tempfile.TemporaryDirectory(prefix="toolpath-warm-up-") as folder:
        while shared := [index for index in pending if index not in alone]:
            suspects = _pool_round(workers, kernels, shared, pending, progress, folder)
            if suspects is None:
                break
            if not suspects:
                raise BrokenProcessPool("a warm-up process ended while compiling nothing")
            if len(suspects) == 1:
                _died(suspects[0], pending, progress)
            else:
                alone += suspects
        for index in alone:
            if index in pending and _pool_round(1, kernels, [index], pending, progress,
                                                folder) is not None:
                _died(index, pending, progress)


def _died(index: int, pending: list[int], progress: _Progress) -> None:
    progress.done(index, "failed: the process compiling it died", 0.0)
    pending.remove(index)


def _pool_round(workers: int, kernels: Sequence[Kernel], indices: Sequence[int],
                pending: list[int], progress: _Progress, folder: str) -> list[int] | None:
    """The kernels ``indices`` in a pool of ``workers``: None, or those in compile if it broke.

    A kernel found busy (another worker compiles it as one its kernel calls) is handed out
    again, to wait for that compile and find it in the cache. Done kernels leave
    ``pending``. If a worker dies, returns the kernels the workers were compiling then.
    """
    spawn = multiprocessing.get_context("spawn")  # (no fork of a process running numba)
    marks = tempfile.mkdtemp(dir=folder)  # (this pool's workers' files)
    by_key = {_key(kernels[index]): index for index in indices}
    with ProcessPoolExecutor(max_workers=workers, mp_context=spawn, initializer=_start_worker,
                             initargs=(marks, list(by_key))) as pool:
        def submit(index: int, wait: bool) -> None:
            later = [kernels[i] for i in indices[indices.index(index) + 1:] if i in pending]
            running[pool.submit(warm_kernel, kernels[index], wait, later)] = index

        running: dict[Future, int] = {}
        for index in indices:
            submit(index, False)
        try:
            while running:
                done, _ = wait(running, return_when=FIRST_COMPLETED)
                for future in done:
                    index = running.pop(future)
                    try:
                        state, cpu_s = future.result()
                    except BrokenProcessPool:
                        return _compiling(marks, by_key, pending)
                    if state == "busy":
                        submit(index, True)
                        continue
                    progress.done(index, state, cpu_s)
                    pending.remove(index)
        except KeyboardInterrupt:
            pool.shutdown(wait=False, cancel_futures=True)
            raise
    return None


def _key(kernel: Kernel) -> str:
    """A recorded kernel as one string (name and argument types)."""
    return json.dumps([kernel.module, kernel.name, list(kernel.args)])


def _compiling(marks: str, by_key: dict[str, int], pending: Sequence[int]) -> list[int]:
    """The kernels each worker of ``marks`` was compiling last (its innermost), not done."""
    found = set()
    for mark in Path(marks).iterdir():
        try:
            keys = json.loads(mark.read_text(encoding="utf-8"))
        except (OSError, ValueError):  # (a worker's file, half written when it died)
            continue
        if keys and by_key.get(keys[-1]) in pending:
            found.add(by_key[keys[-1]])
    return sorted(found)


def _start_worker(marks: str, keys: Sequence[str]) -> None:
    """A warm-up process: one thread for compiled loops, and its compiles written down.

    The process's file in ``marks`` lists, innermost last, the kernels of ``keys``
    (:func:`_key`) it is compiling (numba's ``numba:compile`` events; a kernel loaded
    from the cache has none), rewritten whole (a new file renamed over the old) at each
    start and end of one.
    """
    _one_thread()
    import toolpath  # noqa: F401  (the kernel cache's folder and lock, before numba loads)

    wanted, path = set(keys), Path(marks) / str(os.getpid())
    from numba.core import event
    opened: list[str | None] = []  # each compile begun and not ended: its key, if wanted

    def write() -> None:
        path.with_suffix(".new").write_text(json.dumps([k for k in opened if k]),
                                            encoding="utf-8")
        os.replace(path.with_suffix(".new"), path)

    class Compiles(event.Listener):
        def on_start(self, ev: event.Event) -> None:
            func = ev.data["dispatcher"].py_func
            try:
                args = [encode_type(arg) for arg in ev.data["args"]]
            except ValueError:
                args = None
            key = json.dumps([func.__module__, func.__qualname__, args])
            opened.append(key if key in wanted else None)
            if opened[-1]:
                write()

        def on_end(self, ev: event.Event) -> None:
            if opened.pop():
                write()

    event.register("numba:compile", Compiles())


def _one_thread() -> None:
    """Compiled loops run on one thread in a warm-up process (the processes share the cores).

    (Read by numba when it loads, before the first kernel; compiled code does not depend
    on it.)
    """
    os.environ["NUMBA_NUM_THREADS"] = "1"


def compile_modules(packages: Sequence[str] = PACKAGES) -> list[str]:
    """Write the bytecode of the packages' modules (``__pycache__/*.pyc``) where it is missing.

    Python compiles a module's source at every import that finds no bytecode beside it,
    and writes the bytecode then unless told not to (``PYTHONDONTWRITEBYTECODE``, ``-B``:
    e.g. a container image sets it): there a source install (``pip install -e``) compiled
    the ~140 modules a job imports in every command, 0.24 s of the 1.2 s of CPU a warm
    ``toolpath run`` spends before its first stage (``pip install`` of a wheel writes the
    bytecode at install, as it does for numpy and scipy). Bytecode is checked against its
    source at each import (its size and time stamp), so an edited module compiles afresh.
    A folder that cannot be written (a read-only install: its installer wrote them) is
    skipped. Returns the packages whose bytecode could not all be written.
    """
    import compileall
    import importlib.util

    missed = []
    for name in packages:
        spec = importlib.util.find_spec(name)
        folders = list(spec.submodule_search_locations or []) if spec else []
        if not all(compileall.compile_dir(folder, quiet=2) for folder in folders):
            missed.append(name)
    return missed


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
