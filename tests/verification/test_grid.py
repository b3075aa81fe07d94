"""The piece grid's counting sort against the stable sort of the cell keys."""

import numpy as np

from verification.grid import PieceGrid


def test_counting_sort_is_the_stable_sort_of_cell_keys():
    rng = np.random.default_rng(3)
    mid = rng.uniform(-2.0, 12.0, size=(5000, 3))
    mid[::7] = mid[::7].round()  # many pieces on cell borders and sharing cells
    mid[5] = np.nan
    lo, hi, cell = np.zeros(3), np.array([10.0, 8.0, 9.0]), 0.7
    grid = PieceGrid.build(mid, lo, hi, cell)
    dims = np.asarray(grid.dims)
    ijk = np.floor((mid - lo) / grid.cell_mm)
    with np.errstate(invalid="ignore"):
        inside = np.flatnonzero(((ijk >= 0) & (ijk < dims)).all(axis=1))
    key = ((ijk[inside, 0] * dims[1] + ijk[inside, 1]) * dims[2] + ijk[inside, 2]).astype(int)
    np.testing.assert_array_equal(grid.order, inside[np.argsort(key, kind="stable")])
    counts = np.bincount(key, minlength=int(np.prod(dims)))
    np.testing.assert_array_equal(grid.starts, np.r_[0, np.cumsum(counts)])
    assert 0 < grid.n_pieces < mid.shape[0]
