"""The line-capsule kernel against a sampled oracle, and its special cases."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from verification.capsule import line_capsule_interval


def _oracle(p, d, a, b, r, lo=-20.0, hi=20.0, n=400001, block=4000):
    """Entry/exit by dense sampling of the distance to the segment (``d`` a unit vector).

    The distance to the segment moves no faster than the point: a block of samples whose
    middle stands farther than ``r`` + half its span (+1e-9) from the segment has no
    sample inside, one nearer than ``r`` - half its span none outside. Only the other
    blocks' samples are measured (those the capsule's surface passes through).
    """
    lam = np.linspace(lo, hi, n)
    e = b - a

    def distance(lam):
        x = p + lam[:, None] * d
        f = np.clip((x - a) @ e / max(e @ e, 1e-300), 0.0, 1.0)
        return np.linalg.norm(x - (a + f[:, None] * e), axis=1)

    inside = np.empty(n, dtype=bool)
    for start in range(0, n, block):
        part = lam[start:start + block]
        reach = 0.5 * (part[-1] - part[0])
        middle = distance(np.array([0.5 * (part[0] + part[-1])]))[0]
        if abs(middle - r) > reach + 1e-9:
            inside[start:start + block] = middle < r
        else:
            inside[start:start + block] = distance(part) <= r
    if not inside.any():
        return np.inf, -np.inf
    return lam[inside][0], lam[inside][-1]


def _call(p, d, a, b, r):
    e = (b - a)[None]
    li, lo = line_capsule_interval(p[None], d[None], a[None], e, (e * e).sum(1), r)
    return li[0], lo[0]


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_kernel_matches_a_dense_sampling_oracle(seed):
    rng = np.random.default_rng(seed)
    p = rng.uniform(-3, 3, 3)
    d = rng.normal(size=3)
    d /= np.linalg.norm(d)
    a = rng.uniform(-3, 3, 3)
    b = a + rng.normal(size=3) * rng.choice([0.0, 0.5, 4.0])
    r = rng.uniform(0.5, 3.0)
    got = _call(p, d, a, b, r)
    want = _oracle(p, d, a, b, r)
    if np.isinf(want[0]):
        # a miss, or a graze thinner than the oracle's step
        assert np.isinf(got[0]) or got[1] - got[0] < 1e-3
    else:
        assert got[0] == pytest.approx(want[0], abs=2e-4)
        assert got[1] == pytest.approx(want[1], abs=2e-4)


def test_a_ball_rolling_over_a_plane_point_and_degenerate_segments():
    up = np.array([0.0, 0.0, 1.0])
    origin = np.zeros(3)
    # a ball centre line 3 mm up, 1 mm aside: the dexel enters at R - sqrt(R^2 - 1)
    li, lo = _call(origin, up, np.array([-5.0, 1.0, 3.0]), np.array([5.0, 1.0, 3.0]), 3.0)
    assert li == pytest.approx(3.0 - np.sqrt(8.0)) and lo == pytest.approx(3.0 + np.sqrt(8.0))
    # zero-length segment: a sphere
    li, lo = _call(origin, up, np.array([0.0, 0.0, 2.0]), np.array([0.0, 0.0, 2.0]), 3.0)
    assert (li, lo) == pytest.approx((-1.0, 5.0))
    # line along the segment's axis: the end spheres bound it
    li, lo = _call(origin, up, np.array([0.0, 0.0, 4.0]), np.array([0.0, 0.0, 9.0]), 3.0)
    assert (li, lo) == pytest.approx((1.0, 12.0))
    # a miss
    li, lo = _call(origin, up, np.array([5.0, 0.0, 0.0]), np.array([5.0, 4.0, 0.0]), 3.0)
    assert np.isposinf(li) and np.isneginf(lo)
