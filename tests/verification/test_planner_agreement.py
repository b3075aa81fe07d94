"""Issue 9: the planner's reported scallop and chord error agree with verification."""

import pytest

from gcode import GRBL, PostOptions, emit_text, parse, post
from toolpath.planning import plan_finishing
from toolpath.planning.analytic import CylinderPatch, PlaneSurface
from verification import VerifyOptions, verify_program, verify_toolpath


@pytest.mark.parametrize(
    "surface",
    [PlaneSurface((0.0, 0.0, 0.0), (30.0, 0.0, 0.0), (0.0, 20.0, 0.0)),
     CylinderPatch(radius_mm=20.0, angle_deg=(-45.0, 45.0), length_mm=(0.0, 15.0))],
    ids=["plane", "cylinder"])
def test_planned_scallop_and_chord_error_are_confirmed(router, ball6, surface):
    scallop, chord = 0.01, 0.005
    tp, planned = plan_finishing(surface, ball6, scallop_mm=scallop, chord_tol_mm=chord,
                                 machine=router)
    opts = VerifyOptions(scallop_mm=scallop, merge_tol_mm=0.0)
    exact = verify_toolpath(tp, surface, router, ball6, options=opts)
    assert exact.max_scallop_mm == pytest.approx(planned.max_scallop_mm, rel=0.03)
    assert exact.max_scallop_mm <= scallop * 1.001
    assert exact.max_gouge_mm == pytest.approx(planned.chord_overcut_mm, abs=3e-4)
    assert exact.stats.uncut_area_mm2 == 0.0
    # the posted text, rounded to 1 um, moves the figures by at most about that much
    text = emit_text(post(tp, router, options=PostOptions(coolant=None, arcs=False)), GRBL)
    posted = verify_program(parse(text, GRBL), surface, router, ball6, options=opts)
    assert abs(posted.max_scallop_mm - exact.max_scallop_mm) < 1.2e-3 * 1.0
    assert abs(posted.max_gouge_mm - exact.max_gouge_mm) < 1.2e-3


def test_five_axis_planned_scallop_follows_the_joint_interpolation(ball6):
    # on the trunnion the A axis turns between points and the part sits far from its
    # pivot: the joint-interpolated tip bows off each short chord by microns, which the
    # report must include (tip-linear pieces reported 0.0076 mm where 0.0086 mm stood)
    from machines import load_machine
    from toolpath.planning.setup import centred_on_table, rotation_from_spec

    trunnion = load_machine("trunnion-ac")
    surface = centred_on_table(CylinderPatch(radius_mm=20.0, angle_deg=(-60.0, 60.0),
                                             length_mm=(0.0, 15.0)), rotation_from_spec("x:0"))
    tp, planned = plan_finishing(surface, ball6, scallop_mm=0.01, chord_tol_mm=0.005,
                                 machine=trunnion, axis_mode="lead-tilt", lead_deg=10.0)
    exact = verify_toolpath(tp, surface, trunnion, ball6,
                            options=VerifyOptions(scallop_mm=0.01, merge_tol_mm=0.0))
    assert exact.max_scallop_mm == pytest.approx(planned.max_scallop_mm, rel=0.03)
    assert exact.max_scallop_mm <= 0.01
