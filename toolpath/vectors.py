"""Small vector helpers shared by the fits and the planner (numpy, rows of vectors)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["move_axes", "move_poses", "unit"]


def unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """``v / |v|`` along the last axis; a zero vector stays zero (no division by 0)."""
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(norm > 0.0, norm, 1.0)


def move_poses(tip_a: NDArray[np.float64], axis_a: NDArray[np.float64],
               tip_b: NDArray[np.float64], axis_b: NDArray[np.float64],
               u: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The tool's tips and axes at fractions ``u`` (one per row) of moves ``a -> b``.

    As the control runs a straight 5-axis move: the tip linear,
    ``(1 - u) tip_a + u tip_b``, and the axis linear then normalised,
    ``unit((1 - u) axis_a + u axis_b)`` (:func:`unit`; opposite axes at ``u = 1/2``, a
    half-turn with no axis between, give a zero axis). Rows in, rows out.
    """
    w = u[:, None]
    return tip_a * (1 - w) + tip_b * w, move_axes(axis_a, axis_b, u)


def move_axes(axis_a: NDArray[np.float64], axis_b: NDArray[np.float64],
              u: NDArray[np.float64]) -> NDArray[np.float64]:
    """The tool axes of :func:`move_poses` alone: ``unit((1 - u) axis_a + u axis_b)``."""
    w = u[:, None]
    return unit(axis_a * (1 - w) + axis_b * w)
