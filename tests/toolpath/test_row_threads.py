"""Row slices run in threads: every row once, the same result as one call over all rows."""

import os
import subprocess
import sys
import threading
import time

import numba
import numpy as np
import pytest

from toolpath.row_threads import MIN_ROWS_PER_THREAD, query_workers, row_slices, run_in_threads


@pytest.mark.parametrize("n_rows", [0, 1, MIN_ROWS_PER_THREAD, 2 * MIN_ROWS_PER_THREAD - 1,
                                    2 * MIN_ROWS_PER_THREAD, 10 * MIN_ROWS_PER_THREAD + 7])
@pytest.mark.parametrize("threads", [1, 2, 3, 8])
def test_slices_cover_every_row_once_in_order(n_rows, threads):
    slices = row_slices(n_rows, threads)
    rows = [i for lo, hi in slices for i in range(lo, hi)]
    assert rows == list(range(n_rows))
    assert all(lo < hi for lo, hi in slices)
    if threads > 1 and n_rows >= 2 * MIN_ROWS_PER_THREAD:
        assert len(slices) > 1
        assert min(hi - lo for lo, hi in slices) >= MIN_ROWS_PER_THREAD


def test_few_rows_or_one_thread_are_one_slice():
    assert row_slices(2 * MIN_ROWS_PER_THREAD - 1, 8) == [(0, 2 * MIN_ROWS_PER_THREAD - 1)]
    assert row_slices(10 * MIN_ROWS_PER_THREAD, 1) == [(0, 10 * MIN_ROWS_PER_THREAD)]


@numba.njit(nogil=True)
def _square_rows(x, out, lo, hi):
    for i in range(lo, hi):
        out[i] = x[i] * x[i] + i


@numba.njit(nogil=True)
def _mark_rows(visits, slice_lo, thread, lo, hi):
    """Each row: how often a slice wrote it, which slice and which thread (its ident)."""
    with numba.objmode(ident="uint64"):
        ident = threading.get_ident()
    for i in range(lo, hi):
        visits[i] += 1
        slice_lo[i] = lo
        thread[i] = ident


def test_threads_give_the_one_call_result():
    x = np.random.default_rng(7).normal(size=20 * MIN_ROWS_PER_THREAD + 3)
    whole, sliced = np.full_like(x, np.nan), np.full_like(x, np.nan)
    _square_rows(x, whole, 0, x.size)
    run_in_threads(_square_rows, x.size, x, sliced, threads=3)
    np.testing.assert_array_equal(sliced, whole)


@pytest.mark.filterwarnings("ignore:.*Code running in object mode")
@pytest.mark.parametrize("threads", [2, 3, 4])
def test_each_row_once_in_its_slice_from_several_threads(threads):
    # (threads given: several whatever NUMBA_NUM_THREADS is, one pool for every call)
    n = 10 * MIN_ROWS_PER_THREAD + 5
    visits, slice_lo = np.zeros(n, dtype=np.int64), np.full(n, -1, dtype=np.int64)
    thread = np.zeros(n, dtype=np.uint64)
    run_in_threads(_mark_rows, n, visits, slice_lo, thread, threads=threads)
    assert (visits == 1).all()  # none missing, none twice
    slices = row_slices(n, threads)
    assert len(slices) > threads
    expected = np.concatenate([np.full(hi - lo, lo) for lo, hi in slices])
    np.testing.assert_array_equal(slice_lo, expected)
    assert len(set(thread.tolist())) >= 2
    for lo, hi in slices:  # a slice runs in one thread
        assert len(set(thread[lo:hi].tolist())) == 1


@numba.njit(nogil=True)
def _slow_first_slice(visits, slice_lo, thread, lo, hi):
    """``_mark_rows``, the first slice held up: the other thread takes the rest meanwhile."""
    if lo == 0:
        with numba.objmode():
            time.sleep(0.5)
    _mark_rows(visits, slice_lo, thread, lo, hi)


@pytest.mark.filterwarnings("ignore:.*Code running in object mode")
def test_dynamic_slices_are_taken_as_the_threads_free():
    n, small = 40 * 64 + 9, 64
    slices = row_slices(n, 2, min_rows=small, dynamic=True)
    assert len(slices) == n // small  # as many as there are min_rows in the rows
    assert min(hi - lo for lo, hi in slices) >= small
    assert [i for lo, hi in slices for i in range(lo, hi)] == list(range(n))
    assert len(row_slices(n, 2, min_rows=small)) == 2 * 4  # static: SLICES_PER_THREAD each
    visits, slice_lo = np.zeros(n, dtype=np.int64), np.full(n, -1, dtype=np.int64)
    thread = np.zeros(n, dtype=np.uint64)
    run_in_threads(_slow_first_slice, n, visits, slice_lo, thread, threads=2, min_rows=small,
                   dynamic=True)
    assert (visits == 1).all()
    expected = np.concatenate([np.full(hi - lo, lo) for lo, hi in slices])
    np.testing.assert_array_equal(slice_lo, expected)
    held = thread[0]
    # while the first slice slept, the other thread took every other one (statically it
    # would have had half of them)
    assert (thread[slices[1][0]:] != held).all()


@numba.njit(nogil=True)
def _fails_in_the_last_slice(n, lo, hi):
    if hi == n:
        raise ValueError("the last slice failed")


def test_an_error_in_a_slice_is_raised():
    for threads in (1, 2, 3):
        with pytest.raises(ValueError, match="the last slice failed"):
            run_in_threads(_fails_in_the_last_slice, 20 * MIN_ROWS_PER_THREAD,
                           20 * MIN_ROWS_PER_THREAD, threads=threads)


@numba.njit
def _holds_the_lock(out, lo, hi):
    out[lo:hi] = 1.0


def test_a_kernel_without_nogil_is_refused():
    out = np.zeros(4 * MIN_ROWS_PER_THREAD)
    for block in (_holds_the_lock, _holds_the_lock.py_func):
        with pytest.raises(TypeError, match=r"nogil=True.*_holds_the_lock"):
            run_in_threads(block, out.size, out, threads=2)
    assert not out.any()


def test_numba_s_debug_mode_runs_the_python_rows():
    """Under ``NUMBA_DISABLE_JIT=1`` ``njit`` returns the Python function: still run it."""
    script = ("import numba, numpy as np\n"
              "from toolpath.row_threads import run_in_threads\n"
              "@numba.njit(nogil=True)\n"
              "def rows(out, lo, hi):\n"
              "    for i in range(lo, hi):\n"
              "        out[i] = 2 * i\n"
              "out = np.zeros(5000)\n"
              "run_in_threads(rows, 5000, out, threads=2)\n"
              "assert (out == 2 * np.arange(5000)).all()\n"
              "print('ok')\n")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          timeout=120, env={**os.environ, "NUMBA_DISABLE_JIT": "1"})
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "ok"


def test_a_small_k_d_query_runs_in_the_calling_thread_alone():
    # scipy starts its query's workers afresh each call: a few hundred points are asked
    # in one thread, many in numba's threads (one where numba is held to one)
    assert query_workers(0) == query_workers(MIN_ROWS_PER_THREAD - 1) == 1
    assert query_workers(MIN_ROWS_PER_THREAD) == numba.get_num_threads()
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        assert query_workers(10 * MIN_ROWS_PER_THREAD) == 1
    finally:
        numba.set_num_threads(before)
