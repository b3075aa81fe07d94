"""The fine model around the extremes holds every near search its levels may make.

The fine levels move a design point ``P`` by up to a third of a grid step, but the near
search runs around the centre ``c = P + R n``, which on a convex surface moves
``(1 + R kappa)`` times as fast: a 3 mm ball on a 1.5 mm convex dome moves its centre 3
times as far as the point. The stretches of path the fine model replays must cover the
near search around every centre of the parameter box the levels may visit, not only a
margin of the design point's own drift around the box's middle.
"""


import numpy as np
import pytest
from verify_programs import DEPTH_MM, DOME_MM, LEVEL_MM, convex_dome_model

from gcode import GRBL, Linear, Program, Rapid, emit_text, parse
from machines import load_machine
from toolpath.planning.analytic import PlaneSurface
from toolpath.planning.cutters import parse_cutter
from verification import VerifyOptions, verify_program
from verification.fine_model import box_centres
from verification.samples import surface_points_normals


def test_the_fine_model_holds_the_near_search_of_every_point_of_its_boxes():
    dome, ev, fine = convex_dome_model()
    t0, s0 = np.array([0.5]), np.array([0.5])
    half_t, half_s = 0.02, 0.03  # 0.032 mm and 0.031 mm of the dome at its middle
    conv = np.array([1.0 / DOME_MM])
    centres, slack = box_centres(dome, t0, s0, half_t, half_s, ev.corner)
    held = set(fine.rows_around(centres, slack, conv, level_mm=LEVEL_MM,
                                depth_mm=DEPTH_MM)[0].tolist())
    # every point of the box, on a grid finer than the one measured, and at random
    off = np.linspace(-1.0, 1.0, 33)
    t = np.concatenate(((t0 + half_t * off[:, None] + 0 * off).ravel(),
                        t0 + half_t * np.random.default_rng(3).uniform(-1, 1, 300)))
    s = np.concatenate(((s0 + half_s * off[None, :] + 0 * off[:, None]).ravel(),
                        s0 + half_s * np.random.default_rng(4).uniform(-1, 1, 300)))
    points, normals, _ = surface_points_normals(dome, t, s)
    mid, mid_normal, _ = surface_points_normals(dome, t0, s0)
    c = points + ev.corner * normals
    r_c = ev.near_radius_mm(LEVEL_MM, DEPTH_MM, np.repeat(conv, c.shape[0]))
    needed = set(fine.rows_within(c, r_c).tolist())
    assert needed and needed <= held
    # the centres move (1 + R / rho) = 3 times as far as the points: a margin of twice the
    # points' drift around the middle's centre misses stretches some of those searches need
    drift = float(np.max(np.linalg.norm(points - mid, axis=1)))
    c0 = mid + ev.corner * mid_normal
    assert float(np.max(np.linalg.norm(c - c0, axis=1))) > 2.5 * drift
    old = set(fine.rows_within(c0, ev.near_radius_mm(LEVEL_MM, DEPTH_MM, conv)
                               + 2.0 * drift).tolist())
    assert not needed <= old


@pytest.mark.parametrize("spec", ["flat:6", "bull:6:0.5"])
def test_a_flank_gouge_high_up_the_cutter_stays_in_the_fine_model(spec):
    # one pass with the tip at z 0 gouges a wall leaning in over it with the cutter's
    # flank 2.5 mm up; a second pass higher up leaves material there. The gouging pass's
    # segment stands farther from the near-search centre than the reach of a ball, but its
    # core reaches the wall: the fine model must replay it, or the gouge drops out
    blocks = [Rapid(z=5.0), Rapid(x=-8.0, y=0.0), Linear(z=0.0, feed=300.0),
              Linear(x=8.0, y=0.0, z=0.0, feed=800.0), Rapid(z=5.0),
              Rapid(x=8.0, y=-0.1), Linear(z=1.5, feed=300.0),
              Linear(x=-8.0, y=-0.1, z=1.5, feed=800.0), Rapid(z=5.0)]
    program = parse(emit_text(Program(tuple(blocks)), GRBL), GRBL)
    wall = PlaneSurface((-2.0, 3.0, 0.5), (4.0, 0.0, 0.0), (0.0, -0.05, 2.0))
    report = verify_program(program, wall, load_machine("grbl-router"), parse_cutter(spec),
                            options=VerifyOptions(spacing_mm=0.1, scallop_mm=0.05))
    assert report.max_gouge_mm == pytest.approx(0.05, abs=1e-3)
