"""The points' scatter about a smooth curve through them (toolpath.scatter)."""

import numpy as np
import pytest

from toolpath.scatter import point_scatter_mm, sections_scatter_mm


def _bent_curve(n=400):
    """A 3-D curve of varying curvature, its stations clustered cosine-wise at both ends
    (steps from 10 um to 0.4 mm), with a 30 deg corner in the middle."""
    u = 0.5 * (1.0 - np.cos(np.linspace(0.0, np.pi, n)))
    x = 80.0 * u
    curve = np.c_[x, 5.0 * np.sin(x / 15.0), 0.02 * x**1.5]
    mid = n // 2
    turn = np.radians(30.0)
    rotation = np.array([[np.cos(turn), -np.sin(turn), 0.0], [np.sin(turn), np.cos(turn), 0.0],
                         [0.0, 0.0, 1.0]])
    curve[mid:] = curve[mid] + (curve[mid:] - curve[mid]) @ rotation.T
    return curve


def test_exact_points_read_no_scatter():
    # however unevenly spaced, curved or cornered: well under a micrometre
    assert point_scatter_mm(_bent_curve()) < 2e-5


@pytest.mark.parametrize("sigma_um", [1.0, 3.0])
@pytest.mark.parametrize("dimensions", [2, 3])
def test_scatter_reads_the_points_spread(sigma_um, dimensions):
    # (in the plane the wobble is 0.67 sigma, in space 1.59: one or two directions across)
    rng = np.random.default_rng(7)
    curve = _bent_curve()[:, :dimensions]
    sections = [curve + rng.normal(0.0, 1e-3 * sigma_um, curve.shape) for _ in range(9)]
    assert 0.8 < sections_scatter_mm(sections) / (1e-3 * sigma_um) < 1.25
