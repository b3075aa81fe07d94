"""The paper's published test data (Examples 1, 2, 4, 5), generated exactly.

Examples 3, 6 and 7 use unpublished measured blades; the bundled development blade
(``toolpath/data``) stands in for them.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
import scipy.interpolate
import scipy.linalg
from numpy.typing import NDArray

__all__ = ["bundled_data_path", "example1", "example2", "example4", "example5", "nurbs_points"]


def example1(n: int = 100, span: float = 1.0) -> tuple[NDArray, NDArray, NDArray]:
    """Ex 1: ``A = [[0,−1,0],[1,0,0],[0,0,1]]``, ``X_0 = (1,−1,1)``, ``t ∈ [0, span]``.

    Returns ``(points, t, A)``.
    """
    A = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    t = np.linspace(0.0, span, n)
    return scipy.linalg.expm(t[:, None, None] * A) @ np.array([1.0, -1.0, 1.0]), t, A


def example2(n: int = 100, span: float = 5.65) -> tuple[NDArray, NDArray, NDArray]:
    """Ex 2: the rotation with ``A_33 = 0``, ``X_0 = (1, 0, 1)``: a circle, ``t ∈ [0, span]``.

    ``span = 5.65`` (about 0.9 of a turn) is the reading that matches Table 2.
    """
    A = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    t = np.linspace(0.0, span, n)
    return scipy.linalg.expm(t[:, None, None] * A) @ np.array([1.0, 0.0, 1.0]), t, A


def nurbs_points(knots, control_points, weights, n: int, degree: int = 2) -> NDArray:
    """``n`` points of a NURBS curve, uniform in its parameter over the valid domain."""
    knots = np.asarray(knots, float)
    w = np.asarray(weights, float)
    homogeneous = np.c_[np.asarray(control_points, float) * w[:, None], w]
    spline = scipy.interpolate.BSpline(knots, homogeneous, degree)
    u = np.linspace(knots[degree], knots[len(w)], n)
    h = spline(u)
    return h[:, :-1] / h[:, -1:]


def example4(n: int = 1001) -> NDArray:
    """Ex 4: closed degree-2 NURBS through the origin with two 63° corners (Table 4)."""
    return nurbs_points(
        [0, 0, 0, 0.17, 0.33, 0.33, 0.67, 0.67, 0.83, 1, 1, 1],
        [(0, 0), (-150, 50), (-50, 50), (0, 150), (150, 150), (150, 0), (50, -50),
         (50, -150), (0, 0)],
        [1, 2, 3, 1, 0.7071, 1, 3, 2, 1], n)


def example5(n: int = 1001) -> NDArray:
    """Ex 5: degree-2 NURBS on ``[0, 0.67]`` ending at the origin, one 20° corner (Table 5)."""
    return nurbs_points(
        [0, 0, 0, 0.17, 0.33, 0.33, 0.67, 0.67, 0.83],
        [(-75, 25), (-150, 50), (-100, 25), (-50, -50), (-25, -150), (0, 0)],
        [2, 3, 1, 3, 2, 1], n)


def bundled_data_path(name: str) -> Path:
    """Path of a bundled data file (``dev_blade_15x142.csv``, ``dev_half_profile_71.csv``)."""
    return Path(str(resources.files("toolpath") / "data" / name))
