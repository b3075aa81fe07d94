"""Shortcuts of the flat and bull-nose search against their full methods.

* the inner minimisation of :mod:`verification.torus` (bracketed Newton on ``w``) against
  a dense minimisation of the core's distance over the chord
"""

import numpy as np
import pytest

from verification.torus import core_signed_distance, sweep_distance


def _unit(v):
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _three_axis_pieces(rng, m):
    """Pieces of a fixed +Z axis along chords that climb or fall a little (3-axis passes)."""
    c0 = rng.uniform(-2.0, 2.0, (m, 3))
    across = rng.normal(size=(m, 2)) * rng.choice([0.3, 1.5], (m, 1))
    chord = np.column_stack((across, rng.normal(scale=0.15, size=m)))
    axis = np.tile([0.0, 0.0, 1.0], (m, 1))
    return c0, chord, axis


def _dense_distance(y, c0, chord, axis, height, core, corner):
    """``min_w sd_core(y - C0 - w D) - r``: grids over ``w``, each about the last one's least.

    ``Phi`` is convex in ``w`` (kinked inside the core), so the least of a grid lies
    within one step of the minimiser: four grids of 2001 steps pin it to 1e-13 of the chord.
    """
    lo, hi = 0.0, 1.0
    least = np.inf
    for _ in range(4):
        ws = np.linspace(lo, hi, 2001)
        sd, _ = core_signed_distance(y - c0 - ws[:, None] * chord,
                                     np.tile(axis, (ws.size, 1)), np.full(ws.size, height),
                                     core)
        k = int(np.argmin(sd))
        least = min(least, float(sd[k]) - corner)
        lo, hi = ws[max(k - 1, 0)], ws[min(k + 1, ws.size - 1)]
    return least


@pytest.mark.parametrize(("core", "height", "corner"), [(3.0, 3.0, 0.0), (2.0, 1.0, 1.0)])
def test_the_inner_minimum_is_the_dense_one(rng, core, height, corner):
    # points near the rim of the swept core (where the minimiser sits on a rim between two
    # faces: false position crawled there) and anywhere around it, 3-axis and turned axes;
    # mutation caught: a Newton step taken outside the bracket (``lo < nw < hi`` dropped in
    # _inner_min) minimises past the chord's ends, below the true distance
    m = 300
    c0, chord, axis = _three_axis_pieces(rng, m)
    axis[m // 2:] = _unit(rng.normal(size=(m - m // 2, 3)))
    w = rng.uniform(-0.3, 1.3, m)[:, None]
    rim = _unit(np.cross(axis, rng.normal(size=(m, 3)))) * core
    y = c0 + w * chord + rim + rng.normal(scale=rng.choice([0.001, 0.3], (m, 1)), size=(m, 3))
    got = sweep_distance(y, c0, chord, axis, np.full(m, height), core_radius_mm=core,
                         corner_radius_mm=corner)
    want = np.array([_dense_distance(y[k], c0[k], chord[k], axis[k], height, core, corner)
                     for k in range(m)])
    # never below the minimum (every value measured is the distance at some w in [0, 1])
    # and within the stopping test's 1e-9 mm of it
    assert (got >= want - 1e-12).all()
    np.testing.assert_allclose(got, want, rtol=0.0, atol=2e-9)
