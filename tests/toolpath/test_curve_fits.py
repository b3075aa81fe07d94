import importlib
import json
from pathlib import Path

import numpy as np
import pytest
import scipy.interpolate
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from toolpath import (
    BSplineCurve,
    StreamlineCurve,
    curve_from_dict,
    fit_bspline_curve,
    fit_streamline_curve,
)
from toolpath.knots import detect_corners, fourth_derivative_density, place_knots
from toolpath.paper_examples import bundled_data_path, example4, example5
from toolpath.parametrize import unit_curve_parameters
from toolpath.pointio import read_points

FITTERS = [fit_streamline_curve, fit_bspline_curve]


def _half_profile():
    return read_points(bundled_data_path("dev_half_profile_71.csv"))


# Paper Tables 4 and 5: max error at 44 / 30 control points (B-spline, Algorithm 3).
@pytest.mark.parametrize("example,count,paper_bspline,paper_streamline",
                         [(example4, 44, 0.0576, 0.0508), (example5, 30, 0.0353, 0.0289)])
def test_paper_examples_at_or_below_paper_error_with_paper_counts(example, count,
                                                                  paper_bspline,
                                                                  paper_streamline):
    points = example()
    bspline = fit_bspline_curve(points, n_control_points=count)
    streamline = fit_streamline_curve(points, n_control_points=count)
    assert bspline.n_control_points <= count and streamline.n_control_points <= count
    assert bspline.max_error <= paper_bspline
    assert streamline.max_error <= paper_streamline


@pytest.mark.parametrize("fit", FITTERS)
def test_end_points_interpolated_exactly(fit):
    points = _half_profile()
    curve = fit(points, tol=0.01)
    scale = np.abs(points).max()
    assert np.abs(curve(0.0) - points[0]).max() <= 1e-12 * scale
    assert np.abs(curve(1.0) - points[-1]).max() <= 1e-12 * scale


@pytest.mark.parametrize("fit", FITTERS)
@pytest.mark.parametrize("points", [_half_profile(), example5()], ids=["3d", "2d"])
def test_derivatives_match_finite_differences(fit, points):
    curve = fit(points, tol=0.01, corner_angle_deg=None)
    t = np.linspace(0.05, 0.95, 13)
    h = 1e-5
    d1 = (curve(t + h) - curve(t - h)) / (2 * h)
    d2 = (curve(t + h) - 2 * curve(t) + curve(t - h)) / h**2
    scale1 = np.abs(d1).max()
    np.testing.assert_allclose(curve.derivative(t), d1, atol=1e-6 * scale1)
    np.testing.assert_allclose(curve.derivative(t, order=2), d2,
                               atol=2e-3 * np.abs(d2).max())


def test_streamline_derivative_is_the_system_rhs():
    curve = fit_streamline_curve(_half_profile(), tol=0.01)
    t = np.linspace(0, 1, 9)
    rhs = np.einsum("ij,njk,kl,nl->ni", np.linalg.inv(curve.T), curve.D(t), curve.T,
                    curve(t) + curve.c)
    np.testing.assert_allclose(curve.derivative(t), rhs, rtol=1e-10, atol=1e-10)
    assert np.allclose(curve.G(0.0), 0.0)


@pytest.mark.parametrize("fit", FITTERS)
def test_fit_within_tol_reports_true_errors(fit):
    points = _half_profile()
    curve = fit(points, tol=0.002)
    errors = np.linalg.norm(curve(curve.params) - points, axis=1)
    assert curve.max_error <= 0.002
    assert curve.max_error == pytest.approx(errors.max(), rel=1e-9)
    assert curve.rms_error == pytest.approx(np.sqrt(np.mean(errors**2)), rel=1e-9)


def test_same_knots_bspline_matches_dense_lstsq():
    points = example5(301)
    ref = fit_bspline_curve(points, n_control_points=20)
    curve = fit_bspline_curve(points, knots=ref.knots, minimax=False)
    t = curve.params
    # dense design matrix from first principles: each basis function as its own spline
    n_coef = len(ref.knots) - 4
    design = np.column_stack([
        scipy.interpolate.BSpline(ref.knots, np.eye(n_coef)[j], 3)(t) for j in range(n_coef)])
    rhs = points - np.outer(design[:, 0], points[0]) - np.outer(design[:, -1], points[-1])
    inner = np.linalg.lstsq(design[:, 1:-1], rhs, rcond=None)[0]
    expected = np.vstack([points[0], inner, points[-1]])
    np.testing.assert_allclose(curve.control_points, expected, atol=1e-9)


