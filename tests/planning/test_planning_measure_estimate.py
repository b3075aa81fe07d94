"""The ball's cusp estimate from the passes' own geometry against the full ray cast.

``measure_scallop`` estimates every seed's cusp from two centre segments and ray-casts
only the seeds near the largest; ``estimate=False`` ray-casts every seed (the full
method, the oracle here). Both must report the same scallop, and the estimate itself must
stand within a few per cent of the ray cast seed by seed.
"""

import numpy as np
import pytest

import toolpath.planning.finishing as finishing
import toolpath.planning.measure as measure
from machines import load_machine
from toolpath import fit_streamline_surface
from toolpath.paper_examples import bundled_data_path
from toolpath.planning import SpherePatch, plan_finishing
from toolpath.planning.setup import centred_on_table, rotation_from_spec


@pytest.fixture(scope="module")
def blade():
    rows = np.loadtxt(bundled_data_path("dev_blade_15x142.csv"), delimiter=",", skiprows=1)
    sections = rows[:, 1:].reshape(15, 142, 3)[::2]  # every other section: a shorter fit
    return fit_streamline_surface(sections, tol=0.01, closed=False)


#: The estimate decides on small plans too, ray casting only the 16 largest.
FEW_RAYS = {"estimate_min_seeds": 0, "estimate_top": 16, "estimate_top_share": 0.0}


def _measured_inputs(monkeypatch, surface, cutter, **options):
    """Plan with the measurement on, keeping what ``measure_scallop`` was given."""
    seen = {}

    def keep(*args, **kwargs):
        seen["args"], seen["kwargs"] = args, kwargs
        return measure.measure_scallop(*args, **kwargs)

    monkeypatch.setattr(finishing, "measure_scallop", keep)
    plan_finishing(surface, cutter, **options)
    return seen["args"], seen["kwargs"]


def _same_scallop(args, kwargs):
    fast = measure.measure_scallop(*args, **kwargs, estimate=True, **FEW_RAYS)
    full = measure.measure_scallop(*args, **kwargs, estimate=False)
    assert full.n_cast == full.n_samples
    assert fast.n_cast < 0.9 * fast.n_samples  # the estimate did decide where to cast
    assert fast.max_mm == pytest.approx(full.max_mm, rel=0.02)
    assert fast.interior_max_mm == pytest.approx(full.interior_max_mm, rel=0.02)
    assert fast.uncut_fraction == full.uncut_fraction
    assert full.max_mm > 0.0
    return fast, full


def test_sphere_cap_three_and_five_axis(monkeypatch):
    cap = SpherePatch(radius_mm=50.0, longitude_deg=(-20.0, 20.0), colatitude_deg=(15.0, 40.0))
    for axis in ({"axis_mode": "3"}, {"axis_mode": "lead-tilt", "lead_deg": 10.0}):
        _same_scallop(*_measured_inputs(monkeypatch, cap, "ball:6", scallop_mm=0.02,
                                        chord_tol_mm=0.02, **axis))


def test_blade_lying_with_uncut_areas(monkeypatch, blade):
    lying = centred_on_table(blade, rotation_from_spec("x:90"), base_height_mm=0.0)
    fast, _ = _same_scallop(*_measured_inputs(monkeypatch, lying, "ball:10", scallop_mm=0.06,
                                              chord_tol_mm=0.03, axis_mode="3"))
    assert fast.uncut_fraction > 0.1  # the far side: interior and overall maxima differ


def test_blade_standing_under_joint_interpolation(monkeypatch, blade):
    standing = centred_on_table(blade, rotation_from_spec("y:-90"))
    args, kwargs = _measured_inputs(monkeypatch, standing, "ball:6", scallop_mm=0.03,
                                    chord_tol_mm=0.03, axis_mode="lead-tilt", lead_deg=10.0,
                                    machine=load_machine("trunnion-ac"))
    _same_scallop(args, kwargs)


