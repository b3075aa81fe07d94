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
from toolpath.periodic import closed_cut, period_of
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


def _closed_nose_dense_airfoil(chord=50.0, half_thickness=2.0, flank_radius=80.0,
                               le_radius=0.3, te_radius=0.15, nose_step=0.02,
                               flank_points=30):
    """A closed airfoil-like section: two flank arcs (radius 80 mm) joined G1 (not G2) by
    round LE and TE noses sampled ``nose_step`` apart, the flanks by cosine stations up to
    1.8 mm apart (spacing ratio 95). Upper flank TE -> LE, LE nose, lower flank, TE nose;
    the first point is not repeated. Returns the points and where each part starts."""
    d, mid = flank_radius - half_thickness, 0.5 * chord

    def nose_centre(r, side):
        return np.array([mid + side * np.sqrt((flank_radius - r) ** 2 - d**2), 0.0])

    def heading(frm, to):
        return np.arctan2(*(to - frm)[::-1])

    def arc(centre, radius, a0, a1, u):
        a = a0 + (a1 - a0) * u
        return centre + radius * np.c_[np.cos(a), np.sin(a)]

    le, te = nose_centre(le_radius, -1), nose_centre(te_radius, 1)
    upper_c, lower_c = np.array([mid, -d]), np.array([mid, d])
    cosine = 0.5 * (1 - np.cos(np.pi * np.linspace(0, 1, flank_points)))
    upper = arc(upper_c, flank_radius, heading(upper_c, te), heading(upper_c, le), cosine)
    lower = arc(lower_c, flank_radius, heading(lower_c, le), heading(lower_c, te), cosine)

    def nose(centre, r, a0, a1):
        a1 = a0 + np.mod(a1 - a0, 2 * np.pi)
        return arc(centre, r, a0, a1, np.linspace(0, 1, int(np.ceil((a1 - a0) * r
                                                                    / nose_step)) + 1))

    le_arc = nose(le, le_radius, heading(upper_c, le), heading(lower_c, le))
    te_arc = nose(te, te_radius, heading(lower_c, te), heading(upper_c, te))
    parts = [upper[:-1], le_arc[:-1], lower[:-1], te_arc[:-1]]
    loop = np.vstack(parts)
    starts = np.cumsum([0] + [len(p) for p in parts[:-1]])
    return np.c_[loop, 0.1 * loop[:, 0]] + [100.0, 20.0, 5.0], dict(
        zip(("upper", "le", "lower", "te"), starts.tolist(), strict=True))


class _DentedCircle:
    """A half circle (radius 50 mm) with an inward Gaussian dent of ``depth`` (mm) and
    width 0.1 mm at t = 0.5: concave at its bottom, convex elsewhere."""

    turn = np.pi  # the angle the circle turns over t in [0, 1]
    at = 0.5  # where the dent is

    def __init__(self, depth, params):
        self.depth, self.params = depth, params

    def _radius(self, t, order=0):
        w = 0.1 / (50.0 * self.turn)
        g = np.exp(-0.5 * ((t - self.at) / w) ** 2)
        dg = [g, -(t - self.at) / w**2 * g,
              (((t - self.at) / w**2) ** 2 - 1 / w**2) * g][order]
        return (50.0 if order == 0 else 0.0) - self.depth * dg

    def __call__(self, t):
        t = np.asarray(t, float)
        a = self.turn * t
        return self._radius(t)[:, None] * np.c_[np.cos(a), np.sin(a), 0 * a]

    def derivative(self, t, order=1):
        t = np.asarray(t, float)
        a, k = self.turn * t, self.turn
        e = np.c_[np.cos(a), np.sin(a), 0 * a]
        n = np.c_[-np.sin(a), np.cos(a), 0 * a]
        r, r1 = self._radius(t), self._radius(t, 1)
        if order == 1:
            return r1[:, None] * e + k * r[:, None] * n
        r2 = self._radius(t, 2)
        return ((r2 - k**2 * r)[:, None] * e + 2 * k * r1[:, None] * n)


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


