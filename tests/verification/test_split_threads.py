"""Pieces cut in threads are the pieces of the chord fractions' formulas, bit for bit.

:func:`verification.pieces._split` writes each segment's pieces straight into the set's
arrays (:func:`verification.pieces._cut_rows`), segments shared among threads; every piece
depends on its own segment only, so one thread or several give the same arrays, and they
are the formulas' (written here in numpy, as the pieces were cut before the kernel).
"""

import numpy as np
import pytest

from verification.pieces import _split

FIELDS = ("a", "e", "ee", "mid", "half_mm", "move", "shank", "axis", "arc0_mm", "arc1_mm",
          "height_mm")


def _segments(rng, n):
    a = rng.uniform(-5.0, 5.0, (n, 3))
    b = a + rng.normal(0.0, 0.4, (n, 3)) * rng.integers(0, 4, (n, 1))  # some of length 0
    axis = rng.normal(0.0, 0.2, (n, 3)) + np.array([0.0, 0.0, 1.0])
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    axis_end = axis + rng.normal(0.0, 0.05, (n, 3))
    axis_end /= np.linalg.norm(axis_end, axis=1, keepdims=True)
    arc0 = np.cumsum(rng.uniform(0.0, 1.0, n))
    arc1 = arc0 + np.linalg.norm(b - a, axis=1)
    return a, b, axis, axis_end, np.arange(n, dtype=np.int64) * 3, arc0, arc1


def _formulas(a, b, axis, move, arc0, arc1, max_piece, *, min_count=None, axis_end=None):
    """The pieces' fields in numpy: cut at k / count of the chord once any segment is cut."""
    count = np.maximum(np.ceil(np.linalg.norm(b - a, axis=1) / max_piece), 1).astype(np.int64)
    if min_count is not None:
        count = np.maximum(count, min_count)
    if count.max() > 1:
        rep = np.repeat(np.arange(a.shape[0]), count)
        k = np.arange(rep.shape[0]) - (np.cumsum(count) - count)[rep]
        f0, f1 = k / count[rep], (k + 1) / count[rep]
        d, da = b[rep] - a[rep], arc1[rep] - arc0[rep]
        a, b = a[rep] + f0[:, None] * d, a[rep] + f1[:, None] * d
        arc0, arc1, move = arc0[rep] + f0 * da, arc0[rep] + f1 * da, move[rep]
        if axis_end is not None:
            axis = axis[rep] + 0.5 * (f0 + f1)[:, None] * (axis_end[rep] - axis[rep])
            axis, axis_end = axis / np.linalg.norm(axis, axis=1, keepdims=True), None
        else:
            axis = axis[rep]
    if axis_end is not None:
        axis = axis + axis_end
        axis = axis / np.linalg.norm(axis, axis=1, keepdims=True)
    e = b - a
    ee = (e[:, 0] * e[:, 0] + e[:, 1] * e[:, 1]) + e[:, 2] * e[:, 2]  # (in that order)
    return {"a": a, "e": e, "ee": ee, "mid": a + 0.5 * e, "half_mm": 0.5 * np.sqrt(ee),
            "move": move, "axis": axis, "arc0_mm": arc0, "arc1_mm": arc1}


@pytest.mark.parametrize("case", ["cut", "cut_axes", "min_count", "whole"])
def test_pieces_in_threads_are_the_formulas_pieces(rng, case):
    a, b, axis, axis_end, move, arc0, arc1 = _segments(rng, 3000)
    kw = {}
    max_piece = 0.3
    if case == "cut_axes":
        kw["axis_end"] = axis_end
    if case == "min_count":
        kw.update(axis_end=axis_end, min_count=rng.integers(0, 5, a.shape[0]))
    if case == "whole":  # no segment cut: every piece a segment, ends as given
        max_piece = 100.0
        kw["axis_end"] = axis_end
    expected = _formulas(a, b, axis, move, arc0, arc1, max_piece, **kw)
    one = _split(a, b, axis, move, arc0, arc1, max_piece, False, arc0, move, height_mm=1.5,
                 threads=1, **kw)
    shared = _split(a, b, axis, move, arc0, arc1, max_piece, False, arc0, move,
                    height_mm=1.5, threads=3, **kw)
    assert one.size > a.shape[0] or case == "whole"
    if case == "whole":
        np.testing.assert_array_equal(one.a + one.e, b)  # the ends as given
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(shared, name), getattr(one, name), err_msg=name)
        if name in expected:
            np.testing.assert_array_equal(getattr(one, name), expected[name], err_msg=name)
    np.testing.assert_array_equal(one.height_mm, 1.5)
    assert not one.shank.any()


def test_no_segments_no_pieces():
    empty = np.zeros((0, 3))
    none = np.zeros(0)
    pieces = _split(empty, empty, empty, np.zeros(0, dtype=np.int64), none, none, 0.3, True,
                    none, np.zeros(0, dtype=np.int64))
    assert pieces.size == 0 and pieces.a.shape == (0, 3)
