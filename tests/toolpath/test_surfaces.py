"""Streamline and B-spline surfaces: exactness, derivatives, geometry, seams, JSON, errors."""

import json

import numpy as np
import pytest

import toolpath
from toolpath import (
    InvalidParameterError,
    InvalidPointsError,
    fit_bspline_surface,
    fit_streamline_surface,
    surface_from_dict,
)
from toolpath.errors import DataFileError
from toolpath.paper_examples import bundled_data_path
from toolpath.splinefit import clamped_knots

FITS = (fit_streamline_surface, fit_bspline_surface)


@pytest.fixture(scope="module")
def blade_sections():
    return toolpath.read_sections(bundled_data_path("dev_blade_15x142.csv"))


@pytest.fixture(scope="module")
def blade(blade_sections):
    return fit_streamline_surface(blade_sections, tol=0.01)


def cylinder_sections(radius=40.0, m=6, n=40):
    theta = np.linspace(0.2, 1.2, n)
    z = np.linspace(0.0, 30.0, m)
    return np.stack([np.c_[radius * np.cos(theta), radius * np.sin(theta), np.full(n, zj)]
                     for zj in z])


def test_surface_of_a_known_diagonal_system_is_recovered_exactly():
    # X = Z0(s) * exp(G(t, s)) with T = I: Z0 cubic in s, G bicubic with G(0, s) = 0
    t = np.linspace(0.0, 1.0, 25)
    s = np.linspace(0.0, 1.0, 6)
    tt, ss = np.meshgrid(t, s)  # (m, n)
    z0 = np.stack([10 + ss, 20 + 2 * ss, 30 + ss**2 - ss**3], axis=-1)
    g = np.stack([tt * (0.3 + 0.1 * ss), tt**2 * (-0.2 + 0.05 * ss**2),
                  tt * (0.1 * tt + 0.2 * ss)], axis=-1)
    points = z0 * np.exp(g)
    surf = fit_streamline_surface(points, knots=clamped_knots(np.array([])), params=t,
                                  section_params=s, frame="paper", minimax=False)
    assert surf.max_error < 1e-9
    assert surf.n_control_points == (4, 6)
    probe_t, probe_s = np.random.default_rng(1).random((2, 50))
    exact = np.stack([10 + probe_s, 20 + 2 * probe_s, 30 + probe_s**2 - probe_s**3], -1) * \
        np.exp(np.stack([probe_t * (0.3 + 0.1 * probe_s),
                         probe_t**2 * (-0.2 + 0.05 * probe_s**2),
                         probe_t * (0.1 * probe_t + 0.2 * probe_s)], -1))
    assert np.abs(surf(probe_t, probe_s) - exact).max() < 1e-8


@pytest.mark.parametrize("fit", FITS)
def test_cylinder_patch_curvatures_and_outward_normals(fit):
    surf = fit(cylinder_sections(), tol=1e-4)
    assert surf.max_error <= 1e-4
    t, s = np.meshgrid(np.linspace(0.1, 0.9, 7), np.linspace(0.1, 0.9, 5))
    k_min, k_max = surf.principal_curvatures(t, s)
    assert np.allclose(k_min, -1 / 40.0, rtol=0.01)
    assert np.allclose(k_max, 0.0, atol=2e-4)
    points = surf(t, s)
    radial = points[..., :2] / np.linalg.norm(points[..., :2], axis=-1, keepdims=True)
    assert (np.einsum("...k,...k->...", surf.normal(t, s)[..., :2], radial) > 0.999).all()


@pytest.mark.parametrize("fit", FITS)
def test_end_conditions_and_sections_are_reproduced(fit, blade_sections):
    surf = fit(blade_sections, tol=0.01)
    data = np.stack(blade_sections)
    first = surf(np.zeros(15), surf.s_params)
    last = surf(np.ones(15), surf.s_params)
    assert np.abs(first - data[:, 0]).max() < 1e-9
    assert np.abs(last - data[:, -1]).max() < 1e-9
    for j in (0, 7, 14):
        along = surf.streamline(surf.s_params[j])(surf.t_params)
        assert np.linalg.norm(along - data[j], axis=1).max() <= surf.max_error + 1e-12
    assert surf.max_error <= 0.01
    assert surf.loo_error > 0.0


def test_streamline_boundary_curve_x0_holds_between_sections(blade):
    s = np.linspace(0, 1, 31)
    assert np.abs(blade(np.zeros_like(s), s) - blade.X0(s)).max() < 1e-9


