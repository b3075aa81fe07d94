"""Row slices run in threads: every row once, the same result as one call over all rows."""

import numba
import numpy as np
import pytest

from toolpath.row_threads import MIN_ROWS_PER_THREAD, row_slices, run_in_threads


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


def test_threads_give_the_one_call_result():
    x = np.random.default_rng(7).normal(size=20 * MIN_ROWS_PER_THREAD + 3)
    whole, sliced = np.full_like(x, np.nan), np.full_like(x, np.nan)
    _square_rows(x, whole, 0, x.size)
    run_in_threads(_square_rows, x.size, x, sliced)
    np.testing.assert_array_equal(sliced, whole)


def test_an_error_in_a_slice_is_raised():
    def fails_late(lo, hi):
        if hi == 20 * MIN_ROWS_PER_THREAD:
            raise ValueError(f"rows {lo}..{hi}")

    if numba.get_num_threads() > 1:
        with pytest.raises(ValueError, match="rows"):
            run_in_threads(fails_late, 20 * MIN_ROWS_PER_THREAD)
