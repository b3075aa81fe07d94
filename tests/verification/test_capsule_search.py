"""The compiled searches against the exact pair search they replace (the oracle).

The pair search expands every candidate (dexel, piece) pair in numpy and folds the
minimum; the compiled walks (ball: capsules; flat and bull-nose: swept cutters, issue 28)
meet the same candidates, skip the pieces their bounds rule out, and seek only below what
an earlier search found. Both must leave the same material on every dexel, traced to the
same block.
"""


import numpy as np
import pytest
from search_oracle import assert_same_material, compiled_and_oracle
from verify_programs import five_axis_line, zigzag_raster

from gcode import Linear, Program, Rapid
from machines import load_machine
from toolpath.planning.analytic import PlaneSurface, SpherePatch
from toolpath.planning.cutters import parse_cutter
from verification import VerifyOptions


def test_a_raster_with_a_deep_pass_and_a_rapid_through_the_part(monkeypatch, router, ball6):
    honest = zigzag_raster([0.0, 0.8, 1.6, 2.4], -5.0, 15.0, shift={2: -0.05})
    crash = Program((*honest.blocks[:-1], Rapid(x=-6.0, y=1.2, z=-4.0),
                     Rapid(x=16.0, y=1.2, z=-4.0), Rapid(z=5.0)))
    plane = PlaneSurface((0.0, 0.0, 0.0), (10.0, 0.0, 0.0), (0.0, 2.4, 0.0))
    assert_same_material(*compiled_and_oracle(
        monkeypatch, crash, plane, router, ball6, options=VerifyOptions(spacing_mm=0.1)))


def test_a_thin_wall_nicked_from_behind(monkeypatch, router, ball6):
    underside = PlaneSurface((0.0, 0.0, 0.0), (0.0, 10.0, 0.0), (10.0, 0.0, 0.0))
    program = Program((Rapid(x=-5.0, y=5.0, z=5.0), Linear(z=-0.3, feed=300.0),
                       Linear(x=15.0, feed=800.0), Rapid(z=5.0)))
    assert_same_material(*compiled_and_oracle(
        monkeypatch, program, underside, router, ball6, options=VerifyOptions(spacing_mm=0.1)))


@pytest.mark.parametrize("machine_name", ["trunnion-ac", "head-table-bc"])
def test_five_axis_blocks_swinging_the_tool(monkeypatch, ball6, machine_name):
    machine = load_machine(machine_name)
    program = five_axis_line(machine, ball6, 40, tilt_deg=(5.0, 60.0), lean="y")
    plane = PlaneSurface((0.0, -2.0, 0.0), (20.0, 0.0, 0.0), (0.0, 4.0, 0.0))
    assert_same_material(*compiled_and_oracle(
        monkeypatch, program, plane, machine, ball6,
        options=VerifyOptions(spacing_mm=0.08, scallop_mm=0.005)))


def test_a_sphere_raster_with_uncut_stock(monkeypatch, router, ball6):
    # convex: the near search widens; passes 1.2 mm apart leave cusps up to the horizon
    sphere = SpherePatch(radius_mm=30.0, colatitude_deg=(5.0, 30.0), longitude_deg=(0, 90))
    blocks = [Rapid(z=40.0), Rapid(x=0.0, y=0.0)]
    for k, y in enumerate(np.arange(0.0, 14.0, 1.2)):
        xs = np.arange(0.0, 14.0, 0.5)
        xs = xs if k % 2 == 0 else xs[::-1]
        z = np.sqrt(np.maximum(33.0**2 - xs**2 - y**2, 0.0)) - 3.0
        blocks += [Linear(x=float(x), y=float(y), z=float(h), feed=900.0)
                   for x, h in zip(xs, z, strict=True)]
    assert_same_material(*compiled_and_oracle(
        monkeypatch, Program(tuple(blocks)), sphere, router, ball6,
        options=VerifyOptions(spacing_mm=0.15)))


@pytest.mark.parametrize("spec", ["flat:6", "bull:6:1"])
def test_flat_and_bull_nose_five_axis_blocks(monkeypatch, spec):
    # the axis turns along every block: pieces cut short, the case the walk is for
    machine = load_machine("trunnion-ac")
    cutter = parse_cutter(spec)
    program = five_axis_line(machine, cutter, 4, tilt_deg=(5.0, 12.0), length_mm=4.0,
                             lean="y")
    plane = PlaneSurface((0.0, -2.0, 0.0), (4.0, 0.0, 0.0), (0.0, 4.0, 0.0))
    assert_same_material(*compiled_and_oracle(
        monkeypatch, program, plane, machine, cutter,
        options=VerifyOptions(spacing_mm=0.3, horizon_mm=0.1, refine=4)))


@pytest.mark.parametrize("spec", ["flat:6", "bull:6:1"])
def test_flat_and_bull_nose_raster_with_a_deep_pass_and_a_rapid(monkeypatch, router, spec):
    honest = zigzag_raster([0.0, 4.0, 8.0], -5.0, 11.0, shift={1: -0.05})
    crash = Program((*honest.blocks[:-1], Rapid(x=-6.0, y=6.0, z=-4.0),
                     Rapid(x=12.0, y=6.0, z=-4.0), Rapid(z=5.0)))
    plane = PlaneSurface((0.0, 0.0, 0.0), (6.0, 0.0, 0.0), (0.0, 8.0, 0.0))
    assert_same_material(*compiled_and_oracle(
        monkeypatch, crash, plane, router, parse_cutter(spec),
        options=VerifyOptions(spacing_mm=0.2, refine=4)))
