"""Issue 9: a ball-end raster on a plane leaves the scallop h = R - sqrt(R^2 - (w/2)^2)."""

import math

import numpy as np
import pytest
from verify_programs import zigzag_raster

from gcode import GRBL, emit_text, parse
from toolpath.planning.analytic import PlaneSurface
from verification import VerifyOptions, verify_program


@pytest.mark.parametrize(("stepover", "method"), [(1.0, "z"), (0.6, "normal"), (1.6, "auto")])
def test_plane_raster_leaves_the_analytic_scallop(router, ball6, stepover, method):
    radius = ball6.radius_mm
    levels = np.arange(0, 8) * stepover
    program = parse(emit_text(zigzag_raster(levels, -5.0, 25.0), GRBL), GRBL)
    # the design: the plane between the first and last pass, away from the raster's ends
    plane = PlaneSurface((0.0, 0.0, 0.0), (20.0, 0.0, 0.0), (0.0, float(levels[-1]), 0.0))
    expected = radius - math.sqrt(radius**2 - (stepover / 2) ** 2)
    report = verify_program(program, plane, router, ball6,
                            options=VerifyOptions(scallop_mm=expected, method=method))
    assert report.max_gouge is None
    assert report.max_scallop_mm == pytest.approx(expected, rel=0.05)
    # on the cusp line, half-way between two passes
    assert report.max_scallop.point_mm[1] % stepover == pytest.approx(stepover / 2, abs=0.02)
    assert report.stats.uncut_area_mm2 == 0.0 and report.stats.hidden_area_mm2 == 0.0
    # the cusp field is exact everywhere, not only at its top: median of the profile
    # h(y) = R - sqrt(R^2 - y^2), y uniform on [0, w/2]
    y = np.linspace(0.0, stepover / 2, 20001)
    median = float(np.median(radius - np.sqrt(radius**2 - y**2)))
    assert report.stats.percentiles_mm["p50"] == pytest.approx(median, rel=0.05, abs=2e-4)
