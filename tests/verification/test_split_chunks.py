"""Pieces cut a group of segments at a time are the pieces cut all at once, bit for bit.

:func:`verification.pieces._split` writes groups of about ``chunk_pieces`` pieces into
the whole set's arrays (its temporaries a group's, not the whole set's); every piece
depends on its own segment only, so any grouping gives the same arrays. Groups of 1, 3
and 7 pieces put seams inside runs of a segment's pieces' neighbours and after segments
of more pieces than a group.
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


@pytest.mark.parametrize("chunk", [1, 3, 7, 64])
@pytest.mark.parametrize("case", ["cut", "cut_axes", "min_count", "whole"])
def test_any_grouping_gives_the_pieces_of_one_group(rng, chunk, case):
    a, b, axis, axis_end, move, arc0, arc1 = _segments(rng, 300)
    kw = {"height_mm": 1.5}
    max_piece = 0.3
    if case == "cut_axes":
        kw["axis_end"] = axis_end
    if case == "min_count":
        kw.update(axis_end=axis_end, min_count=rng.integers(0, 5, a.shape[0]))
    if case == "whole":  # no segment cut: every piece a segment, ends as given
        max_piece = 100.0
        kw["axis_end"] = axis_end
    one = _split(a, b, axis, move, arc0, arc1, max_piece, False, arc0, move, **kw,
                 chunk_pieces=10**9)
    grouped = _split(a, b, axis, move, arc0, arc1, max_piece, False, arc0, move, **kw,
                     chunk_pieces=chunk)
    assert one.size > a.shape[0] or case == "whole"
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(grouped, name), getattr(one, name), err_msg=name)
