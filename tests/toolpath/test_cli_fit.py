import json

import numpy as np
import pytest

from streamline_cam.cli import main
from toolpath import curve_from_dict, surface_from_dict
from toolpath.errors import FitError
from toolpath.paper_examples import bundled_data_path


def test_fit_curve_writes_json_plot_and_report(tmp_path, capsys):
    src = bundled_data_path("dev_half_profile_71.csv")
    out, png = tmp_path / "fit.json", tmp_path / "fit.png"
    assert main(["fit", "curve", str(src), "--tol", "0.005", "-o", str(out),
                 "--plot", str(png), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["method"] == "streamline" and report["within_tol"]
    assert report["max_error_mm"] <= 0.005 and len(report["T"]) == 3
    curve = curve_from_dict(json.loads(out.read_text()))
    assert curve.max_error == report["max_error_mm"]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_fit_curve_text_report_for_each_method(tmp_path, capsys):
    path = tmp_path / "arc.txt"
    s = np.linspace(0, 2, 40)
    np.savetxt(path, np.c_[np.cos(s), np.sin(s), s] * 30)
    for method in ("bspline", "P0", "P1-1", "P1-2", "P2"):
        assert main(["fit", "curve", str(path), "--method", method]) == 0
        text = capsys.readouterr().out
        assert f"method            {method}" in text and "max error" in text


def test_fit_surface_writes_json_plot_and_report(tmp_path, capsys):
    src = bundled_data_path("dev_blade_15x142.csv")
    out, png = tmp_path / "blade.json", tmp_path / "blade.png"
    assert main(["fit", "surface", str(src), "--tol", "0.01", "-o", str(out),
                 "--plot", str(png), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["method"] == "streamline" and report["within_tol"]
    assert report["n_sections"] == 15 and report["points_per_section"] == 142
    surface = surface_from_dict(json.loads(out.read_text()))
    assert surface.max_error == report["max_error_mm"] <= 0.01
    assert list(surface.n_control_points) == report["n_control_points"]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["fit", "surface", str(src), "--method", "bspline"]) == 0
    assert "bspline surface" in capsys.readouterr().out


def test_fit_surface_bad_file_is_one_line_and_exit_2(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("section,x,y\n0,1,2\n", encoding="utf-8")
    assert main(["fit", "surface", str(bad)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "lacks column(s) z" in err


def test_fit_surface_of_ragged_sections_reports_each_count(tmp_path, capsys):
    from toolpath import read_sections

    sections = read_sections(bundled_data_path("dev_rotor_dca_11x181.csv"))[:6]
    sections[2] = np.delete(sections[2], np.arange(5, 60, 2), axis=0)  # 28 flank points fewer
    path = tmp_path / "ragged.csv"
    rows = ["section,x,y,z"] + [f"{j},{x:.6f},{y:.6f},{z:.6f}" for j, p in enumerate(sections)
                                for x, y, z in p]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    out = tmp_path / "ragged.json"
    assert main(["fit", "surface", str(path), "--method", "bspline", "--tol", "0.02",
                 "-o", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["section_point_counts"] == [181, 181, 153, 181, 181, 181]
    assert report["within_tol"] and report["between_sections_basis"].startswith("estimate")
    surface = surface_from_dict(json.loads(out.read_text()))
    assert surface.between_error == report["between_sections_mm"] > 0.0
    assert main(["fit", "surface", str(path), "--method", "bspline", "--tol", "0.02"]) == 0
    text = capsys.readouterr().out
    assert "6 x 153-181 points (closed)" in text and "(estimate:" in text


def test_a_tolerance_the_fit_cannot_reach_names_the_flag_and_a_value_to_give(tmp_path,
                                                                              capsys):
    # the propeller's points with 3 um of noise asked within 0.01 um: with as many control
    # points as points the fit stays about 0.011 um off them. The library names its own
    # keywords (tol, max_control_points, which no command offers); the command names its
    # flag, and a tolerance the fit reaches
    from toolpath import read_sections

    rng = np.random.default_rng(0)
    path = tmp_path / "noisy.csv"
    with path.open("w") as out:
        out.write("section,x,y,z\n")
        for j, section in enumerate(read_sections(bundled_data_path("dev_prop_7x100.csv"))):
            for x, y, z in section + rng.normal(0.0, 0.003, section.shape):
                out.write(f"{j},{x:.6f},{y:.6f},{z:.6f}\n")
    for argv, flag in ((["fit", "surface", str(path), "--tol", "0.00001"], "--tol"),
                       (["run", str(path), "--fit-tol", "0.00001", "--quiet",
                         "-o", str(tmp_path / "job" / "part.nc")], "--fit-tol")):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert f"the fit cannot reach {flag} 1e-05 mm" in err and "max_control_points" not in err
        best = float(err.split("it stays ")[1].split()[0])
        given = float(err.split(f"give {flag} ")[1].split()[0])
        assert 1e-5 < best < given < 1.5 * best  # a little above the best the fit reaches
    assert main(["fit", "surface", str(path), "--tol", f"{given:g}"]) == 0  # reached
    # a batch's or the service's job says it in the job's field
    from streamline_cam.pipeline import JobRequest, run_job
    from streamline_cam.service.runner import as_job_fields

    with pytest.raises(FitError) as raised:
        run_job(JobRequest(sections_path=path, fit_tol_mm=1e-5), tmp_path / "service-job")
    assert "the fit cannot reach fit_tol_mm 1e-05 mm" in as_job_fields(str(raised.value))


def _scattered_blade(tmp_path, sigma_mm=0.003):
    """The bundled blade's sections with ``sigma_mm`` of scatter on every coordinate."""
    from toolpath import read_sections

    rng = np.random.default_rng(0)
    path = tmp_path / "scattered.csv"
    with path.open("w") as out:
        out.write("section,x,y,z\n")
        for j, section in enumerate(read_sections(bundled_data_path("dev_blade_15x142.csv"))):
            for x, y, z in section + rng.normal(0.0, sigma_mm, section.shape):
                out.write(f"{j},{x:.6f},{y:.6f},{z:.6f}\n")
    return path


def test_scattered_points_are_told_with_the_tolerance_that_smooths_them(tmp_path, capsys):
    # 3 um of scatter: within 0.01 mm (3.4 sigma) the fit takes in the farthest points and
    # ripples at the blade's open edge, where a 6 mm ball then gouged 0.45 mm. The fit
    # report says how far the points scatter and what tolerance smooths them; the job's
    # gouge error says it with --fit-tol (a service: fit_tol_mm); exact points say nothing
    path = _scattered_blade(tmp_path)
    assert main(["fit", "surface", str(path), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert 0.0025 < report["scatter_mm"] < 0.0035 and report["follows_scatter"]
    note = [n for n in report["notes"] if n.startswith("scatter: ")]
    assert len(note) == 1 and "a fit within 0.01 mm follows that scatter" in note[0]
    advised = float(note[0].split("a tolerance of ")[1].split()[0])
    assert 0.015 <= advised <= 0.021  # 6 sigma, rounded up
    assert main(["fit", "surface", str(bundled_data_path("dev_blade_15x142.csv")),
                 "--json"]) == 0
    exact = json.loads(capsys.readouterr().out)
    assert exact["scatter_mm"] < 1e-4 and not exact["follows_scatter"]
    assert not any(n.startswith("scatter: ") for n in exact["notes"])
    # the whole job stops on the ripple's gouge, naming the cause and the cure
    assert main(["run", str(path), "--machine", "trunnion-ac", "--axis", "lead-tilt",
                 "--lead", "10", "--quiet", "-o", str(tmp_path / "job" / "part.nc")]) == 2
    err = capsys.readouterr().err
    assert "would cut" in err and "a fit within --fit-tol 0.01 follows that scatter" in err
    assert f"--fit-tol {advised:g} or more smooths it" in err


def test_a_curve_fit_reports_the_points_scatter(tmp_path, capsys):
    points = np.loadtxt(bundled_data_path("dev_half_profile_71.csv"), delimiter=",",
                        skiprows=1)
    assert main(["fit", "curve", str(bundled_data_path("dev_half_profile_71.csv")),
                 "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["scatter_mm"] < 1e-4
    noisy = tmp_path / "noisy.csv"
    rng = np.random.default_rng(3)
    np.savetxt(noisy, points + rng.normal(0.0, 0.003, points.shape), delimiter=",",
               header="x,y,z", comments="", fmt="%.6f")
    assert main(["fit", "curve", str(noisy), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert 0.002 < report["scatter_mm"] < 0.0045
    assert any(n.startswith("scatter: the points scatter") for n in report["notes"])
