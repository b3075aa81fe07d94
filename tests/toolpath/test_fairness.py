"""Issue 23 item 2: fits fair between the data (no invented concave ripples at the noses)."""

import json
import warnings

import numpy as np
import pytest

from streamline_cam.cli import main
from toolpath import (
    as_sections,
    fit_bspline_curve,
    fit_bspline_surface,
    fit_streamline_curve,
    fit_streamline_surface,
    read_sections,
)
from toolpath.errors import ConvergenceWarning
from toolpath.fairness import (
    CONCAVE_DEPTH_MM,
    SAMPLES_PER_INTERVAL,
    curve_fairness,
    dense_parameters,
    surface_fairness,
)
from toolpath.paper_examples import bundled_data_path
from toolpath.parametrize import unit_curve_parameters
from toolpath.splinefit import clamped_knots

FITTERS = [fit_streamline_curve, fit_bspline_curve]


def _nose_dense_section(nose_radius=0.3, flank_radius=60.0, nose_step=0.02, flank_step=2.0):
    """An open airfoil-like section: a circular LE sampled ``nose_step`` apart, tangent to
    two flank arcs sampled ``flank_step`` apart (spacing ratio 100), TE side open."""
    tangent_deg = 100.0
    u = np.radians(tangent_deg)
    nose = np.linspace(u, 2 * np.pi - u, int(np.ceil((2 * np.pi - 2 * u) * nose_radius
                                                       / nose_step)) + 1)
    upper_centre = -(flank_radius - nose_radius) * np.array([np.cos(u), np.sin(u)])
    sweep = 40.0 / flank_radius
    flank = np.linspace(u - sweep, u, int(np.ceil(sweep * flank_radius / flank_step)) + 1)
    upper = upper_centre + flank_radius * np.c_[np.cos(flank), np.sin(flank)]
    lower = upper[::-1] * [1.0, -1.0]
    points = np.vstack((upper[:-1], nose_radius * np.c_[np.cos(nose), np.sin(nose)],
                        lower[1:]))
    return np.c_[points, np.zeros(len(points))] + [100.0, 20.0, 5.0]


class _DentedCircle:
    """A half circle (radius 50 mm) with an inward Gaussian dent of ``depth`` (mm) and
    width 0.1 mm at t = 0.5: concave at its bottom, convex elsewhere."""

    def __init__(self, depth, params):
        self.depth, self.params = depth, params

    def _radius(self, t, order=0):
        w = 0.1 / (50.0 * np.pi)
        g = np.exp(-0.5 * ((t - 0.5) / w) ** 2)
        dg = [g, -(t - 0.5) / w**2 * g, (((t - 0.5) / w**2) ** 2 - 1 / w**2) * g][order]
        return (50.0 if order == 0 else 0.0) - self.depth * dg

    def __call__(self, t):
        t = np.asarray(t, float)
        a = np.pi * t
        return self._radius(t)[:, None] * np.c_[np.cos(a), np.sin(a), 0 * a]

    def derivative(self, t, order=1):
        t = np.asarray(t, float)
        a = np.pi * t
        e = np.c_[np.cos(a), np.sin(a), 0 * a]
        n = np.c_[-np.sin(a), np.cos(a), 0 * a]
        r, r1 = self._radius(t), self._radius(t, 1)
        if order == 1:
            return r1[:, None] * e + np.pi * r[:, None] * n
        r2 = self._radius(t, 2)
        return ((r2 - np.pi**2 * r)[:, None] * e + 2 * np.pi * r1[:, None] * n)


def test_dense_parameters_are_twenty_times_denser_in_every_interval():
    t = np.array([0.0, 0.001, 0.5, 1.0])
    tt = dense_parameters(t)
    assert SAMPLES_PER_INTERVAL >= 20 and tt.size == 3 * SAMPLES_PER_INTERVAL + 1
    assert np.all(np.diff(tt) > 0) and tt[0] == 0.0 and tt[-1] == 1.0


def test_depth_of_a_known_dent_is_measured():
    t = np.linspace(0.0, 1.0, 601)
    data = _DentedCircle(0.0, t)(t)
    # the bridge over the dent rests on its shoulders, which the circle bends away: the
    # depth under it is most of a sharp dent and a fraction of a shallow one
    for depth, least in ((0.0005, 0.1), (0.005, 0.6)):
        fairness = curve_fairness(_DentedCircle(depth, t), data)
        assert fairness.deepest is not None
        assert abs(fairness.deepest.t - 0.5) < 0.0005
        assert least * depth <= fairness.deepest_mm <= depth
        assert fairness.n_concave == (fairness.deepest_mm > CONCAVE_DEPTH_MM)
        assert fairness.n_concave == (depth > CONCAVE_DEPTH_MM)
    assert curve_fairness(_DentedCircle(0.0, t), data).n_concave == 0