def test_same_knots_streamline_matches_dense_lstsq_in_log_space():
    points = _half_profile()
    ref = fit_streamline_curve(points, n_control_points=12)
    curve = fit_streamline_curve(points, knots=ref.knots, minimax=False)
    z = (points + curve.c) @ curve.T.T
    y = np.log(z / z[0])
    n_coef = len(ref.knots) - 4
    design = np.column_stack([
        scipy.interpolate.BSpline(ref.knots, np.eye(n_coef)[j], 3)(curve.params)
        for j in range(n_coef)])
    rhs = y - np.outer(design[:, -1], y[-1])
    inner = np.linalg.lstsq(design[:, 1:-1], rhs, rcond=None)[0]
    np.testing.assert_allclose(curve.g_coefficients[1:-1], inner, atol=1e-9)
    np.testing.assert_allclose(curve.g_coefficients[-1], y[-1], atol=1e-12)


def test_both_methods_fit_identical_knots():
    points = example4()
    stream = fit_streamline_curve(points, n_control_points=44)
    bspline = fit_bspline_curve(points, knots=stream.knots)
    assert np.array_equal(bspline.knots, stream.knots)
    assert bspline.n_control_points == stream.n_control_points


@pytest.mark.parametrize("cls,fit", [(StreamlineCurve, fit_streamline_curve),
                                     (BSplineCurve, fit_bspline_curve)])
def test_json_round_trip_is_identical(cls, fit):
    curve = fit(example5(), tol=0.01)
    back = curve_from_dict(json.loads(json.dumps(curve.to_dict())))
    assert isinstance(back, cls)
    t = np.linspace(0, 1, 101)
    assert np.array_equal(back(t), curve(t))
    assert np.array_equal(back.derivative(t, 2), curve.derivative(t, 2))
    assert back.max_error == curve.max_error and back.n_control_points == curve.n_control_points


def _circle(n, center, radius=40.0, turns=1.0):
    s = np.linspace(0, 2 * np.pi * turns, n)
    return np.c_[np.cos(s), np.sin(s)] * radius + center


@pytest.mark.parametrize("points", [
    _circle(200, (0.0, 0.0), turns=0.98),          # around the origin
    _circle(200, (40.0, 0.0), turns=0.98),          # through the origin
    np.c_[np.linspace(-30, 30, 50), np.linspace(-10, 10, 50), np.linspace(5, -5, 50)],
    example4(),                                     # closed, starts and ends at the origin
], ids=["around-origin", "through-origin", "3d-line-through-origin", "ex4"])
def test_curves_around_and_through_the_origin_fit_within_tol(points):
    curve = fit_streamline_curve(points, tol=0.01)
    assert curve.max_error <= 0.01
    z = (points + curve.c) @ curve.T.T
    assert (z > 0).all()


def test_corners_of_paper_examples_detected_where_they_are():
    x4, x5 = example4(), example5()
    c4 = detect_corners(x4, unit_curve_parameters(x4))
    c5 = detect_corners(x5, unit_curve_parameters(x5))
    assert [c.index for c in c4] == [330, 670]
    assert all(abs(c.angle_deg - 63.5) < 1.0 for c in c4)
    assert len(c5) == 1 and abs(c5[0].angle_deg - 19.7) < 1.0
    # Ex 5's corner lies between samples 492 and 493 (NURBS parameter 0.33 of [0, 0.67])
    t5 = unit_curve_parameters(x5)
    assert t5[492] < c5[0].t < t5[493]


def test_dominant_point_rule_runs_the_papers_algorithm():
    points = _half_profile()
    curve = fit_streamline_curve(points, tol=0.01, knot_method="dominant", frame="paper")
    assert curve.max_error <= 0.01
    assert np.allclose(curve.c, 0.0)  # the half profile lies in one octant: T = I, c = 0


