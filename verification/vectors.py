"""Lengths of many 3-vectors at once.

``np.linalg.norm(v, axis=-1)`` reduces over a strided last axis, three times slower on a
million rows than the same sum written out: :func:`row_norms` is
``sqrt((x^2 + y^2) + z^2)``, the same additions in the same order, so the same values.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["row_norms"]

FloatArray = NDArray[np.float64]


def row_norms(v: FloatArray) -> FloatArray:
    """``|v|`` over the last axis (length 3), shape ``v.shape[:-1]``; equal to numpy's norm."""
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    out = x * x
    out += y * y
    out += z * z
    return np.sqrt(out, out=out)
