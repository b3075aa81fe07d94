"""Linking runs: a chain of runs that follow on one another links as the runs one by one."""

import numpy as np
import pytest

from toolpath.path import MoveKind
from toolpath.planning.linking import ClearancePlane, LinkOptions, Run, extends, link_runs


def _run(rng, pass_index, n, **flags):
    offset = np.array([0.0, 2.0 * pass_index, 0.0])
    tips = np.cumsum(rng.normal(scale=0.5, size=(n, 3)), axis=0) + offset
    axes = np.tile([0.0, 0.0, 1.0], (n, 1))
    return Run(tips=tips, axes=axes, pass_index=pass_index, normal_start=np.array([0, 0, 1.0]),
               normal_end=np.array([0, 0, 1.0]), feed_start=np.array([1.0, 0, 0]),
               feed_end=np.array([1.0, 0, 0]), **flags)


def _chain(runs):
    """The runs as one chain: rows end to end, LINK (or CUT if joined) where each begins."""
    sizes = [len(r.tips) for r in runs]
    kinds = np.full(sum(sizes), MoveKind.CUT, dtype=np.uint8)
    kinds[np.cumsum(sizes)[:-1]] = [MoveKind.CUT if r.joined else MoveKind.LINK
                                    for r in runs[1:]]
    head, tail = runs[0], runs[-1]
    return Run(tips=np.concatenate([r.tips for r in runs]),
               axes=np.concatenate([r.axes for r in runs]), pass_index=head.pass_index,
               normal_start=head.normal_start, normal_end=tail.normal_end,
               feed_start=head.feed_start, feed_end=tail.feed_end,
               joined=head.joined, direct_link=head.direct_link, point_kinds=kinds,
               point_passes=np.repeat([r.pass_index for r in runs], sizes))


@pytest.mark.parametrize("how", ["direct", "joined"])
def test_a_chain_links_like_its_runs_one_by_one(how):
    rng = np.random.default_rng(4)
    flag = {"direct_link": True} if how == "direct" else {"joined": True}
    runs = ([_run(rng, 0, 5)] + [_run(rng, p, int(rng.integers(2, 7)), **flag)
                                 for p in range(1, 6)]
            + [_run(rng, 6, 4)] + [_run(rng, p, 3, **flag) for p in range(7, 9)])
    opt = LinkOptions(clearance=ClearancePlane(np.array([0.0, 0.0, 1.0]), 50.0),
                      feed_mm_per_min=1000.0, plunge_feed_mm_per_min=250.0,
                      lead_radius_mm=3.0, lead_angle_deg=90.0, approach_mm=2.0,
                      extend_mm=0.0, chord_tol_mm=0.01)
    one_by_one = link_runs(runs, opt)
    chained = link_runs([_chain(runs[:6]), _chain(runs[6:])], opt)
    for a, b in zip(one_by_one, chained, strict=True):
        np.testing.assert_array_equal(a, b)
    kinds, passes = one_by_one[2], one_by_one[4]
    assert (kinds == MoveKind.LINK).sum() == (7 if how == "direct" else 0)  # (run 6 lifts)
    assert set(passes[passes >= 0].tolist()) == set(range(9))


def test_extends_only_open_edges_and_only_a_positive_length():
    np.testing.assert_array_equal(extends(np.array([True, False]), 2.0), [True, False])
    assert not extends(True, 0.0)