@st.composite
def smooth_curves(draw):
    seed = draw(st.integers(0, 2**31 - 1))
    rng = np.random.default_rng(seed)
    dim = draw(st.sampled_from([2, 3]))
    s = np.linspace(0.0, 1.0, draw(st.integers(60, 300)))
    coef = rng.normal(size=(4, dim)) * 20.0 / np.arange(1, 5)[:, None] ** 2
    phase = rng.uniform(0, 2 * np.pi, size=(4, dim))
    pts = sum(coef[k] * np.sin((k + 1) * np.pi * s[:, None] + phase[k]) for k in range(4))
    pts = pts + rng.normal(size=dim) * 30.0 + 60.0 * s[:, None] * rng.normal(size=dim)
    return pts


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(smooth_curves())
def test_random_smooth_curves_fit_within_tol(points):
    for fit in FITTERS:
        curve = fit(points, tol=0.01)
        assert curve.max_error <= 0.01
        assert np.linalg.norm(curve(curve.params) - points, axis=1).max() <= 0.01 + 1e-12


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**31 - 1), st.integers(1, 3))
def test_random_corners_are_detected_and_fit(seed, n_corners):
    rng = np.random.default_rng(seed)
    # smooth arcs joined at corners of 30-90 degrees
    pieces, heading, start = [], 0.0, np.zeros(2)
    for k in range(n_corners + 1):
        bend = rng.uniform(-0.8, 0.8)
        s = np.linspace(0, 1, 80)[(1 if k else 0):]
        angle = heading + bend * s
        step = np.c_[np.cos(angle), np.sin(angle)] * (30.0 / 80)
        piece = start + np.cumsum(step, axis=0)
        pieces.append(piece)
        start = piece[-1]
        heading = angle[-1] + rng.choice([-1, 1]) * np.radians(rng.uniform(30, 90))
    points = np.vstack(pieces)
    t = unit_curve_parameters(points)
    assert len(detect_corners(points, t)) == n_corners
    for fit in FITTERS:
        assert fit(points, tol=0.01).max_error <= 0.01


# Issue 23: the streamline fit within 0.015 / 0.010 mm at the paper's counts (paper: 0.0508 /
# 0.0289). The B-spline's figures before the per-piece knot shares, the corner-free f''''
# seed and the RMS sweeps were 0.0406 mm (Ex 4, 44 CPs) and 0.0201 mm (Ex 5, 30 CPs); the
# same machinery must not make them worse.
BSPLINE_BEFORE_MM = {"Ex 4": 0.0406, "Ex 5": 0.0201}


def test_paper_targets_met_and_printed_beside_the_bspline(monkeypatch, capsys):
    benchmarks = Path(__file__).resolve().parents[2] / "benchmarks"
    monkeypatch.syspath_prepend(str(benchmarks))
    tables = importlib.import_module("paper_tables")
    rows = tables.paper_target_rows()
    assert [row[0] for row in rows] == ["Ex 4", "Ex 5"]
    for label, count, streamline, target, paper, bspline in rows:
        assert (count, target) == {"Ex 4": (44, 0.015), "Ex 5": (30, 0.010)}[label]
        assert streamline <= target < paper
        assert bspline <= BSPLINE_BEFORE_MM[label]
    for example, count in ((example4, 44), (example5, 30)):
        assert fit_streamline_curve(example(), n_control_points=count).n_control_points == count
    tables.paper_targets()
    out = capsys.readouterr().out
    assert "Ex 4 @44 CPs: streamline" in out and "B-spline" in out and "NOT MET" not in out


def _arcs_with_corner():
    """Two arcs (R 50 mm, R 15 mm) meeting at a 40 degree corner, 200 samples."""
    s = np.linspace(0.0, 1.0, 100)
    first = 50.0 * np.c_[np.sin(s), 1.0 - np.cos(s)]
    heading = 1.0 + np.radians(40.0)
    centre = first[-1] + 15.0 * np.array([-np.sin(heading), np.cos(heading)])
    angle = heading - np.pi / 2 + 1.5 * s[1:]
    second = centre + 15.0 * np.c_[np.cos(angle), np.sin(angle)]
    return np.vstack((first, second))


