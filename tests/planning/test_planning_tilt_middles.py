"""Moves whose post-split middle leans past the tilt joint's travel are split by the planner.

The post splits a 5-axis move at its middle with the normalized mean of the ends' axes
(``travel.with_split_middles`` models it for the travel check); beyond 90 deg from +Z that
middle leans further than either end. The real-like propeller on ``trunnion-ac`` once
failed its run there: both ends leaned back to the cap, the middle 0.007 deg past the A
joint's -120 deg.
"""

from types import SimpleNamespace

import numpy as np
import pytest

from toolpath.planning.options import TILT_MARGIN_DEG
from toolpath.planning.passes import middle_past_tilt
from toolpath.planning.travel import with_split_middles

REACH_DEG = 120.0
CAP_DEG = REACH_DEG - TILT_MARGIN_DEG


def _axis(tilt_deg, azimuth_deg):
    t, a = np.radians(tilt_deg), np.radians(azimuth_deg)
    return np.array([np.sin(t) * np.cos(a), np.sin(t) * np.sin(a), np.cos(t)])


def _tilt_deg(axes):
    return np.degrees(np.arccos(np.clip(axes[:, 2], -1.0, 1.0)))


@pytest.mark.parametrize("tilt_deg", [95.0, 110.0, CAP_DEG])
def test_moves_left_whole_keep_their_post_middle_within_the_reach(tilt_deg):
    rng = np.random.default_rng(7)
    n = 4000
    azimuth = rng.uniform(0.0, 360.0, n)
    turn = rng.uniform(0.0, 25.0, n)
    tilt_b = np.minimum(tilt_deg + rng.uniform(-3.0, 3.0, n), CAP_DEG)
    axes = np.empty((2 * n, 3))
    axes[0::2] = np.array([_axis(tilt_deg, a) for a in azimuth])
    axes[1::2] = np.array([_axis(b, a + d) for b, a, d in zip(tilt_b, azimuth, turn, strict=True)])
    pts = SimpleNamespace(axes=axes)
    res = SimpleNamespace(max_tilt_deg=CAP_DEG)
    idx = np.arange(0, 2 * n, 2)
    split = middle_past_tilt(res, pts, idx)
    # the post's middles of the moves left whole
    tips = np.zeros_like(axes)
    moves = np.zeros(2 * n - 1, dtype=bool)
    moves[idx[~split]] = True
    _, with_middles, _ = with_split_middles(tips, axes, moves)
    assert len(with_middles) == 2 * n + int((~split).sum())
    assert _tilt_deg(with_middles).max() <= REACH_DEG
    assert split.any() == (tilt_deg == CAP_DEG)


@pytest.mark.parametrize(("turn_deg", "split"), [(4.0, False), (10.0, True), (30.0, True)])
def test_ends_at_the_cap_turned_far_apart_are_split(turn_deg, split):
    axes = np.array([_axis(CAP_DEG, 40.0), _axis(CAP_DEG, 40.0 + turn_deg)])
    res = SimpleNamespace(max_tilt_deg=CAP_DEG)
    assert middle_past_tilt(res, SimpleNamespace(axes=axes), np.array([0]))[0] == split


def test_no_cap_splits_nothing():
    axes = np.array([_axis(170.0, 0.0), _axis(170.0, 90.0)])
    res = SimpleNamespace(max_tilt_deg=float("inf"))
    assert not middle_past_tilt(res, SimpleNamespace(axes=axes), np.array([0])).any()
