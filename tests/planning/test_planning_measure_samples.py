"""Seeds with no estimate ray cast a sample at a time, then near the high cusps.

Where the passes' own geometry gives no estimate (a flat end leaned over a blade under a
5-axis machine: most seeds), :func:`~toolpath.planning.measure.cast_beyond_estimates`
casts the first, last and every :data:`SAMPLE_STRIDE`-th seed of each run of them, then
every such seed within that stride of a cusp cast at or above :data:`SAMPLE_NEAR_SHARE`
of the largest, until none is left. Checked on known cusps (a peak between the samples is
found), and end to end against the full method on a 5-axis flat-end blade job.
"""

import numpy as np
from measured_plans import KnownCusps, standing_blade_job

from toolpath.planning import measure
from toolpath.planning.measure import (
    ESTIMATE_TOP,
    ESTIMATE_TOP_MOST,
    SAMPLE_NEAR_SHARE,
    SAMPLE_STRIDE,
    _run_samples,
    cast_beyond_estimates,
)


def test_each_run_is_sampled_at_its_ends_and_every_stride():
    rows = np.zeros(40, dtype=bool)
    rows[2:13] = True  # one run of 11: 2, 6, 10 and its last, 12
    rows[20] = True  # a run of one
    rows[25:31] = True  # 25..30, the pass changing at 28: runs 25..27 and 28..30
    passes = np.where(np.arange(40) < 28, 0, 1)
    got = np.flatnonzero(_run_samples(rows, passes, 4))
    assert got.tolist() == [2, 6, 10, 12, 20, 25, 27, 28, 30]
    assert not _run_samples(np.zeros(5, dtype=bool), np.zeros(5, dtype=np.int64), 4).any()


def _smooth_cusps(rng, n_passes, per_pass):
    """Cusps changing gradually along each pass (0.2 to 0.6 mm), seeds in pass order."""
    along = np.linspace(0.0, 6.0 * np.pi, per_pass)
    cusps = np.concatenate([0.4 + 0.2 * np.sin(along + rng.uniform(0.0, 6.0))
                            for _ in range(n_passes)])
    return cusps, np.repeat(np.arange(n_passes), per_pass)


def _bump(cusps):
    """Raise the third pass's cusps to 1 mm at a seed between two samples, a bump of
    half-width 1.5 strides; returns that seed."""
    peak = 2 * 400 + 3 * SAMPLE_STRIDE + SAMPLE_STRIDE // 2
    rows = np.arange(peak - 3 * SAMPLE_STRIDE, peak + 3 * SAMPLE_STRIDE + 1)
    bump = np.exp(-0.5 * ((rows - peak) / (1.5 * SAMPLE_STRIDE)) ** 2)
    cusps[rows] = cusps[rows] * (1.0 - bump) + bump
    return peak


def test_a_peak_between_the_samples_is_found_from_the_samples_beside_it():
    rng = np.random.default_rng(5)
    cusps, passes = _smooth_cusps(rng, 6, 400)
    # the largest cusp, 1 mm, on a bump a few strides wide, centred between two samples
    peak = _bump(cusps)
    search = KnownCusps(cusps)
    guess = np.full(len(cusps), np.nan)  # no estimate anywhere
    cast_beyond_estimates(search, guess, [np.ones(len(cusps), dtype=bool)], ESTIMATE_TOP,
                          ESTIMATE_TOP_MOST, passes=passes)
    assert np.nanmax(search.height) == 1.0
    first = _run_samples(np.ones(len(cusps), dtype=bool), passes, SAMPLE_STRIDE)
    assert not first[peak]  # found by casting near the high samples
    # every seed at or above the share of the largest was cast, few below it
    assert search.cast[cusps >= SAMPLE_NEAR_SHARE].all()
    assert search.cast.sum() < 0.8 * len(cusps)
    assert search.cast[cusps < 0.25].sum() < 0.2 * (cusps < 0.25).sum()


def test_a_cast_above_the_horizon_casts_the_seeds_beside_it():
    # low cusps (0.1 of the largest: none high by its share) but a stretch above the
    # horizon, samples 96 and 104 among it: the seeds between them are cast for it alone
    cusps = np.full(200, 0.1)
    cusps[40] = 1.0  # the largest, on a sample
    cusps[94:107] = np.inf  # uncut: above the horizon
    search = KnownCusps(cusps)
    cast_beyond_estimates(search, np.full(200, np.nan), [np.ones(200, dtype=bool)],
                          ESTIMATE_TOP, ESTIMATE_TOP_MOST, passes=np.zeros(200, dtype=int))
    assert search.cast[97:104].all()
    assert not search.cast[150:190].all()  # (the low seeds away from both: samples only)


def test_without_casting_near_high_cusps_the_peak_is_missed(monkeypatch):
    # the check above can fail: with nothing counted high, the samples alone miss it
    monkeypatch.setattr(measure, "SAMPLE_NEAR_SHARE", np.inf)
    rng = np.random.default_rng(5)
    cusps, passes = _smooth_cusps(rng, 6, 400)
    _bump(cusps)
    search = KnownCusps(cusps)
    cast_beyond_estimates(search, np.full(len(cusps), np.nan),
                          [np.ones(len(cusps), dtype=bool)], ESTIMATE_TOP, ESTIMATE_TOP_MOST,
                          passes=passes)
    assert np.nanmax(search.height) < 1.0


def test_a_five_axis_flat_end_blade_job_reads_the_full_method_s_figures():
    # the standing dev blade under trunnion-ac, flat:6: many seeds have no estimate
    measured = standing_blade_job("flat:6", 0.2, 0.05)
    fast = measured.seeds()
    full = measured.seeds(estimate=False)
    without = np.isnan(fast.estimate_mm)
    assert without.mean() > 0.3
    assert fast.cast[without].sum() < 0.6 * without.sum()  # sampled, not all cast
    got, want = measure._scallop_result(fast), measure._scallop_result(full)
    assert got.max_mm == want.max_mm > 0.0
    assert got.interior_max_mm == want.interior_max_mm
    assert (got.t, got.s) == (want.t, want.s)
    # every seed cast reads as the full method's
    np.testing.assert_array_equal(fast.height_mm[fast.cast], full.height_mm[fast.cast])
    # the seeds left uncast stand well below the largest cusp (0.58 of it here): the
    # casts near the high ones took the high stretches
    assert np.nanmax(full.height_mm[~fast.cast]) < 0.9 * want.max_mm