def test_corner_jump_does_not_crowd_the_spans_beside_it():
    points = _arcs_with_corner()
    t = unit_curve_parameters(points)
    corners = detect_corners(points, t)
    assert len(corners) == 1
    flat = (np.array([0.0, 1.0]), np.ones(1))
    knots = place_knots(t, corners, *flat, 20)
    spline = scipy.interpolate.make_lsq_spline(t, points, knots, k=3)
    edges, density = fourth_derivative_density(spline.t, spline.c)
    j = int(np.searchsorted(edges, corners[0].t))  # edges[j] is the corner
    beside = density[[j - 1, j]]
    away = np.r_[density[j - 3:j - 1], density[j + 1:j + 3]]
    assert beside.max() <= 2.0 * away.max()


def test_knots_are_shared_among_pieces_by_mass_and_counted_exactly():
    points = _arcs_with_corner()
    t = unit_curve_parameters(points)
    corners = detect_corners(points, t)
    # a density twice as heavy on the second piece: it gets about twice the spans
    edges = np.array([0.0, corners[0].t, 1.0])
    density = np.array([1.0, 2.0 * corners[0].t / (1.0 - corners[0].t)])
    knots = place_knots(t, corners, edges, density, 22)
    inner = knots[4:-4]
    assert inner.size == 22 + 3
    assert np.count_nonzero(inner == corners[0].t) == 3
    first = np.count_nonzero(inner < corners[0].t) + 1
    second = np.count_nonzero(inner > corners[0].t) + 1
    assert (first, second) == (8, 16)


def _polyline_turning(turns_deg, step_mm=0.5):
    """An open polyline of equal steps turning by ``turns_deg`` at its interior samples."""
    heading = np.concatenate(([0.0], np.cumsum(np.radians(turns_deg))))
    steps = step_mm * np.c_[np.cos(heading), np.sin(heading)]
    return np.vstack(([0.0, 0.0], np.cumsum(steps, axis=0)))


def test_a_round_nose_whose_turns_ramp_up_is_no_corner():
    # the propeller's LE sampled at steps near its radius: 14, 25, 38, 32, 16 deg (its
    # pair, 70 deg, is 5x the turns two steps away); a C0 knot there creased the surface
    flank = [1.0] * 12
    nose = [*flank, 2.0, 4.0, 8.0, 14.0, 25.0, 38.0, 32.0, 16.0, 8.0, 4.0, 2.0, *flank]
    points = _polyline_turning(nose)
    assert detect_corners(points, unit_curve_parameters(points)) == []
    corner = [*flank, 1.0, 1.0, 1.0, 2.0, 2.0, 70.0, 2.0, 2.0, 1.0, 1.0, 1.0, *flank]
    points = _polyline_turning(corner)
    found = detect_corners(points, unit_curve_parameters(points))
    assert [c.index for c in found] == [18] and abs(found[0].angle_deg - 70.0) < 1e-6


def _elliptic_nose_section(vertex_radius_mm, n_round, aspect, flank_step_mm):
    """Straight flanks 30 mm long either side of a half ellipse (semi-axes ``aspect`` and
    ``aspect²`` times the vertex radius, so its vertex circle is ``vertex_radius_mm``)
    sampled ``n_round`` points round at even arc length; ``aspect`` 1 is a circle."""
    b = vertex_radius_mm * aspect
    a = b * aspect
    theta = np.linspace(0.0, np.pi, 4001)
    arc = np.c_[-a * np.sin(theta), b * np.cos(theta)]
    s = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(arc, axis=0), axis=1))))
    nose = arc[np.searchsorted(s, np.linspace(0.0, s[-1], n_round)).clip(0, theta.size - 1)]
    x = flank_step_mm * np.arange(1, int(30.0 / flank_step_mm) + 1)
    return np.vstack((np.c_[x[::-1], np.full(x.size, b)], nose, np.c_[x, np.full(x.size, -b)]))


