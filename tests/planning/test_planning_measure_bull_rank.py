"""The flat and bull-nose estimate ranks the seeds it decides as their ray casts do.

The measure ray casts the seeds of the largest estimates, those without one and those
whose estimate stands above the largest cusp cast by more than
:data:`~toolpath.planning.measure.ESTIMATE_SHARE`; the rest it decides without a cast
(:func:`~toolpath.planning.measure.cast_beyond_estimates`). An estimate reading hundreds
of times its cusp decides nothing: it is cast. The user's kind of job (the standing dev
blade, 5-axis under trunnion-ac's joints, bull:8:1, lead 10 degrees), on a coarser
request and the seeds round the leading edge (``t`` 0.46 to 0.5): where the passes' axes
lean apart unequally the two passes' sections met on the own flank facing away, 0.47 mm
up, 25 times the largest cusp (:func:`~toolpath.planning.torus_profile.profile_ridges`).
The oracle: every seed ray cast (the full method).
"""

import numpy as np
import pytest
from measured_plans import bull_leading_edge, bull_leading_edge_estimates

from toolpath.planning.cusp_search import CuspSearch
from toolpath.planning.measure import (
    ESTIMATE_SHARE,
    ESTIMATE_TOP,
    ESTIMATE_TOP_MOST,
    cast_beyond_estimates,
)

#: The seeds round the leading edge, ``t`` from and to.
BAND_T = (0.46, 0.5)


@pytest.fixture(scope="module")
def leading_edge():
    """The estimates and both searches (estimated, full) over the band's seeds."""
    measured, volume, seeds, others = bull_leading_edge(*BAND_T)
    guess = bull_leading_edge_estimates(*BAND_T)
    searches = [CuspSearch(volume, measured.surface, seeds, others, 1.0, 20_000)
                for _ in range(2)]
    fast, full = searches
    cast_beyond_estimates(fast, guess, [np.ones(len(guess), dtype=bool)], ESTIMATE_TOP,
                          ESTIMATE_TOP_MOST)
    full.run(np.ones(len(guess), dtype=bool))
    return guess, fast, full


def test_the_seeds_decided_cast_within_the_share_or_below_the_largest(leading_edge):
    guess, fast, full = leading_edge
    top = np.nanmax(np.where(np.isfinite(full.height), full.height, np.nan))
    assert np.nanmax(fast.height) == top > 0.0  # the largest cusp, as the full method
    decided = ~fast.cast
    assert decided.sum() > 0.5 * len(guess)
    h, g = full.height[decided], guess[decided]
    found = np.isfinite(h)
    assert ((h[found] <= ESTIMATE_SHARE * g[found]) | (h[found] < top)).all()


def test_no_estimate_stands_far_above_the_largest_cusp(leading_edge):
    # the sections met on the own flank facing away read 0.47 mm (25 times the largest
    # cusp); the ridge between the contacts reads near its cast
    guess, _, full = leading_edge
    top = np.nanmax(np.where(np.isfinite(full.height), full.height, np.nan))
    assert np.nanmax(guess) < 10.0 * top


def test_the_nearest_of_the_own_pass_is_found_whatever_crowds_round():
    """Per-pass k-d trees find each point's nearest of its own pass, as brute force does.

    Crowded: 30 passes' points in a thin slab, and one pass whose points all stand behind
    5,000 points of other passes round its queries (the search among the nearest 1,024 of
    all points gave up there, -1, read as piece 0).
    """
    from toolpath.planning.cusp_estimates import _nearest_in_pass

    rng = np.random.default_rng(7)
    slab = rng.random((6000, 3)) * (10.0, 10.0, 0.1)
    crowd = rng.normal(20.0, 0.1, (5000, 3))
    behind = rng.normal(20.0, 0.1, (50, 3)) + np.array([3.0, 0.0, 0.0])
    points = np.concatenate([slab, crowd, behind])
    pass_of = np.concatenate([rng.integers(0, 30, 6000), 1 + np.arange(5000) % 29,
                              np.full(50, 30)])
    pass_of[pass_of == 5] = 6  # (a pass with no point: -1)
    point = np.concatenate([rng.random((500, 3)) * (10.0, 10.0, 0.1),
                            rng.normal(20.0, 0.05, (100, 3))])
    pass_ = np.concatenate([rng.integers(0, 30, 500), np.full(100, 30)])
    got = _nearest_in_pass(points, pass_of, point, pass_)
    for i in range(len(point)):
        own = np.flatnonzero(pass_of == pass_[i])
        if not own.size:
            assert got[i] == -1
            continue
        dist = np.linalg.norm(points[own] - point[i], axis=1)
        assert got[i] == own[np.argmin(dist)]