def _estimates_over_ray_cast(monkeypatch, surface, **options):
    """Each seed's estimate over its ray cast cusp, where both stand and the cusp is high.

    (Cusps above half the largest, away from the passes' ends.)
    """
    args, kwargs = _measured_inputs(monkeypatch, surface, "ball:6", **options)
    seen = {}
    real_estimates, real_cusps = measure._ball_cusp_estimates, measure._cusps

    def estimates(*a, **k):
        seen["guess"] = real_estimates(*a, **k)
        seen["t"], seen["s"] = a[2].t, a[2].s
        return seen["guess"]

    def cusps(volume, surface, t, s0, s1, own):
        h, s = real_cusps(volume, surface, t, s0, s1, own)
        seen.setdefault("cast", []).append((t, s0, h))
        return h, s

    monkeypatch.setattr(measure, "_ball_cusp_estimates", estimates)
    monkeypatch.setattr(measure, "_cusps", cusps)
    measure.measure_scallop(*args, **kwargs, estimate=True, **FEW_RAYS)
    seen.pop("cast")
    measure.measure_scallop(*args, **kwargs, estimate=False)
    t, s0, h = (np.concatenate(c) for c in zip(*seen["cast"], strict=True))
    full = dict(zip(zip(t.tolist(), s0.tolist(), strict=True), h.tolist(), strict=True))
    guess = seen["guess"]
    h = np.array([full.get(key, np.nan)
                  for key in zip(seen["t"].tolist(), seen["s"].tolist(), strict=True)])
    both = np.isfinite(guess) & np.isfinite(h) & (h > 0.5 * np.nanmax(h))
    # at the passes' ends (the patch's edges t = 0, 1) the nearest pieces are the links',
    # and the estimate reads the ridge as sunk (below the ray cast, which a dense scan of
    # those brackets confirms): the interior's cusps, as high, are cast there
    both &= (seen["t"] > 1e-9) & (seen["t"] < 1.0 - 1e-9)
    assert both.sum() > 100
    return guess[both] / h[both]


def test_the_estimate_stands_near_the_ray_cast_seed_by_seed(monkeypatch):
    cap = SpherePatch(radius_mm=50.0, longitude_deg=(-20.0, 20.0), colatitude_deg=(15.0, 40.0))
    ratio = _estimates_over_ray_cast(monkeypatch, cap, scallop_mm=0.02, chord_tol_mm=0.02,
                                     axis_mode="3")
    assert np.median(ratio) == pytest.approx(1.0, abs=0.05)
    assert ratio.min() > 0.95  # the share the ray cast is asked for leaves room


def test_the_estimate_sinks_the_ridge_by_half_as_the_passes_curve(monkeypatch):
    # on a large sphere in 5 axes the ridge between two passes' nearest segments lies
    # inside their neighbouring pieces (the passes curve) by about a seventh of its
    # height; the crossing of the two sides sinks by half of that: reading it whole, or
    # not at all, puts the estimate 6 % off the ray cast, over the share the cast is
    # asked for (ESTIMATE_SHARE), and most seeds are cast
    dome = SpherePatch(radius_mm=150.0, longitude_deg=(-6.0, 6.0),
                       colatitude_deg=(50.0, 60.0))
    ratio = _estimates_over_ray_cast(monkeypatch, dome, scallop_mm=0.005, chord_tol_mm=0.01,
                                     axis_mode="lead-tilt", lead_deg=10.0)
    low, high = np.quantile(ratio, [0.05, 0.95])
    assert low > 0.98 and high < 1.02
    assert ratio.max() < measure.ESTIMATE_SHARE