@pytest.mark.parametrize("radius_mm", [0.1, 0.2, 0.3])
@pytest.mark.parametrize("n_round", [6, 7, 8, 10, 15, 20])
def test_a_thin_round_or_elliptic_nose_is_no_corner(radius_mm, n_round):
    # its largest turns (14, 55, 55, 14 deg on a 4:1 ellipse sampled 20 points round) stand
    # 4-8x above their neighbours, but the neighbours continue the arc those turns imply;
    # 6-8 points round a 4:1 ellipse (9, 78, 78, 9 deg) ramp up to them on both sides
    for aspect in (1.0, 2.5, 3.0, 4.0):
        for flank_step_mm in (0.5, 2.0, 5.0):
            points = _elliptic_nose_section(radius_mm, n_round, aspect, flank_step_mm)
            assert detect_corners(points, unit_curve_parameters(points)) == [], \
                (aspect, flank_step_mm)


@pytest.mark.parametrize("angle_deg", [20.0, 45.0, 90.0, 135.0])
def test_a_corner_between_samples_or_at_one_stays_a_corner(angle_deg):
    # two straight or gently curved sides meeting at a sample or between two (the chord
    # across the corner turns too), unequal steps either side; Ex 4 and Ex 5 keep theirs
    for step_in, step_out in ((0.1, 0.5), (0.5, 0.5), (2.0, 0.5), (0.5, 2.0)):
        for fraction in (0.0, 0.25, 0.5):
            for radius_mm in (None, 100.0):
                heading = np.radians(angle_deg)
                s_in = step_in * np.arange(25, -1, -1) + fraction * step_in
                s_out = step_out * np.arange(26) + (1.0 - fraction) * step_out
                bend = 0.0 if radius_mm is None else 1.0 / radius_mm
                incoming = np.c_[-s_in, -0.5 * bend * s_in**2]
                out_dir = np.array([np.cos(heading), np.sin(heading)])
                out_normal = np.array([-out_dir[1], out_dir[0]])
                outgoing = (s_out[:, None] * out_dir
                            + (0.5 * bend * s_out**2)[:, None] * out_normal)
                points = np.vstack((incoming, outgoing if fraction else outgoing[1:]))
                found = detect_corners(points, unit_curve_parameters(points))
                assert len(found) == 1, (step_in, step_out, fraction, radius_mm)
                # (a corner read at one sample reports that sample's turn: >= 85 %)
                assert 0.8 * angle_deg < found[0].angle_deg < 1.1 * angle_deg
    for example, count in ((example4, 2), (example5, 1)):
        points = example()
        assert len(detect_corners(points, unit_curve_parameters(points))) == count


def test_turns_ramping_up_on_both_sides_are_a_nose_a_jump_above_its_sides_a_corner():
    flank = [0.0] * 12
    # a 4:1 elliptic nose 6 points round: the turns beside the peak ramp up to it
    points = _polyline_turning([*flank, 3.2, 9.3, 77.6, 77.4, 9.3, 3.2, *flank], 0.3)
    assert detect_corners(points, unit_curve_parameters(points)) == []
    # the same peak on sides turning at their own level (3 deg a sample), or ramping on
    # one side only, or far too gently for it: corners
    for sides in (([3.0] * 4, [3.0] * 4), ([0.0, 0.0, 3.2, 9.3], [0.0] * 4),
                  ([0.0, 0.0, 0.5, 1.0], [1.0, 0.5, 0.0, 0.0])):
        points = _polyline_turning([*flank, *sides[0], 77.6, 77.4, *sides[1], *flank], 0.3)
        found = detect_corners(points, unit_curve_parameters(points))
        assert len(found) == 1 and abs(found[0].angle_deg - 155.0) < 1.0, sides


@pytest.mark.parametrize("roll", [0, 14, 16, 18, 20, 36, 38, 40])
def test_a_closed_section_with_thin_noses_has_no_corner_round_its_seam(roll):
    # a closed thin section: a 4:1 elliptic nose 6 points round at either end of straight
    # flanks, opened anywhere (the seam in a nose reads turns across it)
    one = _elliptic_nose_section(0.1, 6, 4.0, 2.0)  # flanks at x = 2 ... 30 mm, 15 each
    nose = one[15:21]
    other = np.c_[32.0 - nose[:, 0], -nose[:, 1]]  # the same nose turned round at x = 32
    loop = np.roll(np.vstack((one, other)), roll, axis=0)
    loop = np.vstack((loop, loop[:1]))
    assert detect_corners(loop, unit_curve_parameters(loop)) == []


