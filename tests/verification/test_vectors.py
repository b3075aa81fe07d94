"""Row norms written out equal numpy's norm, value for value."""

import numpy as np

from verification.vectors import row_norms


def test_row_norms_equal_numpy_norm():
    rng = np.random.default_rng(5)
    v = rng.normal(size=(4000, 3)) * 10.0 ** rng.integers(-6, 4, size=(4000, 1))
    v[:7] = [[0, 0, 0], [1, 0, 0], [0, 0, -2], [3, 4, 12], [1e-300, 0, 0], [np.inf, 0, 1],
             [np.nan, 0, 0]]
    np.testing.assert_array_equal(row_norms(v), np.linalg.norm(v, axis=1))
    grid = v[:3900].reshape(30, 130, 3)
    np.testing.assert_array_equal(row_norms(grid), np.linalg.norm(grid, axis=-1))
    assert row_norms(v[:0]).shape == (0,)
