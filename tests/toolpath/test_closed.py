"""Closed sections: the seam rule on real-style exports, periodic fits smooth across the seam."""

import json
import warnings

import numpy as np
import pytest

from streamline_cam.cli import main
from streamline_cam.commands.run import request_from_args
from toolpath import (
    as_sections,
    curve_from_dict,
    fit_bspline_curve,
    fit_bspline_surface,
    fit_streamline_curve,
    fit_streamline_surface,
    read_sections,
    surface_from_dict,
)
from toolpath.closure import read_seam
from toolpath.errors import ClosureWarning, FitError, InvalidParameterError, InvalidPointsError
from toolpath.fairness import curve_fairness
from toolpath.paper_examples import bundled_data_path
from toolpath.periodic import (
    from_clamped,
    is_periodic,
    period_of,
    periodic_knots,
    periodic_lsq,
    periodic_violation,
)

CURVE_FITS = [fit_streamline_curve, fit_bspline_curve]
SURFACE_FITS = [fit_streamline_surface, fit_bspline_surface]


def _sections(name):
    return [np.asarray(p, float) for p in read_sections(bundled_data_path(name))]


# ----------------------------------------------------------------------------- real-style data
def _arc_table(xy, samples=200_000):
    """Arc length of a closed parametric curve ``xy(u)``, u in [0, 1)."""
    u = np.linspace(0.0, 1.0, samples + 1)
    p = xy(u)
    s = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))))
    return u, s


def _rounded_section(gap_mm, nose_step_mm, *, z=0.0, a=50.0, b=3.0, start_mm=0.2):
    """A closed airfoil-like contour (an ellipse, nose radius b²/a = 0.18 mm) exported as a
    CAD tool does: arc-length stations nose_step_mm apart on the noses, growing 15 % per mm
    of arc up to 2 mm on the flanks, the first on the TE nose start_mm past its vertex, the
    last gap_mm (along the arc) before the first: the first point is not repeated."""
    def xy(u):
        return np.c_[a * np.cos(2 * np.pi * u), b * np.sin(2 * np.pi * u)]

    u, s = _arc_table(xy)
    length = s[-1]
    half = np.interp(0.5, u, s)

    def step(at):
        d = min(at % length, abs(at % length - half), length - at % length)
        return min(2.0, nose_step_mm + 0.15 * d)

    stations = [start_mm]
    while stations[-1] + step(stations[-1]) < start_mm + length - gap_mm - 0.5 * nose_step_mm:
        stations.append(stations[-1] + step(stations[-1]))
    stations.append(start_mm + length - gap_mm)
    pts = xy(np.interp(np.mod(stations, length), s, u))
    return np.c_[pts, np.full(len(pts), z)]


def _naca_section(n, *, base_mm, chord=60.0, thick=0.1, shift=0.0, z=0.0):
    """A NACA-like section, TE -> suction -> LE -> pressure -> TE, cosine spacing, n points.

    ``base_mm`` > 0: a blunt TE of that width, the first and last points its corners, the
    base between them not sampled (open); 0: a sharp TE at the first point, or with
    ``shift`` 0.5 between the last point and the first (stations moved by half a step).
    """
    k = np.arange(n)
    phi = 2 * np.pi * k / (n - 1) if base_mm > 0 else 2 * np.pi * (k + shift) / n
    x = 0.5 * (1 + np.cos(phi))
    yt = 5 * thick * (0.2969 * np.sqrt(x) - 0.126 * x - 0.3516 * x**2 + 0.2843 * x**3
                      - 0.1036 * x**4) * chord + 0.5 * base_mm * x
    side = np.where(phi <= np.pi, 1.0, -1.0)
    return np.c_[chord * x, side * yt, np.full(n, z)]


@pytest.mark.parametrize("name, closed", [
    ("dev_rotor_dca_11x181.csv", True),    # 0.006-0.009 mm, the shortest step
    ("dev_prop_7x100.csv", True),          # an ordinary step; a sharp TE at point 0
    ("dev_rotor_blunt_9x120.csv", False),  # a 0.4 mm blunt TE base
    ("dev_blade_15x142.csv", False),       # an unsampled 0.06-0.13 mm blunt TE base
])
def test_seam_rule_on_the_development_blades(name, closed):
    sections = _sections(name)
    assert all(read_seam(p).closed is closed for p in sections)
    assert as_sections(sections).closed is closed


@pytest.mark.parametrize("roll", [40, 90, 140])
def test_a_seam_on_a_coarse_flank_closes_too(roll):
    # the DCA rotor's sections started elsewhere: the closing step is then a flank step of
    # 0.5-2.5 mm (up to 2.7 % of the contour), still a step like its neighbours
    sections = [np.roll(p, roll, axis=0) for p in _sections("dev_rotor_dca_11x181.csv")]
    assert as_sections(sections).closed