def test_data_that_turn_concave_are_not_counted():
    t = np.linspace(0.0, 1.0, 601)
    dented = _DentedCircle(0.005, t)
    assert curve_fairness(dented, _DentedCircle(0.0, t)(t)).n_concave == 1  # fit only
    inside = np.array([0.4996, 0.5, 0.5004])
    params = np.sort(np.r_[t, inside])
    data = dented(params)
    # where the data themselves dent, the fit's dent is the data's
    assert curve_fairness(_DentedCircle(0.005, params), data).n_concave == 0


@pytest.mark.parametrize("fit", FITTERS)
def test_ripple_on_bad_knots_is_found_and_the_tol_fit_is_fair(fit):
    points = _nose_dense_section()
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    assert steps.max() / steps.min() > 90  # the trait: nose 0.02 mm, flanks 2 mm apart
    # evenly spread knots: the nose falls inside a few long spans; the fit rings on the
    # flanks beside it and leaves the nose circle between the data
    bad = fit(points, knots=clamped_knots(np.linspace(0, 1, 17)[1:-1]), minimax=False)
    found = curve_fairness(bad, points)
    assert found.n_concave >= 1 and found.deepest_mm > 10 * CONCAVE_DEPTH_MM
    assert all(0.3 < s.t < 0.7 for s in found.stretches)  # beside the nose (0.37-0.63)
    assert found.nose_error_mm > 0.05
    with warnings.catch_warnings():
        warnings.simplefilter("error", ConvergenceWarning)
        good = fit(points, tol=0.01)
    fairness = curve_fairness(good, points)
    assert good.max_error <= 0.01
    assert fairness.n_concave == 0 and fairness.nose_error_mm <= 0.01


@pytest.mark.parametrize("name", ["dev_rotor_dca_11x181", "dev_prop_7x100",
                                  "dev_rotor_blunt_9x120"])
@pytest.mark.parametrize("fit", FITTERS)
def test_real_like_sections_fit_fair(name, fit):
    points = np.asarray(read_sections(bundled_data_path(f"{name}.csv"))[0])  # the hub
    curve = fit(points, tol=0.01)
    fairness = curve_fairness(curve, points)
    assert curve.max_error <= 0.01
    assert fairness.n_concave == 0, fairness.line()
    assert fairness.nose_error_mm <= 0.01


@pytest.mark.parametrize("name,fit", [
    ("dev_rotor_dca_11x181", fit_streamline_surface),
    ("dev_rotor_dca_11x181", fit_bspline_surface),
    ("dev_prop_7x100", fit_streamline_surface),
    ("dev_rotor_blunt_9x120", fit_bspline_surface),
])
def test_real_like_surfaces_fit_fair_on_and_between_sections(name, fit):
    grid = as_sections(read_sections(bundled_data_path(f"{name}.csv")))
    surface = fit(grid, tol=0.01)  # the matched sections as they are (a union grid: DCA)
    fairness = surface_fairness(surface, grid.points)
    assert surface.max_error <= 0.01
    assert fairness.n_concave == 0, fairness.line()
    assert fairness.nose_error_mm <= 0.01


def test_unfair_fit_without_the_mend_is_reported_by_section_and_t():
    sections = read_sections(bundled_data_path("dev_rotor_dca_11x181.csv"))
    # paired by index (the mean chord length per point, as before sections were matched;
    # matched, this fit is fair): the density seed alone (no error sweeps, no mend)
    # ripples beside the noses
    by_index = np.mean([unit_curve_parameters(np.vstack((p, p[:1]))) for p in sections], 0)
    grid = as_sections(sections, params=by_index)
    surface = fit_bspline_surface(grid, tol=0.01, fair=False, sweeps=0)
    fairness = surface_fairness(surface, grid.points)
    assert fairness.n_concave > 0
    [note] = [w for w in fairness.warnings(0.01) if w.startswith("unfair")]
    assert "section" in note and "t=" in note
    record = fairness.as_dict()
    assert record["concave_stretches"] == fairness.n_concave
    assert record["deepest"]["depth_mm"] == fairness.deepest_mm > CONCAVE_DEPTH_MM


def test_fit_reports_carry_fairness(capsys):
    src = bundled_data_path("dev_half_profile_71.csv")
    assert main(["fit", "curve", str(src), "--method", "bspline"]) == 0
    text = capsys.readouterr().out
    assert "fairness          0 concave stretches > 1 um (deepest" in text
    assert "noses             " in text
    assert main(["fit", "surface", str(bundled_data_path("dev_blade_15x142.csv")),
                 "--method", "bspline", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["fairness"]["concave_stretches"] == 0
    assert set(report["fairness"]) >= {"deepest_mm", "nose_error_mm", "summary", "stretches"}
