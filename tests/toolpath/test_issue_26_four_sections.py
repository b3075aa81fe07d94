"""Issue 26: surfaces from four sections (the documented minimum) fit, fewer are refused.

Leaving one of four sections out leaves three, too few for a not-a-knot cubic across them
(scipy: "The number of derivatives at boundaries does not match"); every four-section fit
failed. The leave-one-out now uses a natural cubic through the three, and the report says
that with fewer than five sections the between-sections figure has no interpolation term.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from streamline_cam.cli import main
from toolpath import fit_bspline_surface, fit_streamline_surface, read_sections
from toolpath.errors import InvalidPointsError
from toolpath.paper_examples import bundled_data_path


def _sections_csv(path, rows):
    blade = bundled_data_path("dev_blade_15x142.csv").read_text().splitlines()
    keep = {str(j) for j in rows}
    path.write_text("\n".join([blade[0], *(r for r in blade[1:] if r.split(",")[0] in keep)])
                    + "\n")
    return str(path)


@pytest.mark.parametrize("method", ["streamline", "bspline"])
def test_fit_surface_of_four_sections_from_the_command_line(tmp_path, capsys, method):
    src = _sections_csv(tmp_path / "four.csv", [0, 1, 2, 3])
    out = tmp_path / "four.json"
    assert main(["fit", "surface", src, "--method", method, "-o", str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["n_sections"] == 4 and report["within_tol"]
    assert np.isfinite(report["between_sections_mm"])
    assert np.isfinite(report["leave_one_out_mm"])
    assert any("4 sections, too few for the interpolation error" in n for n in report["notes"])
    assert json.loads(out.read_text())["kind"] == f"{method}_surface"


@pytest.mark.parametrize("rows", [[0, 7, 14], [0, 14]])
def test_fewer_sections_are_refused_naming_the_count_and_the_minimum(tmp_path, capsys, rows):
    src = _sections_csv(tmp_path / "few.csv", rows)
    assert main(["fit", "surface", src]) == 2
    err = capsys.readouterr().err
    assert err == (f"toolpath: error: a surface needs at least 4 sections, got {len(rows)}\n")


@pytest.mark.parametrize("fitter", [fit_streamline_surface, fit_bspline_surface])
def test_the_api_fits_four_sections_and_refuses_three(fitter):
    blade = np.array(read_sections(bundled_data_path("dev_blade_15x142.csv")))
    surface = fitter(blade[3:7], tol=0.01)
    assert surface.max_error <= 0.01 and np.isfinite(surface.between_error)
    with pytest.raises(InvalidPointsError, match="at least 4 sections, got 3"):
        fitter(blade[3:6], tol=0.01)
