"""Issue 9: a ball-end raster on a plane leaves the scallop h = R - sqrt(R^2 - (w/2)^2)."""

import math

import numpy as np
import pytest
from verify_programs import zigzag_raster

from gcode import GRBL, Linear, Program, Rapid, emit_text, parse
from toolpath.planning.analytic import CylinderPatch, PlaneSurface
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


def test_material_facing_away_from_a_fixed_axis_is_unreachable_not_scallop(router, ball6):
    # a 3-axis raster over a cylinder (R 10 about X) down to 88 deg from the top; the
    # design runs on to 93 deg, past the equator: there it faces down, no move of a fixed
    # +Z axis cuts to it and the passing ball's side leaves up to 0.16 mm (within the
    # horizon, so "cut"). That is not a scallop between passes: it is reported as facing
    # away, and the scallop is the raster's
    radius, r = 10.0, ball6.radius_mm
    centre = np.array([0.0, 0.0, -10.0])
    blocks = [Rapid(z=20.0)]
    for k, angle in enumerate(np.radians(np.arange(-88.0, 88.1, 2.0))):
        tip = centre + (radius + r) * np.array([0.0, np.sin(angle), np.cos(angle)]) \
            - [0.0, 0.0, r]
        ends = (-5.0, 35.0) if k % 2 == 0 else (35.0, -5.0)
        blocks += [Linear(x=x, y=float(tip[1]), z=float(tip[2]), feed=800.0) for x in ends]
    blocks.append(Rapid(z=20.0))
    cylinder = CylinderPatch(radius, centre, (-93.0, 93.0), (0.0, 30.0))
    width = radius * np.radians(2.0)  # between contacts; the cusp on a convex cylinder:
    cusp = width**2 / 8.0 * (1.0 / r + 1.0 / radius)
    report = verify_program(Program(tuple(blocks)), cylinder, router, ball6,
                            options=VerifyOptions(scallop_mm=0.01))
    assert report.stats.uncut_area_mm2 == 0.0  # the ball's side reaches all of it
    facing_down = 30.0 * radius * np.radians(2 * 3.0)  # 90..93 deg on both sides, mm^2
    assert report.faces_away_area_mm2 == pytest.approx(facing_down, rel=0.15)
    assert report.max_excess.deviation_mm > 0.1  # what the side left down there
    assert report.max_scallop_mm == pytest.approx(cusp, rel=0.1)
    assert abs(report.max_scallop.point_mm[2] - centre[2]) > 1.0  # not near the equator
    assert any("facing away" in line for line in report.lines())
