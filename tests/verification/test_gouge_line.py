"""Issue 9: a program that gouges (one pass shifted into the surface) is caught at its line."""

from dataclasses import replace

import pytest
from verify_programs import zigzag_raster

from gcode import GRBL, LINUXCNC, Units, emit_text, parse
from toolpath.planning.analytic import PlaneSurface
from verification import VerifyOptions, verify_program


@pytest.mark.parametrize("depth", [0.03, 0.4])
def test_a_pass_shifted_into_the_surface_is_reported_at_its_line(router, ball6, depth):
    levels = [0.0, 0.8, 1.6, 2.4, 3.2, 4.0]
    shifted = 3
    program = zigzag_raster(levels, -5.0, 15.0, shift={shifted: -depth})
    text = emit_text(program, GRBL)
    parsed = parse(text, GRBL)
    lines = text.splitlines()
    # the shifted pass is the move along Y = 2.4 at Z = -depth
    want = [i + 1 for i, s in enumerate(lines) if f"Z-{depth:g}" in s or
            (s.startswith("X") and "Y" not in s and "Z" not in s)]
    pass_line = next(i + 1 for i, s in enumerate(lines)
                     if "Y2.4" in s and f"Z-{depth:g}" in s) + 1
    assert pass_line in want
    plane = PlaneSurface((0.0, 0.0, 0.0), (10.0, 0.0, 0.0), (0.0, 4.0, 0.0))
    report = verify_program(parsed, plane, router, ball6, options=VerifyOptions(spacing_mm=0.1))
    assert report.max_gouge is not None
    assert report.max_gouge.line == pass_line
    assert report.max_gouge.block_index is not None
    assert parsed.source_lines[report.max_gouge.block_index] == pass_line
    assert report.max_gouge_mm == pytest.approx(depth, rel=0.02)
    assert report.max_gouge.point_mm[1] == pytest.approx(2.4, abs=0.1)
    assert report.gouging_blocks[0].line == pass_line
    # every gouging block is the shifted pass or one of the links into and out of it
    assert {b.line for b in report.gouging_blocks} <= {pass_line - 1, pass_line, pass_line + 1}


def test_an_honest_raster_has_no_gouge_and_a_mid_pass_line_for_the_scallop(router, ball6):
    levels = [0.0, 0.8, 1.6, 2.4]
    text = emit_text(zigzag_raster(levels, -5.0, 15.0), LINUXCNC)
    parsed = parse(text, LINUXCNC)
    plane = PlaneSurface((0.0, 0.0, 0.0), (10.0, 0.0, 0.0), (0.0, 2.4, 0.0))
    report = verify_program(parsed, plane, router, ball6, options=VerifyOptions(spacing_mm=0.1))
    assert report.max_gouge is None and report.gouging_blocks == ()
    assert text.splitlines()[report.max_scallop.line - 1].startswith(("X", "G1"))


def test_an_inch_program_is_verified_in_millimetres(router, ball6):
    program = zigzag_raster([0.0, 0.8, 1.6, 2.4], -5.0, 15.0, shift={2: -0.0254})
    plane = PlaneSurface((0.0, 0.0, 0.0), (10.0, 0.0, 0.0), (0.0, 2.4, 0.0))
    opts = VerifyOptions(spacing_mm=0.1)
    mm = verify_program(parse(emit_text(program, LINUXCNC), LINUXCNC), plane, router, ball6,
                        options=opts)
    inch_text = emit_text(replace(program, units=Units.INCH), LINUXCNC)
    assert "G20" in inch_text
    inch = verify_program(parse(inch_text, LINUXCNC), plane, router, ball6, options=opts)
    assert inch.max_gouge_mm == pytest.approx(0.0254, abs=2e-4)
    # the mm text rounds -0.0254 to -0.025 (3 decimals); the inch text holds -0.001 in
    assert inch.max_gouge_mm == pytest.approx(mm.max_gouge_mm, abs=5e-4)
    assert inch.max_gouge.line == mm.max_gouge.line