@pytest.mark.parametrize("gap_mm", [0.002, 0.005, 0.01, 0.02])
@pytest.mark.parametrize("nose_step_mm", [0.01, 0.03, 0.1])
def test_real_style_gaps_close_on_any_spacing(gap_mm, nose_step_mm):
    section = _rounded_section(gap_mm, nose_step_mm)
    seam = read_seam(section)
    assert abs(seam.gap_mm - gap_mm) < 0.2 * gap_mm
    assert seam.closed and not seam.repeated, seam.reason


@pytest.mark.parametrize("base_mm", [0.05, 0.1, 0.4, 1.0])
@pytest.mark.parametrize("n", [80, 142, 300])
def test_blunt_bases_stay_open(base_mm, n):
    seam = read_seam(_naca_section(n, base_mm=base_mm))
    assert not seam.closed, seam.reason
    assert min(seam.turns_deg) > 60.0


@pytest.mark.parametrize("shift", [0.0, 0.5])
def test_sharp_trailing_edges_close_whether_sampled_or_between_samples(shift):
    seam = read_seam(_naca_section(140, base_mm=0.0, shift=shift))
    assert seam.closed, seam.reason


def test_open_curves_stay_open():
    half = np.loadtxt(bundled_data_path("dev_half_profile_71.csv"), delimiter=",", skiprows=1)
    assert not read_seam(half).closed
    arc = np.c_[np.cos(np.linspace(0, 5, 50)), np.sin(np.linspace(0, 5, 50))] * 30
    assert not read_seam(arc).closed


def test_a_repeated_first_point_is_closed_and_dropped():
    section = _rounded_section(0.01, 0.03)
    repeated = np.vstack((section, section[:1] + 1e-4))
    assert read_seam(repeated).repeated
    grid = as_sections([repeated + np.array([0.0, 0.0, 10.0 * j]) for j in range(4)])
    assert grid.closed and grid.n_columns == len(section) + 1
    assert np.array_equal(grid.points[:, -1], grid.points[:, 0])


def test_sections_that_disagree_are_refused_naming_the_flags():
    sections = [_rounded_section(0.01, 0.03, z=10.0 * j) for j in range(4)]
    sections[2] = _naca_section(len(sections[0]), base_mm=0.4, z=20.0, chord=100.0)
    with pytest.raises(InvalidPointsError, match=r"section 2 reads open .*--closed or --open"):
        as_sections(sections)
    assert as_sections(sections, closed=False).closed is False



def test_a_few_sections_reading_otherwise_are_fitted_as_most_read_with_a_warning():
    # scatter of a micrometre or two turns a closing step of 10-20 um by tens of degrees:
    # one section of eleven may read as a blunt base (the DCA rotor with 2 um did); here
    # one section misses its last six points (its ends 0.2 mm apart: read open)
    sections = _sections("dev_rotor_dca_11x181.csv")
    sections[4] = sections[4][:-6]
    assert not read_seam(sections[4]).closed
    with pytest.warns(ClosureWarning, match=r"section 4 reads open \(the ends are .* but the "
                      r"other 10 of 11 sections read closed: fitted closed; give --open"):
        assert as_sections(sections).closed
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert as_sections(sections, closed=True).closed  # (said: no warning)
    # the other way round: one of nine open sections repeats its first point
    blunt = _sections("dev_rotor_blunt_9x120.csv")
    blunt[7] = np.vstack((blunt[7], blunt[7][:1]))
    with pytest.warns(ClosureWarning, match=r"section 7 reads closed .* fitted open; give "
                      r"--closed"):
        assert not as_sections(blunt).closed
    # a quarter or more reading otherwise is no reading: refused, naming the flags
    sections[6], sections[9] = sections[6][:-6], sections[9][:-6]
    with pytest.raises(InvalidPointsError, match=r"section 4 reads open .*: say which with "
                       r"--closed or --open$"):
        as_sections(sections)


def _rotor_missing_points(path):
    """The DCA rotor's sections written to ``path``, section 4 short of its last six points."""
    sections = _sections("dev_rotor_dca_11x181.csv")
    sections[4] = sections[4][:-6]
    path.write_text("section,x,y,z\n" + "".join(
        f"{j},{x:.6f},{y:.6f},{z:.6f}\n" for j, p in enumerate(sections) for x, y, z in p))
    return path


