"""Issue 9: flat and bull-nose cutters are verified with the same rigour as the ball.

The swept-cutter kernel against the capsule (a bull-nose with no flat is a ball) and a
dense oracle; raster cusps on a plane against their closed forms; a shifted pass found at
its line; a 5-axis block's joint interpolation; the planner's scallop confirmed.
"""

import math

import numpy as np
import pytest
from verify_programs import five_axis_line, zigzag_raster

from gcode import GRBL, emit_text, parse
from machines import load_machine
from toolpath.planning import plan_finishing
from toolpath.planning.analytic import CylinderPatch, PlaneSurface
from toolpath.planning.cutters import parse_cutter
from verification import VerifyOptions, verify_program, verify_toolpath
from verification.capsule import line_capsule_interval
from verification.torus import core_signed_distance, line_sweep_interval


def _unit(v):
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _random_pairs(rng, m):
    p = rng.uniform(-3, 3, (m, 3))
    d = _unit(rng.normal(size=(m, 3)))
    c0 = rng.uniform(-2, 2, (m, 3))
    chord = rng.normal(size=(m, 3)) * rng.choice([0.0, 0.5, 3.0], (m, 1))
    axis = _unit(rng.normal(size=(m, 3)))
    return p, d, c0, chord, axis


def test_a_bull_nose_without_a_flat_is_the_ball_capsule(rng):
    p, d, c0, chord, axis = _random_pairs(rng, 2000)
    ball_in, ball_out = line_capsule_interval(p, d, c0, chord, (chord * chord).sum(1), 2.0)
    lam_in, lam_out = line_sweep_interval(p, d, c0, chord, axis, np.zeros(2000),
                                          core_radius_mm=0.0, corner_radius_mm=2.0,
                                          exit_wanted=np.ones(2000, dtype=bool))
    hit = np.isfinite(ball_in)
    np.testing.assert_array_equal(np.isfinite(lam_in), hit)
    np.testing.assert_allclose(lam_in[hit], ball_in[hit], atol=1e-9)
    np.testing.assert_allclose(lam_out[hit], ball_out[hit], atol=1e-9)


@pytest.mark.parametrize("corner", [1.0, 0.0])
def test_the_swept_cutter_kernel_matches_a_dense_oracle(rng, corner):
    core, height, m = 3.0 - corner, 3.0, 16
    p, d, c0, chord, axis = _random_pairs(rng, m)
    lam_in, lam_out = line_sweep_interval(p, d, c0, chord, axis, np.full(m, height),
                                          core_radius_mm=core, corner_radius_mm=corner,
                                          exit_wanted=np.ones(m, dtype=bool))
    lam = np.linspace(-12.0, 12.0, 2401)
    steps = 201
    for k in range(m):
        # the sweep sampled at 201 positions along its chord, the line every 10 um
        y = (p[k] + lam[:, None] * d[k])[None] - c0[k] - np.linspace(0, 1, steps)[
            :, None, None] * chord[k]
        flat = y.reshape(-1, 3)
        sd, _ = core_signed_distance(flat, np.tile(axis[k], (flat.shape[0], 1)),
                                     np.full(flat.shape[0], height), core)
        inside = (sd.reshape(steps, -1) <= corner).any(axis=0)
        if not inside.any():
            assert not np.isfinite(lam_in[k]) or lam_out[k] - lam_in[k] < 0.05
            continue
        # line and chord steps (a wall can meet the line at a grazing angle)
        slack = 0.01 + 2.0 * np.linalg.norm(chord[k]) / (steps - 1)
        assert lam_in[k] == pytest.approx(lam[inside][0], abs=slack)
        assert lam_out[k] == pytest.approx(lam[inside][-1], abs=slack)


def test_the_core_distance_is_the_planners_cutter_solid(rng):
    cutter = parse_cutter("bull:10:2")
    r = cutter.corner_radius_mm
    x = rng.uniform(-8, 8, (500, 3))
    tips = rng.uniform(-1, 1, (500, 3))
    axes = _unit(rng.normal(size=(500, 3)))
    sd, grad = core_signed_distance(x - tips - r * axes, axes,
                                    np.full(500, cutter.flute_length_mm - 2 * r),
                                    cutter.radius_mm - r)
    np.testing.assert_allclose(sd - r, cutter.signed_distance(x, tips, axes), atol=1e-12)
    h = 1e-6
    numeric = np.column_stack([
        (core_signed_distance(x - tips - r * axes + h * e, axes, np.full(500, 26.0), 3.0)[0]
         - core_signed_distance(x - tips - r * axes - h * e, axes, np.full(500, 26.0), 3.0)[0]
         ) / (2 * h) for e in np.eye(3)])
    np.testing.assert_allclose(grad, numeric, atol=1e-6)


