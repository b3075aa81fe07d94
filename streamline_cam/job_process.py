"""How a job's process runs: freed arrays reused in the process, idle kernel threads asleep.

Two process-wide settings that change no result, only what the kernel and idle threads
cost. Measured on the issue-27 5-axis job (``toolpath run dev_blade_15x142.csv --machine
trunnion-ac --axis lead-tilt --verify``, 175,000 points) on a 2-core VM:

**Memory.** A job makes and drops hundreds of large temporaries (columns of 1-15 MB in
every stage). By default glibc returns each to the kernel when it is freed (blocks over
its mmap threshold are unmapped, and the top of the heap is trimmed), and numpy asks for
2 MB huge pages for every array over 4 MB. The next temporary then faults in fresh pages,
which the kernel zeroes first; on a virtual machine that hands freed memory back to its
host, a zeroed huge page costs milliseconds. 2-7 s of the run was kernel time, ~99 % of
it zeroing huge pages (``perf``: ``clear_page_erms`` under ``do_huge_pmd_anonymous_page``;
``strace -c``: next to no system calls); 0.3-0.6 s with the settings below. So:

* glibc's mmap threshold at its largest value (:data:`MMAP_THRESHOLD_BYTES`) and its trim
  threshold at :data:`TRIM_THRESHOLD_BYTES`: blocks under 32 MiB come from the heap and
  freed ones are reused there without new page faults; a larger block is still returned
  on free, and so is a free heap top over the trim threshold, so the process holds at most
  its peak plus that;
* numpy's huge-page advice off (``NUMPY_MADVISE_HUGEPAGE=0``, set at runtime): the arrays
  are reused instead, so they fault once, in small pages.

**Idle threads.** The verifier's compiled kernels run their loops on numba's OpenMP
threads (the plan's kernels run row slices in Python threads, :mod:`toolpath.row_threads`); between
two parallel loops GNU OpenMP's idle threads spin (``GOMP_SPINCOUNT``) instead of
sleeping, and a job runs thousands of short loops with numpy work between them. With
``OMP_WAIT_POLICY=PASSIVE`` (unless the environment sets it) they sleep: the plan stage's
CPU time went from 3.6-4.2 s to 2.9 s at a load of 8 (two spinning threads on two cores
take the CPU other work needs). It is read when the OpenMP runtime loads, so it is set
before the first parallel kernel runs.

**Exit.** When the interpreter exits it runs the cyclic garbage collector over every object
left (several full collections while it tears the modules down): with numba's and scipy's
type registries loaded, 150,000 objects and ~0.4 s of CPU time for memory the system takes
back anyway. :func:`freeze_at_exit` registers an exit handler that freezes them first
(:func:`gc.freeze`: the collector leaves frozen objects alone). Objects are still freed by
their reference counts and the standard streams flushed, but an object kept alive only by a
reference cycle is then never finalised (a file it holds is not flushed, a temporary file
not removed). So only the command line's one-shot commands, whose job closes what it opens,
ask for it (``toolpath run``, ``plan``, ``post``, ``check``, ``verify``, ``fit``...); a
service, batch, sender or simulator process, and any library caller, exit as Python does.
Such a process also skips the trim after its job (:func:`as_job`): its exit hands the
memory back.

On a C library without ``mallopt`` (musl, macOS, Windows) the malloc settings are skipped.
"""

from __future__ import annotations

import atexit
import ctypes
import functools
import gc
import os
import sys
from collections.abc import Callable
from typing import Any, Final, TypeVar

__all__ = ["MMAP_THRESHOLD_BYTES", "TRIM_THRESHOLD_BYTES", "as_job", "freeze_at_exit",
           "prepare_job_process", "release_freed_memory"]

F = TypeVar("F", bound=Callable[..., Any])

#: glibc's largest mmap threshold on 64-bit (``DEFAULT_MMAP_THRESHOLD_MAX``): bigger blocks
#: are always mapped on their own.
MMAP_THRESHOLD_BYTES: Final[int] = 32 * 1024 * 1024
#: Free memory at the top of the heap kept for reuse before glibc returns it.
TRIM_THRESHOLD_BYTES: Final[int] = 1024 * 1024 * 1024

# mallopt parameters (malloc.h)
_M_TRIM_THRESHOLD: Final[int] = -1
_M_MMAP_THRESHOLD: Final[int] = -3

_done = False
_freezes_at_exit = False


def _libc_function(name: str) -> Any:
    """The running C library's function ``name``, or None (not glibc-like, or missing)."""
    if not sys.platform.startswith("linux"):  # (Windows: no CDLL(None); macOS: no mallopt)
        return None
    try:
        return getattr(ctypes.CDLL(None), name)  # the C library the interpreter runs on
    except (OSError, AttributeError, TypeError):
        return None


def _mallopt(param: int, value: int) -> bool:
    """The C library's ``mallopt(param, value)``; False where it has none or refuses."""
    mallopt = _libc_function("mallopt")
    if mallopt is None:
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    return bool(mallopt(param, value))


def as_job(run: F) -> F:
    """``run`` as a job: :func:`prepare_job_process` first, :func:`release_freed_memory` after.

    After, however ``run`` ends (an error too); not in a one-shot process
    (:func:`freeze_at_exit`), which hands all its memory back as it exits: there the trim
    only costs time (60 ms of CPU after the issue-27 5-axis job).
    """
    @functools.wraps(run)
    def job(*args: Any, **kwargs: Any) -> Any:
        prepare_job_process()
        try:
            return run(*args, **kwargs)
        finally:
            if not _freezes_at_exit:
                release_freed_memory()

    return job  # type: ignore[return-value]


def release_freed_memory() -> bool:
    """Hand the memory a finished job freed back to the system (glibc ``malloc_trim(0)``).

    The trim threshold above keeps up to :data:`TRIM_THRESHOLD_BYTES` free per malloc arena
    while a job runs; a long-lived process (the HTTP service's thread pool, a batch worker)
    calls this after each job so that what it holds between jobs does not grow with the
    number of threads. False where the C library has no such call.
    """
    trim = _libc_function("malloc_trim")
    if trim is None:
        return False
    trim.argtypes = (ctypes.c_size_t,)
    trim.restype = ctypes.c_int
    trim(0)
    return True


def freeze_at_exit() -> None:
    """Freeze every object when the interpreter exits (once per process).

    For one-shot command-line processes only (module's text).
    """
    global _freezes_at_exit
    if not _freezes_at_exit:
        atexit.register(gc.freeze)
        _freezes_at_exit = True


def prepare_job_process() -> bool:
    """Set this process up for jobs (see the module's text); idempotent and cheap.

    Returns whether the C library took the malloc settings.
    """
    global _done
    if _done:
        return True
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    from verification.pages import madvise_switch  # numpy's switch, 1.26 and 2.x

    set_hugepage = madvise_switch()
    if set_hugepage is not None:
        set_hugepage(False)
    _done = (_mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)
             and _mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES))
    return _done