def test_the_command_shows_a_warning_as_a_user_reads_it(tmp_path, capsys):
    path = _rotor_missing_points(tmp_path / "rotor.csv")
    assert main(["fit", "surface", str(path), "--json"]) == 0
    out = capsys.readouterr()
    assert json.loads(out.out)["closed"] is True
    assert out.err.startswith("toolpath: warning: section 4 reads open")
    assert "ClosureWarning" not in out.err and ".py:" not in out.err


# ----------------------------------------------------------------------------- periodic fits
def _seam_jumps(value_at):
    """Relative jumps of value, first and second derivative across the seam."""
    out = []
    for order in range(3):
        a, b = value_at(0.0, order), value_at(1.0, order)
        scale = max(np.linalg.norm(a), np.linalg.norm(b), 1.0 if order == 0 else 0.0)
        out.append(float(np.linalg.norm(a - b) / scale))
    return out


def _curve_value(curve):
    def at(t, order):
        x = np.array([t])
        return curve(x)[0] if order == 0 else curve.derivative(x, order)[0]
    return at


@pytest.mark.parametrize("fit", CURVE_FITS)
@pytest.mark.parametrize("section", [
    _sections("dev_rotor_dca_11x181.csv")[4],
    _rounded_section(0.004, 0.02),
    _rounded_section(0.02, 0.1),
], ids=["dca-section", "gap-0.004-on-0.02", "gap-0.02-on-0.1"])
def test_closed_curve_fits_are_smooth_across_the_seam(fit, section):
    curve = fit(section, tol=0.01, closed=None)
    assert curve.closed and is_periodic(curve.knots)
    assert all(jump < 1e-9 for jump in _seam_jumps(_curve_value(curve)))
    assert np.allclose(curve(np.array([0.0]))[0], section[0], rtol=0.0, atol=1e-9)
    # the error figures are the distances at the data, every point (the last one too)
    assert len(curve.params) == len(section)
    distances = np.linalg.norm(curve(curve.params) - section, axis=1)
    assert np.isclose(distances.max(), curve.max_error) and curve.max_error <= 0.01


@pytest.mark.parametrize("fit", CURVE_FITS)
def test_a_corner_at_the_seam_keeps_its_corner_knots(fit):
    prop = _sections("dev_prop_7x100.csv")[3]  # a sharp TE at point 0
    curve = fit(prop, tol=0.01, closed=True)
    assert np.sum(period_of(curve.knots) == 0.0) == 3
    assert curve.max_error <= 0.01
    t0, t1 = curve.derivative(np.array([0.0]))[0], curve.derivative(np.array([1.0]))[0]
    turn = np.degrees(np.arccos(t0 @ t1 / np.linalg.norm(t0) / np.linalg.norm(t1)))
    assert turn > 120.0  # the wedge, not rounded off


@pytest.mark.parametrize("fit", CURVE_FITS)
def test_closed_curve_json_and_given_knots(fit):
    section = _rounded_section(0.01, 0.05)
    curve = fit(section, n_control_points=30, closed=True)
    assert curve.n_control_points == 30
    again = curve_from_dict(json.loads(json.dumps(curve.to_dict())))
    assert again.closed and again.n_control_points == 30
    t = np.linspace(0, 1, 97)
    assert np.array_equal(again(t), curve(t))
    # the same knots, given periodic, give the same fit; a clamped vector's interior knots
    # are used with a seam knot
    # (a streamline fit picks its frame on the knots it is given, the first fit on its
    # B-spline probe's: the frames' margins may differ, the error by a few per cent)
    same = fit(section, knots=curve.knots, closed=True)
    assert np.array_equal(same.knots, curve.knots)
    assert np.isclose(same.max_error, curve.max_error, rtol=0.05)
    clamped = fit(section, knots=np.r_[[0.0] * 4, np.linspace(0, 1, 12)[1:-1], [1.0] * 4],
                  closed=True)
    assert clamped.n_control_points == 11 and is_periodic(clamped.knots)


def test_periodic_knots_that_cannot_be_fitted_are_refused():
    section = _rounded_section(0.01, 0.05)
    crowded = periodic_knots(np.r_[0.0, np.linspace(0.5, 0.5001, 4)])
    with pytest.raises(InvalidParameterError, match="holds no data"):
        fit_bspline_curve(section, knots=crowded, closed=True)
    assert "base interval" in periodic_violation(np.linspace(0, 1, 9), crowded + 0.1)
    with pytest.raises(InvalidParameterError, match="open curves only"):
        fit_streamline_curve(section, tol=0.01, closed=True, refine=True)
    with pytest.raises(FitError, match="not reached with 12 control points"):
        fit_bspline_curve(section, tol=1e-6, closed=True, max_control_points=12)


