"""Compiled loops over rows run in threads, without numba's parallel loops (issue 27).

A numba kernel marked ``parallel=True`` turns its ``prange`` loop into a parallel region
("parfor"); compiling one costs 1.5 to 3 CPU seconds more than the same loop plain, even
for a loop whose body is a single call, which the first job after an install pays for each
such kernel. Here the loop's body is a plain kernel compiled with ``nogil=True``
(``block(*args, lo, hi)`` does rows ``lo .. hi - 1``) and :func:`run_in_threads` calls it on
slices of the rows from a few Python threads: the threads run at once (the kernel releases
the interpreter's lock), for the compile cost of the plain kernel alone.

Each row must be independent of the others, as in a ``prange`` loop: the result is the
same whatever the split. The threads are as many as numba's (``numba.get_num_threads()``:
``NUMBA_NUM_THREADS``, or ``numba.set_num_threads`` in the calling thread), so a worker
limited to one thread runs the loop in its own thread, as a parallel kernel would. Thread
``k`` of ``w`` takes slices ``k, k + w, k + 2 w, ...`` (the calling thread is thread 0, the
others come from one pool of threads kept for the process): interleaved, so that a run of
costly rows is shared out, and fixed, so that the same call splits the same way each time.
With ``dynamic``, the rows come in many slices of ``min_rows`` and each thread takes the
next slice nobody has taken as it frees, as a ``prange`` loop under
``numba.parallel_chunksize`` does: a thread slowed by other work takes fewer.
"""

from __future__ import annotations

import itertools
import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numba

__all__ = ["MIN_ROWS_PER_THREAD", "SLICES_PER_THREAD", "query_workers", "row_slices",
           "run_in_threads"]

#: Fewer rows than this per thread run in the calling thread alone: below it, starting
#: threads costs more than it saves.
MIN_ROWS_PER_THREAD = 1024
#: Slices per thread: a few, so that rows of different cost (e.g. Newton iterations) are
#: shared out among the threads.
SLICES_PER_THREAD = 4


def row_slices(n_rows: int, threads: int, *, min_rows: int = MIN_ROWS_PER_THREAD,
               dynamic: bool = False) -> list[tuple[int, int]]:
    """``(lo, hi)`` ranges covering rows ``0 .. n_rows - 1`` in order, for ``threads``.

    One range when the rows are too few to share (fewer than twice ``min_rows``,
    default :data:`MIN_ROWS_PER_THREAD`), else about :data:`SLICES_PER_THREAD` per thread
    (``dynamic``: ``min_rows`` each from row 0, the last with the rest), each at least
    ``min_rows`` rows.
    """
    if n_rows <= 0:
        return []
    if threads <= 1 or n_rows < 2 * min_rows:
        return [(0, n_rows)]
    count = n_rows // min_rows
    if dynamic:  # slices of min_rows from row 0 (the last takes the rest)
        return list(itertools.pairwise([k * min_rows for k in range(count)] + [n_rows]))
    count = min(threads * SLICES_PER_THREAD, count)
    bounds = [n_rows * k // count for k in range(count + 1)]
    return list(itertools.pairwise(bounds))


def query_workers(n_rows: int) -> int:
    """Workers for a k-d tree query of ``n_rows`` points (scipy's ``cKDTree.query``).

    scipy starts its worker threads afresh on every query: about 0.2 to 0.35 ms for two,
    more than a query of a few hundred points takes in one (the cusp search's queries of
    3 to 700 contacts on the sweep's small plans). Fewer rows than
    :data:`MIN_ROWS_PER_THREAD` are queried in the calling thread alone, more in numba's
    threads (``numba.get_num_threads()``, as :func:`run_in_threads`). The neighbours found
    are the same either way.
    """
    return 1 if n_rows < MIN_ROWS_PER_THREAD else numba.get_num_threads()


def run_in_threads(block: Callable[..., Any], n_rows: int, *args: Any,
                   threads: int | None = None, min_rows: int = MIN_ROWS_PER_THREAD,
                   dynamic: bool = False) -> None:
    """Call ``block(*args, lo, hi)`` over rows ``0 .. n_rows - 1``, in numba's threads.

    ``block`` is a kernel compiled with ``nogil=True`` that writes its rows' results in
    place (its return value is dropped); the slices are :func:`row_slices` for ``threads``
    threads (default ``numba.get_num_threads()``), ``min_rows`` and ``dynamic`` (the
    slices taken as the threads free, module docstring). An exception in a slice is
    raised here once every thread has ended (a thread stops at its first error). Raises
    TypeError for a ``block`` that is not a ``nogil`` kernel: it would hold the
    interpreter's lock, and the threads would take turns.
    """
    _check_nogil(block)
    threads = numba.get_num_threads() if threads is None else threads
    slices = row_slices(n_rows, threads, min_rows=min_rows, dynamic=dynamic)
    if len(slices) <= 1:
        for lo, hi in slices:
            block(*args, lo, hi)
        return
    workers = min(threads, len(slices))
    untaken, taking = iter(slices), threading.Lock()

    def run_share(first: int) -> None:
        if not dynamic:
            for lo, hi in slices[first::workers]:
                block(*args, lo, hi)
            return
        while True:  # the next slice nobody has taken
            with taking:
                rows = next(untaken, None)
            if rows is None:
                return
            block(*args, *rows)

    others = [_pool().submit(run_share, k) for k in range(1, workers)]
    try:
        run_share(0)
    finally:
        for future in others:
            future.exception()  # (waits for it: none goes on past this call)
    for future in others:
        future.result()


def _check_nogil(block: Callable[..., Any]) -> None:
    if numba.config.DISABLE_JIT:  # (numba's debug mode: njit returns the Python function)
        return
    options = getattr(block, "targetoptions", None)
    if not isinstance(options, dict) or not options.get("nogil", False):
        name = getattr(block, "__qualname__", None) or getattr(
            getattr(block, "py_func", None), "__qualname__", repr(block))
        raise TypeError(f"run_in_threads needs a kernel compiled with numba.njit(nogil=True); "
                        f"{name!r} is not one (it would hold the interpreter's lock in every "
                        "thread)")


_POOL: ThreadPoolExecutor | None = None
_POOL_LOCK = threading.Lock()


def _pool() -> ThreadPoolExecutor:
    """The process's pool of row threads, made at the first call that needs one.

    As many threads as numba may use (``NUMBA_NUM_THREADS``), less the calling thread's.
    """
    global _POOL
    with _POOL_LOCK:
        if _POOL is None:
            _POOL = ThreadPoolExecutor(max_workers=max(1, numba.config.NUMBA_NUM_THREADS - 1),
                                       thread_name_prefix="row-thread")
        return _POOL


def _forget_pool() -> None:
    """In a forked child: the parent's pool threads are not there (a new pool when needed)."""
    global _POOL, _POOL_LOCK
    _POOL, _POOL_LOCK = None, threading.Lock()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_forget_pool)
