"""The near search's merge of joining dexels against numpy's union (verification.search)."""

import numpy as np
import pytest

from verification.search import joined_rows


def _disjoint_sorted(rng: np.random.Generator, n: int, share: float) -> tuple[np.ndarray, ...]:
    """Two sorted, disjoint index arrays drawn from ``range(n)`` (as the levels make them)."""
    picked = np.flatnonzero(rng.random(n) < share)
    to_rows = rng.random(picked.shape[0]) < 0.5
    return picked[to_rows], picked[~to_rows]


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("share", [0.0, 0.01, 0.5, 1.0])
def test_joined_rows_is_the_union(seed: int, share: float) -> None:
    # fails if the merge is not sorted (mutation: drop ``merged.sort``), or if an empty
    # side returns the wrong one (mutation: ``return rows`` when ``rows`` is empty)
    rng = np.random.default_rng(seed)
    rows, joining = _disjoint_sorted(rng, 5000, share)
    for a, b in ((rows, joining), (rows[:0], joining), (rows, joining[:0]),
                 (rows[:0], joining[:0])):
        got = joined_rows(a, b)
        want = np.union1d(a, b)
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)


def test_joined_rows_interleaved() -> None:
    # the joining dexels fall between the remaining ones: a concatenation alone is unsorted
    rows = np.array([0, 2, 4, 9], dtype=np.int64)
    joining = np.array([1, 3, 10], dtype=np.int64)
    np.testing.assert_array_equal(joined_rows(rows, joining), [0, 1, 2, 3, 4, 9, 10])
