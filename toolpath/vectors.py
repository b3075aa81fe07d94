"""Small vector helpers shared by the fits and the planner (numpy, rows of vectors)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["unit"]


def unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """``v / |v|`` along the last axis; a zero vector stays zero (no division by 0)."""
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(norm > 0.0, norm, 1.0)