def test_a_piece_with_no_data_between_two_corner_knots_is_straight():
    # two corner knots with no sample between (a blunt base closed by --closed): of all
    # the fits the data cannot tell apart, the straight one
    section = _naca_section(60, base_mm=0.4)[:, :2]
    closed = np.vstack((section, section[:1]))
    t = np.concatenate(([0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))))
    t /= t[-1]
    clamped = np.r_[[0.0] * 4, np.linspace(0, t[-2], 15)[1:-1], [t[-2]] * 3, [1.0] * 4]
    spline = periodic_lsq(t, closed, from_clamped(clamped, seam=3))
    u = np.linspace(t[-2], 1.0, 11)
    base = spline(u)
    chord = (base[-1] - base[0]) / np.linalg.norm(base[-1] - base[0])
    off_line = (base - base[0]) - np.outer((base - base[0]) @ chord, chord)
    assert np.abs(off_line).max() < 1e-6


def test_an_open_fit_is_unchanged_by_default():
    section = _rounded_section(0.01, 0.05)
    curve = fit_bspline_curve(section, tol=0.01)
    assert not curve.closed and not is_periodic(curve.knots)
    with pytest.raises(FitError):  # a periodic fit needs periodic knots in range
        periodic_lsq(np.linspace(0, 1, 5), np.zeros((5, 2)), curve.knots + 0.5)


@pytest.fixture(scope="module")
def dca5():
    """Five sections of the DCA rotor (closed by a 0.006-0.009 mm gap)."""
    return _sections("dev_rotor_dca_11x181.csv")[::2][:5]


@pytest.mark.parametrize("fit", SURFACE_FITS)
def test_closed_surface_fits_are_smooth_across_the_seam(fit, dca5):
    surf = fit(dca5, tol=0.01)
    assert surf.closed_t and is_periodic(surf.knots_t)
    # within tol at every data point (the sections are matched: their seams moved to the
    # trailing edge, tests/toolpath/test_section_matching.py; the mask tells the data)
    grid = as_sections(dca5)
    fitted = surf(surf.t_params[None, :], surf.s_params[:, None])
    distances = np.linalg.norm(fitted - grid.points, axis=2)[grid.data_mask]
    assert np.isclose(distances.max(), surf.max_error) and surf.max_error <= 0.01
    s = np.linspace(0.0, 1.0, 9)
    zeros, ones = np.zeros_like(s), np.ones_like(s)
    for dt, ds in ((0, 0), (1, 0), (2, 0), (0, 1), (1, 1)):
        a = surf.derivative(zeros, s, dt=dt, ds=ds) if dt + ds else surf(zeros, s)
        b = surf.derivative(ones, s, dt=dt, ds=ds) if dt + ds else surf(ones, s)
        scale = np.linalg.norm(a, axis=-1).max()
        assert np.linalg.norm(a - b, axis=-1).max() <= 1e-9 * scale, (dt, ds)
    # X(0, s_j) is each section's seam (its first column)
    assert np.allclose(surf(zeros[:5], surf.s_params), grid.points[:, 0], atol=1e-9)
    n_t, n_s = surf.n_control_points
    assert n_s == 5 and n_t == len(period_of(surf.knots_t))
    # JSON round trip (the compiled kernel too for the streamline surface)
    again = surface_from_dict(json.loads(json.dumps(surf.to_dict())))
    t = np.linspace(0, 1, 33)
    tt, ss = np.meshgrid(t, s)
    assert np.array_equal(again(tt, ss), surf(tt, ss))
    assert again.closed_t and again.n_control_points == surf.n_control_points


def test_compiled_kernel_reads_the_periodic_surface_and_wraps_t(dca5):
    surf = fit_streamline_surface(dca5, tol=0.01)
    kernel = surf.kernel()
    t = np.array([0.0, 0.3, 0.999, 1.0])
    s = np.array([0.1, 0.5, 0.7, 0.9])
    got = kernel.partials(t, s, ((0, 0), (1, 0), (2, 0)))
    for (dt, ds), values in got.items():
        want = surf(t, s) if dt == 0 else surf.derivative(t, s, dt=dt, ds=ds)
        assert np.allclose(values, want, rtol=1e-9, atol=1e-9)


def test_refine_is_for_open_sections():
    sections = [_rounded_section(0.01, 0.05, z=10.0 * j) for j in range(4)]
    with pytest.raises(InvalidParameterError, match="open sections only"):
        fit_streamline_surface(sections, tol=0.01, refine=True)


