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


def _reference_order(mid, lo, cell, dims):
    """The cells of the midpoints as numpy computes them (far and non-finite: outside)."""
    ijk = np.floor(np.clip(np.nan_to_num((mid - lo) / cell, nan=-1.0), -1.0,
                           float(dims.max()))).astype(np.int64)
    inside = np.flatnonzero(((ijk >= 0) & (ijk < dims)).all(axis=1))
    key = (ijk[inside, 0] * dims[1] + ijk[inside, 1]) * dims[2] + ijk[inside, 2]
    counts = np.bincount(key, minlength=int(np.prod(dims)))
    return inside[np.argsort(key, kind="stable")], np.r_[0, np.cumsum(counts)]


def test_cells_found_piece_by_piece_are_numpy_s_to_the_bit():
    # borders met exactly and a rounding away from them, infinities, huge and far values
    rng = np.random.default_rng(11)
    lo, cell = np.array([-1.0, 0.5, 2.0]), 0.3
    border = lo + cell * rng.integers(-3, 40, size=(3000, 3))
    mid = np.concatenate((border, np.nextafter(border, -np.inf), np.nextafter(border, np.inf),
                          rng.uniform(-5.0, 15.0, size=(3000, 3))))
    mid[::97, 0] = np.inf
    mid[1::97, 1] = -np.inf
    mid[2::97, 2] = np.nan
    mid[3::97] = 1e300
    mid[4::97] = -1e300
    grid = PieceGrid.build(mid, lo, lo + 10.0, cell)
    order, starts = _reference_order(mid, lo, grid.cell_mm, np.asarray(grid.dims))
    np.testing.assert_array_equal(grid.order, order)
    np.testing.assert_array_equal(grid.starts, starts)


def test_the_build_makes_no_temporaries_of_the_pieces_size_but_their_keys():
    import tracemalloc

    mid = np.random.default_rng(5).uniform(0.0, 100.0, size=(200_000, 3))
    lo, hi = np.zeros(3), np.full(3, 100.0)
    PieceGrid.build(mid[:10], lo, hi, 1.0)  # compiled before the count
    tracemalloc.start()
    try:
        grid = PieceGrid.build(mid, lo, hi, 1.0)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    kept = grid.starts.nbytes + grid.order.nbytes
    # one int64 key per piece besides what the grid keeps (the cells per axis as floats,
    # then as integers, were 24 bytes per piece each)
    assert peak - kept <= 8 * mid.shape[0] + 1_000_000