def _plane_raster(router, spec, stepover, *, shift=None, passes=4, length=6.0):
    levels = np.arange(passes) * stepover
    text = emit_text(zigzag_raster(levels, -8.0, length + 8.0, shift=shift), GRBL)
    plane = PlaneSurface((0.0, 0.0, 0.0), (length, 0.0, 0.0), (0.0, float(levels[-1]), 0.0))
    report = verify_program(parse(text, GRBL), plane, router, parse_cutter(spec),
                            options=VerifyOptions(spacing_mm=0.1))
    return report, text


@pytest.mark.parametrize(("stepover", "gap"), [(5.0, 0.0), (7.0, 1.0)])
def test_a_flat_end_mill_leaves_no_scallop_where_its_bottoms_overlap(router, stepover, gap):
    report, _ = _plane_raster(router, "flat:6", stepover)
    assert report.max_gouge is None
    if gap == 0.0:
        assert report.max_scallop_mm < 1e-9 and report.stats.uncut_area_mm2 == 0.0
    else:
        # the strips between the flat bottoms are not cut at all (a flat end mill's wall
        # is vertical): three strips 1 mm wide, 6 mm long, to a grid step at each side
        assert report.stats.uncut_area_mm2 == pytest.approx(3 * gap * 6.0, abs=3 * 2 * 0.1 * 6)
        assert report.max_scallop_mm < 1e-9


@pytest.mark.parametrize("stepover", [5.0, 7.0, 7.6])
def test_a_bull_nose_raster_leaves_the_torus_cusp(router, stepover):
    report, _ = _plane_raster(router, "bull:10:2", stepover, passes=3)
    r, flat = 2.0, 6.0  # corner radius, width of the flat bottom
    over = max(stepover - flat, 0.0) / 2
    expected = r - math.sqrt(r * r - over * over)
    assert report.max_gouge is None and report.stats.uncut_area_mm2 == 0.0
    if expected == 0.0:
        assert report.max_scallop_mm < 1e-9
    else:
        assert report.max_scallop_mm == pytest.approx(expected, rel=0.05)
        assert report.max_scallop.point_mm[1] % stepover == pytest.approx(stepover / 2, abs=0.05)


@pytest.mark.parametrize("spec", ["flat:6", "bull:6:1"])
def test_a_shifted_pass_is_caught_at_its_line(router, spec):
    depth = 0.03
    report, text = _plane_raster(router, spec, 4.0, shift={1: -depth}, passes=3)
    lines = text.splitlines()
    pass_line = next(i + 1 for i, s in enumerate(lines) if "Y4Z-0.03" in s) + 1
    assert report.max_gouge is not None and report.max_gouge.line == pass_line
    assert report.max_gouge_mm == pytest.approx(depth, rel=0.02)
    assert report.gouging_blocks[0].line == pass_line


def test_a_big_rotary_block_with_a_bull_nose_shows_the_joint_interpolation_error():
    machine = load_machine("head-table-bc")
    bull = parse_cutter("bull:6:1")
    plane = PlaneSurface((-3.0, -3.0, 0.0), (11.0, 0.0, 0.0), (0.0, 6.0, 0.0))
    opts = VerifyOptions(spacing_mm=0.3, horizon_mm=0.05, refine=8)
    kw = {"tilt_deg": (10.0, 20.0), "length_mm": 6.0}
    big = verify_program(five_axis_line(machine, bull, 1, **kw), plane, machine, bull,
                         options=opts)
    assert big.joints.line == 3 and big.joints.max_mm > 1.0
    assert big.max_gouge is not None and big.max_gouge.line == 3 and big.max_gouge_mm > 1.0
    fine = verify_program(five_axis_line(machine, bull, 40, **kw), plane, machine, bull,
                          options=opts)
    assert fine.joints.max_mm < fine.gouge_tol_mm and fine.max_gouge is None


def test_the_planners_bull_nose_scallop_is_confirmed(router):
    bull = parse_cutter("bull:6:1")
    surface = CylinderPatch(radius_mm=20.0, angle_deg=(-8.0, 8.0), length_mm=(0.0, 4.0))
    tp, planned = plan_finishing(surface, bull, scallop_mm=0.01, chord_tol_mm=0.005,
                                 machine=router)
    exact = verify_toolpath(tp, surface, router, bull,
                            options=VerifyOptions(scallop_mm=0.01, merge_tol_mm=0.0))
    assert exact.max_scallop_mm == pytest.approx(planned.max_scallop_mm, rel=0.03)
    assert exact.max_gouge_mm == pytest.approx(planned.chord_overcut_mm, abs=3e-4)
    assert exact.stats.uncut_area_mm2 == 0.0