# ----------------------------------------------------------------------------- command line
def test_fit_curve_closed_and_open_flags(tmp_path, capsys):
    path = tmp_path / "section.csv"
    section = _sections("dev_rotor_dca_11x181.csv")[5]
    np.savetxt(path, section, delimiter=",", header="x,y,z", comments="")
    assert main(["fit", "curve", str(path), "--method", "bspline", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["closed"] and report["within_tol"]
    assert main(["fit", "curve", str(path), "--method", "bspline", "--open"]) == 0
    assert "points            181 (open)" in capsys.readouterr().out
    blunt = tmp_path / "blunt.csv"
    np.savetxt(blunt, _naca_section(120, base_mm=0.4), delimiter=",", header="x,y,z",
               comments="")
    out = tmp_path / "c.json"
    assert main(["fit", "curve", str(blunt), "--method", "bspline", "--closed",
                 "-o", str(out)]) == 0
    assert "(closed)" in capsys.readouterr().out
    assert curve_from_dict(json.loads(out.read_text())).closed
    assert main(["fit", "curve", str(blunt), "--method", "P0", "--closed"]) == 2
    assert "--closed needs a spline method" in capsys.readouterr().err


def test_a_blunt_base_closed_on_request_reads_no_nose_round_its_seam():
    # the base's two corners read as tight data circles; the fit's straight base between
    # them is no nose error (fairness samples the closing interval of a closed fit)
    blunt = _naca_section(120, base_mm=0.4)
    curve = fit_bspline_curve(blunt, tol=0.01, closed=True)
    fairness = curve_fairness(curve, blunt, closed=True)
    assert curve.max_error <= 0.01
    assert fairness.nose_error_mm <= 0.01 and fairness.n_concave == 0


def test_fit_surface_closed_and_open_flags(tmp_path, capsys):
    path = tmp_path / "dca.csv"
    rows = [np.c_[np.full(len(p), j), p] for j, p in
            enumerate(_sections("dev_rotor_dca_11x181.csv")[::2])]
    np.savetxt(path, np.vstack(rows), delimiter=",", header="section,x,y,z", comments="",
               fmt=["%d", "%.6f", "%.6f", "%.6f"])
    assert main(["fit", "surface", str(path), "--method", "bspline", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["closed"]
    assert main(["fit", "surface", str(path), "--method", "bspline", "--open"]) == 0
    assert "(open)" in capsys.readouterr().out


@pytest.mark.parametrize("flags, closed", [([], None), (["--closed"], True),
                                           (["--open"], False)])
def test_run_takes_closed_and_open(flags, closed):
    import argparse

    from streamline_cam.commands import run

    commands = argparse.ArgumentParser().add_subparsers()
    run.register(commands)
    parser = commands.choices["run"]
    args = parser.parse_args(["blade.csv", *flags])
    assert request_from_args(args.points, args).closed is closed


def test_job_parameters_take_an_optional_closed():
    from streamline_cam.service.schemas import JobParameters

    assert JobParameters().closed is None
    assert JobParameters(closed=True).closed is True


@pytest.mark.parametrize("gap_mm", [0.005, 0.01, 0.02])
@pytest.mark.parametrize("nose_step_mm", [0.01, 0.02, 0.03])
def test_scattered_closing_steps_still_close(gap_mm, nose_step_mm):
    # 3 um of scatter turns the ends of a closing step 10-30 um long by 50-90 deg, as a
    # blunt base's corners turn: the DCA rotor so scattered read 61 of 220 sections open
    # (20 seeds). What the scatter may turn them is no evidence of a base.
    for seed in range(10):
        section = _rounded_section(gap_mm, nose_step_mm)
        section = section + np.random.default_rng(seed).normal(0.0, 0.003, section.shape)
        seam = read_seam(section)
        assert seam.closed, (seed, seam.reason)


@pytest.mark.parametrize("base_mm", [0.1, 0.4, 1.0])
@pytest.mark.parametrize("n", [80, 142, 300])
def test_scattered_blunt_bases_stay_open(base_mm, n):
    for seed in range(10):
        section = _naca_section(n, base_mm=base_mm)
        section = section + np.random.default_rng(seed).normal(0.0, 0.003, section.shape)
        seam = read_seam(section)
        assert not seam.closed, (seed, seam.reason)


def test_a_job_keeps_how_the_closure_was_read_in_its_fit_notes(tmp_path):
    # a service's user reads no warning: the job's report says it
    from streamline_cam.pipeline import JobRequest, _read_sections

    request = JobRequest(_rotor_missing_points(tmp_path / "rotor.csv")).validated()
    with pytest.warns(ClosureWarning):
        sections, notes = _read_sections(request)
    assert sections.closed
    assert len(notes) == 1 and notes[0].startswith("closure: section 4 reads open")