@pytest.mark.parametrize(("cutter", "request_mm", "brackets", "axis"), [
    ("ball:6", 0.02, 12, {"axis_mode": "3"}),
    ("ball:6", 0.02, 12, {"axis_mode": "lead-tilt", "lead_deg": 10.0}),
    # a bull-nose's pieces are the cutter solid over their poses (sweep_kernel's exact
    # entries and pose search), no capsules: the same search over other heights (fewer
    # brackets: each ray of the scan meets many more pieces)
    ("bull:8:1", 0.05, 6, {"axis_mode": "3"}),
    ("bull:8:1", 0.05, 6, {"axis_mode": "lead-tilt", "lead_deg": 10.0}),
])
def test_the_cusp_search_finds_the_crest_a_dense_scan_finds(monkeypatch, cutter, request_mm,
                                                             brackets, axis):
    # the Illinois search (toolpath.planning.roots) on each bracket against the highest
    # min(h_own, h_other) over 2001 points of it: the crest of the machined surface
    cap = SpherePatch(radius_mm=50.0, longitude_deg=(-20.0, 20.0), colatitude_deg=(15.0, 40.0))
    args, _ = _measured_inputs(monkeypatch, cap, cutter, scallop_mm=request_mm,
                               chord_tol_mm=0.02, **axis)
    path, surface, cutter, request, chord = args
    volume = measure._CutVolume(path, cutter, max(10.0 * request, 0.05), request)
    rng = np.random.default_rng(7)
    rows = rng.choice(np.flatnonzero(chord.seeds_s < 0.9), brackets, replace=False)
    t, s0, own = chord.seeds_t[rows], chord.seeds_s[rows], chord.seeds_pass[rows]
    s1 = np.minimum(s0 + 0.15, 1.0)
    h, s = measure._cusps(volume, surface, t, s0, s1, own)
    found = np.isfinite(h)
    assert found.sum() >= 2 * brackets // 3
    for i in np.flatnonzero(found):
        grid = np.linspace(s0[i], s1[i], 2001)
        x, n = surface.points_and_normals(np.full(grid.size, t[i]), grid)
        owner, item = volume.pairs(x)
        mine = volume.pass_of[item] == own[i]
        h_own = volume.height(x, n, *measure.ray_ranges(owner[mine], item[mine], grid.size))
        h_other = volume.height(x, n, *measure.ray_ranges(owner[~mine], item[~mine],
                                                          grid.size))
        low = np.minimum(h_own, h_other)
        # the first crossing from the seed: where the own pass stops standing lower
        cross = int(np.argmax(h_own > h_other))
        crest = low[max(cross - 1, 0):cross + 1].max()
        assert h[i] == pytest.approx(crest, rel=0.01, abs=1e-3 * request)
        assert abs(s[i] - grid[cross]) <= 2.0 * (grid[1] - grid[0])


@pytest.mark.parametrize(("cutter", "request_mm"), [("ball:6", 0.02), ("bull:8:1", 0.05)])
def test_the_uncut_test_stops_at_the_first_entry_as_the_full_entries_say(monkeypatch, cutter,
                                                                         request_mm):
    # _CutVolume.cut stops each ray at the first piece it enters within the horizon: the
    # same rays cut as the lowest entries over all their pieces say, near the passes and
    # off the patch's edges (rays that enter only beyond the horizon stay uncut)
    cap = SpherePatch(radius_mm=50.0, longitude_deg=(-20.0, 20.0), colatitude_deg=(15.0, 40.0))
    args, _ = _measured_inputs(monkeypatch, cap, cutter, scallop_mm=request_mm,
                               chord_tol_mm=0.02, axis_mode="lead-tilt", lead_deg=10.0)
    path, surface, cutter, request, _ = args
    volume = measure._CutVolume(path, cutter, max(10.0 * request, 0.05), request)
    g = np.linspace(-0.05, 1.05, 41)
    t, s = (a.ravel() for a in np.meshgrid(np.clip(g, 0.0, 1.0), g, indexing="ij"))
    q, n = surface.points_and_normals(t, np.clip(s, 0.0, 1.0))
    q = q + np.where(s > 1.0, 3.0, np.where(s < 0.0, -3.0, 0.0))[:, None] * n  # off the sheet
    full = np.isfinite(volume.height(q, n, *measure.ray_ranges(*volume.pairs(q), len(q))))
    got = volume.cut(q, n)
    np.testing.assert_array_equal(got, full)
    assert 0 < full.sum() < len(full)
