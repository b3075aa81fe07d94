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
limited to one thread runs the loop in its own thread, as a parallel kernel would.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numba

__all__ = ["MIN_ROWS_PER_THREAD", "SLICES_PER_THREAD", "row_slices", "run_in_threads"]

#: Fewer rows than this per thread run in the calling thread alone: below it, starting
#: threads costs more than it saves.
MIN_ROWS_PER_THREAD = 1024
#: Slices per thread: a few, so that a thread whose rows are quick takes another slice
#: while a slow one finishes (rows differ in cost, e.g. Newton iterations).
SLICES_PER_THREAD = 4


def row_slices(n_rows: int, threads: int) -> list[tuple[int, int]]:
    """``(lo, hi)`` ranges covering rows ``0 .. n_rows - 1`` in order, for ``threads``.

    One range when the rows are too few to share (:data:`MIN_ROWS_PER_THREAD`), else
    about :data:`SLICES_PER_THREAD` per thread, each at least that many rows.
    """
    if n_rows <= 0:
        return []
    if threads <= 1 or n_rows < 2 * MIN_ROWS_PER_THREAD:
        return [(0, n_rows)]
    count = min(threads * SLICES_PER_THREAD, n_rows // MIN_ROWS_PER_THREAD)
    bounds = [n_rows * k // count for k in range(count + 1)]
    return list(itertools.pairwise(bounds))


def run_in_threads(block: Callable[..., Any], n_rows: int, *args: Any) -> None:
    """Call ``block(*args, lo, hi)`` over rows ``0 .. n_rows - 1``, in numba's threads.

    ``block`` is a kernel compiled with ``nogil=True`` that writes its rows' results in
    place (its return value is dropped); the slices are :func:`row_slices`. An exception
    in a slice is raised here, after every slice has ended.
    """
    slices = row_slices(n_rows, numba.get_num_threads())
    if len(slices) == 1:
        block(*args, *slices[0])
        return
    with ThreadPoolExecutor(max_workers=numba.get_num_threads()) as pool:
        done = [pool.submit(block, *args, lo, hi) for lo, hi in slices]
    for future in done:
        future.result()
