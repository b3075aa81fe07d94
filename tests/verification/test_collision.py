"""Collision search: a rapid through the part and a thin wall nicked from behind."""

import pytest
from verify_programs import zigzag_raster

from gcode import Linear, Program, Rapid
from toolpath.planning.analytic import PlaneSurface
from verification import VerifyOptions, verify_program


def test_a_rapid_through_the_part_is_reported_as_a_deep_gouge_at_its_line(router, ball6):
    honest = zigzag_raster([0.0, 0.8, 1.6, 2.4], -5.0, 15.0)
    # after the raster, a rapid dives 4 mm into the part across it
    crash = Program((*honest.blocks[:-1], Rapid(x=-6.0, y=1.2, z=-4.0),
                     Rapid(x=16.0, y=1.2, z=-4.0), Rapid(z=5.0)))
    plane = PlaneSurface((0.0, 0.0, 0.0), (10.0, 0.0, 0.0), (0.0, 2.4, 0.0))
    report = verify_program(crash, plane, router, ball6, options=VerifyOptions(spacing_mm=0.1))
    assert report.max_gouge is not None and report.max_gouge.rapid
    assert report.max_gouge.block_index == len(crash) - 2
    assert report.max_gouge_mm == pytest.approx(4.0, abs=0.01)  # the tip 4 mm down
    no_collision = verify_program(crash, plane, router, ball6,
                                  options=VerifyOptions(spacing_mm=0.1, collision=False))
    assert no_collision.max_gouge_mm <= report.max_gouge_mm


def test_a_ball_on_the_other_side_of_a_thin_wall_counts_by_how_far_it_pokes_through(
        router, ball6):
    # the design: the underside of a 0.5 mm sheet (normal -Z, the material above it); the
    # cutter comes from above, through the sheet, its tip 0.3 mm below the underside (a
    # strip 2 sqrt(2 R 0.3) = 2.7 mm wide: wider than the collision search's spacing)
    underside = PlaneSurface((0.0, 0.0, 0.0), (0.0, 10.0, 0.0), (10.0, 0.0, 0.0))
    assert underside.normal(0.5, 0.5)[2] == pytest.approx(-1.0)
    program = Program((Rapid(x=-5.0, y=5.0, z=5.0), Linear(z=-0.3, feed=300.0),
                       Linear(x=15.0, feed=800.0), Rapid(z=5.0)))
    report = verify_program(program, underside, router, ball6,
                            options=VerifyOptions(spacing_mm=0.1))
    # it pokes 0.3 mm out through the underside (not the 6 mm of tool behind it)
    assert report.max_gouge_mm == pytest.approx(0.3, abs=1e-3)
    assert report.max_gouge.block_index == 2
