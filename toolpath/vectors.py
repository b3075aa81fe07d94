"""Small vector helpers shared by the fits and the planner (numpy, rows of vectors)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["cross_rows", "lengths", "move_axes", "move_poses", "row_lengths", "unit"]


def unit(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """``v / |v|`` along the last axis; a zero vector stays zero (no division by 0).

    (``|v|`` of 3-vectors by :func:`row_lengths`: numpy's norm, bit for bit, faster.)
    """
    norm = (row_lengths(v)[..., None] if np.shape(v)[-1:] == (3,)
            else np.linalg.norm(v, axis=-1, keepdims=True))
    return v / np.where(norm > 0.0, norm, 1.0)


def lengths(dx: NDArray[np.float64], dy: NDArray[np.float64], dz: NDArray[np.float64]
            ) -> NDArray[np.float64]:
    """Lengths of vectors of components ``dx, dy, dz``: ``np.linalg.norm(d, axis=-1)``.

    The same sum of the same squares in the same order (``dx^2 + dy^2``, then ``+ dz^2``,
    as numpy's reduction of three takes them), without numpy's reduction along a short
    axis (several times slower): the same lengths, bit for bit.
    """
    return np.sqrt(dx * dx + dy * dy + dz * dz)


def row_lengths(v: NDArray[np.float64]) -> NDArray[np.float64]:
    """``np.linalg.norm(v, axis=-1)`` of 3-vectors (:func:`lengths`: bit for bit, faster).

    In float64 (numpy's norm of float32 rows stays float32: other bits).
    """
    v = np.asarray(v, dtype=float)
    return lengths(v[..., 0], v[..., 1], v[..., 2])


def cross_rows(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """``np.cross(a, b)`` of 3-vectors (last axis): the same products, the same differences.

    (``a1 b2 - a2 b1``, ``a2 b0 - a0 b2``, ``a0 b1 - a1 b0``, as numpy's own loop takes
    them, without its set-up for any shapes: a third of its time on ten thousand rows.)
    ``a`` and ``b`` of one shape, taken in float64 (numpy's cross keeps float32 and
    integers: the same bits only for float64).
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    out = np.empty_like(a)
    for k in range(3):
        i, j = (k + 1) % 3, (k + 2) % 3
        np.subtract(a[..., i] * b[..., j], a[..., j] * b[..., i], out=out[..., k])
    return out


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