def test_stacked_sections_read_a_thin_nose_and_a_corner_alike():
    # surface fits look for corners on the sections stacked side by side, (n, 3 m)
    def stacked(section):
        rows = [np.c_[section * scale, np.full(len(section), z)]
                for scale, z in ((1.0, 0.0), (1.2, 20.0), (1.5, 40.0))]
        return np.hstack(rows)

    nose = stacked(_elliptic_nose_section(0.1, 6, 4.0, 2.0))
    assert detect_corners(nose, unit_curve_parameters(nose)) == []
    flank = [0.0] * 12
    wedge = stacked(_polyline_turning([*flank, 1.0, 1.0, 150.0, 1.0, 1.0, *flank]))
    found = detect_corners(wedge, unit_curve_parameters(wedge))
    assert [c.index for c in found] == [15]


def _clustered_flank(n_points=142, length_mm=60.0, bend_per_mm=0.02):
    """An open, gently bent flank (3-D) whose stations cluster cosine-wise at both ends:
    the last step about 30 um, the middle ones about 0.7 mm (a measured open edge)."""
    u = 0.5 * (1.0 - np.cos(np.linspace(0.0, np.pi, n_points)))
    x = length_mm * u
    return np.c_[x, 0.5 * bend_per_mm * (x - 0.5 * length_mm) ** 2, 0.1 * x]


@pytest.mark.parametrize("seed", range(6))
def test_scattered_points_clustered_at_an_open_end_read_no_corner(seed):
    # 3 um of scatter turns samples 30 um apart by up to 25 deg, 4x their neighbours 60-
    # 160 um apart: a blade's measured open trailing edge read a corner there, its double
    # knot curled the fit's edge (curvature 17/mm) and the cutter gouged 1.6 mm
    points = _clustered_flank()
    rng = np.random.default_rng(seed)
    noisy = points + rng.normal(0.0, 0.003, points.shape)
    assert detect_corners(noisy, unit_curve_parameters(noisy)) == []
    # the same flank with a real corner of 30 deg in the middle keeps it
    bent = points.copy()
    mid = len(points) // 2
    turn = np.radians(30.0)
    rel = bent[mid:] - bent[mid]
    rotation = np.array([[np.cos(turn), -np.sin(turn), 0.0], [np.sin(turn), np.cos(turn), 0.0],
                         [0.0, 0.0, 1.0]])
    bent[mid:] = bent[mid] + rel @ rotation.T
    noisy = bent + rng.normal(0.0, 0.003, bent.shape)
    found = detect_corners(noisy, unit_curve_parameters(noisy))
    assert [c.index for c in found] == [mid]


@pytest.mark.parametrize("seed", range(6))
def test_a_scattered_wedge_at_the_seam_keeps_its_corner(seed):
    # a closed section's sharp trailing edge at the seam, its stations clustering towards
    # it (the steps beside it 0.17 mm): 3 um of scatter turned the wedge's neighbours 10
    # deg, read as the arc of a round edge, and the fit rounded the wedge (0.023 mm off)
    from toolpath.knots import DEGREE, seam_multiplicity
    u = 0.5 * (1.0 - np.cos(np.linspace(0.0, np.pi, 50)))  # 0 at the TE, 1 at the LE
    x = 40.0 * u
    thickness = u * np.sqrt(1.0 - u)  # a wedge at the TE, a round nose at the LE
    upper = np.c_[x, 4.0 * thickness, 0.02 * x]
    lower = np.c_[x, -2.0 * thickness, 0.02 * x]
    # from the trailing edge round the upper side, back along the lower one
    loop = np.vstack((upper, lower[-2:0:-1]))
    assert seam_multiplicity(np.vstack((loop, loop[:1])), 8.0) == DEGREE
    rng = np.random.default_rng(seed)
    noisy = loop + rng.normal(0.0, 0.003, loop.shape)
    assert seam_multiplicity(np.vstack((noisy, noisy[:1])), 8.0) == DEGREE