def _seam_at(where):
    """The closed airfoil rolled so that its first point is ``where``."""
    points, starts = _closed_nose_dense_airfoil()
    te_mid = starts["te"] + (len(points) - starts["te"]) // 2
    first = {"on the TE nose": te_mid, "a few points after the TE": te_mid + 3,
             "at a nose-flank join": 2, "on a flank": (starts["upper"] + starts["le"]) // 2,
             "on the LE nose": (starts["le"] + starts["lower"]) // 2}[where]
    return np.roll(points, -first, axis=0)


SEAMS = ["on the TE nose", "a few points after the TE", "at a nose-flank join", "on a flank",
         "on the LE nose"]


@pytest.mark.parametrize("where", SEAMS)
@pytest.mark.parametrize("fit", FITTERS)
def test_closed_nose_dense_sections_fit_fair_wherever_the_seam_falls(fit, where):
    points = _seam_at(where)
    steps = np.linalg.norm(np.diff(np.vstack((points, points[:1])), axis=0), axis=1)
    assert steps.max() / steps.min() > 90  # the trait: noses 0.02 mm, flanks 1.8 mm apart
    curve = fit(points, tol=0.01, closed=True)
    fairness = curve_fairness(curve, points, closed=True)
    assert curve.closed and curve.max_error <= 0.01
    assert fairness.n_concave == 0, fairness.line()
    assert fairness.nose_error_mm <= 0.01


def test_the_knot_driver_cuts_a_closed_loop_where_its_data_are_sparse():
    for where in SEAMS:
        points = _seam_at(where)
        loop = np.vstack((points, points[:1]))
        length = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(loop, axis=0), axis=1))]
        t = length / length[-1]
        k = closed_cut(t)
        steps = np.diff(t)
        around = steps[(k - 1) % steps.size] + steps[k]
        if where == "on a flank":
            assert k == 0  # a seam on a flank is the cut
        elif where != "at a nose-flank join":  # on a nose: cut where the data are sparse
            assert k > 0 and around > 0.5 * np.max(steps + np.roll(steps, 1))
        assert closed_cut(t, seam=3) == 0  # a corner at the seam is the cut
        curve = fit_bspline_curve(points, n_control_points=20, closed=True)
        # the seam stays a knot and the count is the one asked for, wherever the cut
        assert curve.n_control_points == 20 and period_of(curve.knots)[0] == 0.0


def test_dca_rotor_with_its_seam_moved_along_the_te_nose_fits_fair():
    sections = [np.roll(np.asarray(p), -5, axis=0)
                for p in read_sections(bundled_data_path("dev_rotor_dca_11x181.csv"))]
    grid = as_sections(sections)
    assert grid.closed
    surface = fit_bspline_surface(grid, tol=0.01)
    fairness = surface_fairness(surface, grid.points)
    assert surface.max_error <= 0.01
    assert fairness.n_concave == 0, fairness.line()


def test_closed_curve_fairness_samples_round_the_seam():
    t = np.linspace(0.0, 1.0, 301)[:-1]  # a closed fit's parameters stop short of t = 1
    loop = _DentedLoop(0.0, t)
    assert curve_fairness(loop, loop(t), closed=True).n_concave == 0
    # a dent in the closing interval, between the last point and the first
    dented = _DentedLoop(0.005, t, at=0.5 * (t[-1] + 1.0))
    found = curve_fairness(dented, loop(t), closed=True)
    assert found.n_concave == 1 and found.deepest.t > t[-1]


class _DentedLoop(_DentedCircle):
    """A full circle (radius 50 mm) with an inward Gaussian dent of ``depth`` at ``at``."""

    turn = 2 * np.pi

    def __init__(self, depth, params, at=0.5):
        super().__init__(depth, params)
        self.at = at


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