@pytest.mark.parametrize("fit", FITS)
def test_partial_derivatives_match_finite_differences(fit, blade_sections):
    surf = fit(blade_sections, tol=0.01)
    t = np.array([0.05, 0.3, 0.5, 0.77, 0.95])
    s = np.array([0.1, 0.42, 0.5, 0.66, 0.9])
    h = 1e-5

    def fd(f, dt, ds):
        return (f(t + h * dt, s + h * ds) - f(t - h * dt, s - h * ds)) / (2 * h)

    checks = {
        (1, 0): fd(surf, 1, 0),
        (0, 1): fd(surf, 0, 1),
        (2, 0): fd(lambda a, b: surf.derivative(a, b, dt=1, ds=0), 1, 0),
        (1, 1): fd(lambda a, b: surf.derivative(a, b, dt=1, ds=0), 0, 1),
        (0, 2): fd(lambda a, b: surf.derivative(a, b, dt=0, ds=1), 0, 1),
    }
    for (dt, ds), numeric in checks.items():
        exact = surf.derivative(t, s, dt=dt, ds=ds)
        assert np.abs(exact - numeric).max() <= 1e-5 * np.abs(exact).max(), (dt, ds)


def test_normals_are_unit_and_orthogonal_to_both_partials(blade):
    t, s = np.meshgrid(np.linspace(0, 1, 23), np.linspace(0, 1, 9))
    n = blade.normal(t, s)
    assert np.allclose(np.linalg.norm(n, axis=-1), 1.0)
    for dt, ds in ((1, 0), (0, 1)):
        d = blade.derivative(t, s, dt=dt, ds=ds)
        cosine = np.einsum("...k,...k->...", n, d) / np.linalg.norm(d, axis=-1)
        assert np.abs(cosine).max() < 1e-12


def test_grid_and_scattered_evaluation_agree(blade):
    t, s = np.linspace(0, 1, 11), np.linspace(0, 1, 4)
    grid = blade(t, s, grid=True)
    assert grid.shape == (11, 4, 3)
    tt, ss = np.meshgrid(t, s, indexing="ij")
    assert np.array_equal(grid, blade(tt, ss))


def test_closed_sections_have_an_exact_seam_and_outward_normals(closed_sections):
    sections = closed_sections
    surf = fit_streamline_surface(sections, tol=0.005)
    assert surf.closed_t
    assert surf.max_error <= 0.005
    s = np.linspace(0, 1, 17)
    assert np.abs(surf(np.zeros_like(s), s) - surf(np.ones_like(s), s)).max() < 1e-9
    t, ss = np.meshgrid(np.linspace(0.02, 0.98, 40), np.linspace(0, 1, 6))
    points = surf(t, ss)
    centre = np.array([100.0, 50.0])
    away = points[..., :2] - centre
    assert (np.einsum("...k,...k->...", surf.normal(t, ss)[..., :2], away) > 0).all()
    # an unrepeated first point is closed on request, giving the same surface
    again = fit_streamline_surface(sections[:, :-1], tol=0.005, closed=True)
    assert again.closed_t and np.isclose(again.max_error, surf.max_error)


def test_same_knots_comparison(blade, blade_sections):
    baseline = fit_bspline_surface(blade_sections, knots=blade.knots_t)
    assert np.array_equal(baseline.knots_t, blade.knots_t)
    assert baseline.n_control_points == blade.n_control_points
    assert baseline.max_error < 0.05


@pytest.mark.parametrize("fit", FITS)
def test_json_round_trip_is_exact(fit, blade_sections):
    surf = fit(blade_sections, n_control_points=12)
    again = surface_from_dict(json.loads(json.dumps(surf.to_dict())))
    assert type(again) is type(surf)
    t, s = np.random.default_rng(0).random((2, 40))
    assert np.array_equal(again(t, s), surf(t, s))
    assert again.n_control_points == surf.n_control_points == (12, 15)
    assert again.orientation == surf.orientation


def test_saved_surface_of_another_version_is_refused(blade):
    data = blade.to_dict() | {"format_version": 99}
    with pytest.raises(InvalidParameterError, match="version 99"):
        surface_from_dict(data)
    with pytest.raises(InvalidParameterError, match="kind"):
        surface_from_dict({"kind": "mesh"})


def test_refine_does_not_raise_the_error(blade_sections):
    plain = fit_streamline_surface(blade_sections, n_control_points=10, minimax=False)
    refined = fit_streamline_surface(blade_sections, knots=plain.knots_t, refine=True,
                                     minimax=False)
    assert refined.rms_error <= plain.rms_error * (1 + 1e-9)


