"""A verification with the compiled searches and again with the pair search (the oracle).

The pair search (``SweepIndex(compiled=False)``) expands every candidate (dexel, piece)
pair in numpy and folds the minimum; the compiled walks must leave the same material on
every dexel.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import verification.verify as verify_module
from verification import verify_program
from verification.dexels import SweepIndex


def compiled_and_oracle(monkeypatch, *args, **kwargs):
    """``verify_program(*args, **kwargs)`` with the compiled walks, then with the oracle."""
    fast = verify_program(*args, **kwargs)
    with monkeypatch.context() as m:
        m.setattr(verify_module, "SweepIndex", functools.partial(SweepIndex, compiled=False))
        exact = verify_program(*args, **kwargs)
    return fast, exact


def assert_same_material(fast, exact, *, blocks: bool = True) -> None:
    """The same deviation on every dexel and the same extremes; with ``blocks``, traced to
    the same block (ties between abutting pieces may pick either: 0.1 % of the dexels) and
    the extremes to the same line."""
    a, b = fast.deviation_map.deviation_mm, exact.deviation_map.deviation_mm
    assert np.array_equal(np.isnan(a), np.isnan(b))
    assert np.array_equal(np.isinf(a), np.isinf(b))
    finite = np.isfinite(a)
    np.testing.assert_allclose(a[finite], b[finite], rtol=0.0, atol=1e-9)
    for name in ("max_gouge_mm", "max_scallop_mm", "max_excess_mm"):
        assert getattr(fast, name) == pytest.approx(getattr(exact, name), abs=1e-9,
                                                         nan_ok=True)
    if not blocks:
        return
    same_block = fast.deviation_map.block_index == exact.deviation_map.block_index
    assert same_block.mean() > 0.999
    for f, e in ((fast.max_gouge, exact.max_gouge), (fast.max_scallop, exact.max_scallop)):
        assert (f is None) == (e is None)
        if f is not None:
            assert (f.line, f.rapid, f.shank) == (e.line, e.rapid, e.shank)