# ---------------------------------------------------------------------- bad input
def test_ragged_sections_under_array_params_name_the_section():
    # ragged sections are matched (tests/toolpath/test_section_matching.py) unless the
    # parameters are given as one array, which needs one point count
    sections = list(cylinder_sections())
    sections[3] = sections[3][:-1]
    with pytest.raises(InvalidPointsError, match="section 3 has 39 points but section 0 has 40"):
        fit_streamline_surface(sections, tol=0.01, params=np.linspace(0.0, 1.0, 40))


def test_too_few_sections():
    with pytest.raises(InvalidPointsError, match="at least 4 sections, got 3"):
        fit_bspline_surface(cylinder_sections(m=3), tol=0.01)


def test_sections_out_of_order():
    sections = cylinder_sections()
    sections[[2, 3]] = sections[[3, 2]]
    with pytest.raises(InvalidPointsError, match="section 3 is out of order"):
        fit_streamline_surface(sections, tol=0.01)


def test_non_finite_and_repeated_points_name_section_and_point():
    sections = cylinder_sections()
    sections[2, 5, 1] = np.nan
    with pytest.raises(InvalidPointsError, match="section 2: point 5 is not finite"):
        fit_streamline_surface(sections, tol=0.01)
    sections = cylinder_sections()
    sections[4, 8] = sections[4, 7]
    with pytest.raises(InvalidPointsError, match="section 4: points 7 and 8"):
        fit_bspline_surface(sections, tol=0.01)


def test_blade_csv_missing_column_and_disorder(tmp_path):
    path = tmp_path / "blade.csv"
    path.write_text("section,x,y\n0,1,2\n", encoding="utf-8")
    with pytest.raises(DataFileError, match=r"lacks column.*z"):
        toolpath.read_sections(path)
    path.write_text("section,x,y,z\n0,1,2,3\n1,1,2,4\n0,1,2,5\n", encoding="utf-8")
    with pytest.raises(DataFileError, match=r"csv:4: section 0 comes again after section 1 "
                                            r"\(its rows began on line 2\)"):
        toolpath.read_sections(path)


def test_blade_csv_as_spreadsheets_and_other_tools_write_it(tmp_path):
    # the same two sections written as a spreadsheet in a decimal-comma locale writes
    # them (";" between fields), with a UTF-8 byte order mark, tab-separated, and listed
    # tip first: each reads as the plain file does
    rows = [(0, 1.5, 2.25, 3.0), (0, 1.75, 2.5, 3.0), (0, 2.0, 2.5, 3.0),
            (1, 1.5, 2.25, 4.0), (1, 1.75, 2.5, 4.0), (1, 2.0, 2.5, 4.0)]
    plain = tmp_path / "plain.csv"
    plain.write_text("section,x,y,z\n" + "".join(f"{k},{x},{y},{z}\n" for k, x, y, z in rows),
                     encoding="utf-8")
    expected = toolpath.read_sections(plain)
    assert [len(p) for p in expected] == [3, 3] and expected[1][0, 2] == 4.0
    variants = {
        "semicolons.csv": ("section;x;y;z\n" + "".join(
            f"{k};{x};{y};{z}\n".replace(".", ",") for k, x, y, z in rows), "utf-8"),
        "bom.csv": ("section,x,y,z\r\n" + "".join(
            f"{k},{x},{y},{z}\r\n" for k, x, y, z in rows), "utf-8-sig"),
        "tabs.csv": ("section\tx\ty\tz\n" + "".join(
            f"{k}\t{x}\t{y}\t{z}\n" for k, x, y, z in rows), "utf-8"),
        "tip_first.csv": ("section,x,y,z\n" + "".join(
            f"{k},{x},{y},{z}\n" for k, x, y, z in rows[3:] + rows[:3]), "utf-8"),
    }
    for name, (text, encoding) in variants.items():
        path = tmp_path / name
        path.write_text(text, encoding=encoding)
        got = toolpath.read_sections(path)
        assert len(got) == 2, name
        assert all(np.array_equal(a, b) for a, b in zip(got, expected, strict=True)), name
    curve = tmp_path / "curve.csv"
    curve.write_text("x;y\n1,5;2,25\n1,75;2,5\n", encoding="utf-8-sig")
    assert toolpath.read_points(curve).tolist() == [[1.5, 2.25], [1.75, 2.5]]
    curve.write_text("1,5;2,25\n1,75;2,5\n", encoding="utf-8")  # no header
    assert toolpath.read_points(curve).tolist() == [[1.5, 2.25], [1.75, 2.5]]


def test_surface_derivative_orders_are_checked(blade):
    with pytest.raises(InvalidParameterError, match="total order 2"):
        blade.derivative(0.5, 0.5, dt=2, ds=1)
