"""Issue 24 (2): gouges decided by the depth the cutter sinks in, not by a concave radius.

A fit's ripple (a concave radius far below the cutter's, a fraction of a micrometre deep)
plans; a notch the cutter really sinks into is refused naming the depth, the place and the
command-line remedy, or lifted clear with ``--on-gouge lift``. Gouges on the results are
measured by the independent verifier (``verification``), not the planner's own model.
"""

import json

import numpy as np
import pytest

from machines import load_machine
from streamline_cam.cli import main
from toolpath.planning import GougeError, PocketSurface, parse_cutter, plan_finishing
from toolpath.planning.avoid import gouge_depth_mm, local_depth_mm
from toolpath.planning.gouge import GOUGE_TOL_MM
from toolpath.planning.local import pass_frame
from verification import VerifyOptions, verify_toolpath

BALL = "ball:6"
#: A 0.3 um deep dimple 6 um wide: concave radius 0.12 mm, 25 times smaller than the ball.
RIPPLE = PocketSurface(size_mm=(12.0, 8.0), centre_mm=(6.0, 4.0), depth_mm=0.0003,
                       width_mm=0.006)
#: A 1 mm deep notch 1 mm wide: concave radius 1 mm, under the ball's 3 mm.
NOTCH = PocketSurface(size_mm=(12.0, 8.0), centre_mm=(6.0, 4.0), depth_mm=1.0,
                      width_mm=1.0)
PLAN = {"scallop_mm": 0.02, "chord_tol_mm": 0.01}


def _brute_depth(surface, cutter, t, s, axis, *, half_mm=6.0, n=801):
    """Deepest penetration of the cutter touching at (t, s), over a dense grid, mm.

    The grid spans ``half_mm`` each way round the contact (the pocket surfaces are
    uniform: ``x = x0 + t Lx``, ``y = y0 + s Ly``).
    """
    contact, normal = surface(t, s), surface.normal(t, s)
    tip = cutter.tips_from_contacts(contact[None], normal[None], axis[None])
    lx, ly = surface.size
    gt = np.clip(np.linspace(t - half_mm / lx, t + half_mm / lx, n), 0.0, 1.0)
    gs = np.clip(np.linspace(s - half_mm / ly, s + half_mm / ly, n), 0.0, 1.0)
    pts = surface(gt, gs, grid=True).reshape(-1, 3)
    return max(-cutter.signed_distance(pts, tip, axis[None]).min(), 0.0)


def test_measured_depth_tells_a_ripple_from_a_notch():
    cutter = parse_cutter(BALL)
    up = np.array([[0.0, 0.0, 1.0]])
    depth = {}
    for name, surface, radius, half in (("ripple", RIPPLE, 0.12, 0.1),
                                        ("notch", NOTCH, 1.0, 6.0)):
        assert surface.min_concave_radius_mm == pytest.approx(radius)
        frame = pass_frame(surface, np.array([0.5]), np.array([0.5]))
        # the curvature alone calls both a gouge (the old test)
        assert local_depth_mm(frame, cutter, up)[0] > 10 * GOUGE_TOL_MM
        tip = cutter.tips_from_contacts(frame.point, frame.normal, up)
        found = gouge_depth_mm(surface, cutter, [0.5], [0.5], tip, up,
                               speed_t=frame.speed_t, speed_s=frame.speed_s)
        brute = _brute_depth(surface, cutter, 0.5, 0.5, up[0], half_mm=half)
        assert found.depth_mm[0] == pytest.approx(brute, rel=0.02)
        depth[name] = found.depth_mm[0]
    # the ripple costs at most its depth, the notch a real cut
    assert 0.0 < depth["ripple"] <= RIPPLE.depth < GOUGE_TOL_MM / 3
    assert depth["notch"] > 5 * GOUGE_TOL_MM


def test_a_ripple_narrower_than_the_cutter_plans_and_verifies_clean():
    router = load_machine("grbl-router")
    path, rep = plan_finishing(RIPPLE, BALL, machine=router, **PLAN)
    # the plan met the ripple (its smallest concave radius) and cut across it
    assert rep.min_concave_radius_mm == pytest.approx(0.12, rel=0.05)
    assert rep.n_lifted == 0
    exact = verify_toolpath(path, RIPPLE, router, parse_cutter(BALL),
                            options=VerifyOptions(scallop_mm=PLAN["scallop_mm"]))
    assert exact.max_gouge_mm <= PLAN["chord_tol_mm"] + 0.001
    assert exact.stats.uncut_area_mm2 == 0.0


def test_a_notch_is_refused_naming_depth_place_and_the_flag():
    with pytest.raises(GougeError) as err:
        plan_finishing(NOTCH, BALL, **PLAN)
    text, e = str(err.value), err.value
    assert f"would cut {e.depth_mm:.4f} mm into the surface at t={e.t:.5f}, s={e.s:.5f}" in text
    assert "--on-gouge lift" in text and "--gouge-tol" in text and "radius < 1.000" in text
    assert "inf" not in text and "on_gouge=" not in text
    # the depth named is the verifier-independent brute force one at that place
    assert e.depth_mm == pytest.approx(
        _brute_depth(NOTCH, parse_cutter(BALL), e.t, e.s, np.array([0.0, 0.0, 1.0])),
        rel=0.02)
    assert e.depth_mm > 5 * GOUGE_TOL_MM
    # a tolerance above that depth accepts it
    plan_finishing(NOTCH, BALL, gouge_tol_mm=e.depth_mm * 1.01, measure=False, **PLAN)


def test_plan_cli_refuses_a_notch_then_lifts_it_clear(tmp_path, capsys):
    from toolpath.path import Toolpath

    src = tmp_path / "notch.json"
    src.write_text(json.dumps(NOTCH.to_dict()))
    out = tmp_path / "path.npz"
    args = ["plan", str(src), "--machine", "grbl-router", "--scallop", "0.02",
            "--chord-tol", "0.01", "--no-measure", "-o", str(out)]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "mm into the surface at t=" in err and "--on-gouge lift" in err
    router, cutter = load_machine("grbl-router"), parse_cutter(BALL)
    opts = VerifyOptions(scallop_mm=0.02)
    deepest = {}
    for flag in (["--gouge-tol", "1"], ["--on-gouge", "lift"]):
        assert main([*args, *flag]) == 0
        text = capsys.readouterr().out
        assert ("lifted" in text) == (flag[0] == "--on-gouge")
        deepest[flag[0]] = verify_toolpath(Toolpath.load(out), NOTCH, router, cutter,
                                           options=opts).max_gouge_mm
    # accepted, the notch is gouged as deep as refused; lifted, no deeper than a chord
    # dips into a convex surface (the request) and the rounding
    assert deepest["--gouge-tol"] > 0.05
    assert deepest["--on-gouge"] <= 0.01 + 0.001


def test_run_hands_the_gouge_flags_to_the_planner():
    import argparse
    from pathlib import Path

    from streamline_cam.commands.run import add_job_arguments, request_from_args

    parser = argparse.ArgumentParser()
    add_job_arguments(parser)
    args = parser.parse_args(["--on-gouge", "lift", "--gouge-tol", "0.002", "--on-limit",
                              "report", "--lead-radius", "0", "--clearance", "8"])
    options = request_from_args(Path("blade.csv"), args).planning_options
    assert options == {"on_gouge": "lift", "gouge_tol_mm": 0.002, "on_limit": "report",
                       "lead_radius_mm": 0.0, "approach_mm": 2.0, "clearance_mm": 8.0}
    defaults = request_from_args(Path("blade.csv"), parser.parse_args([])).planning_options
    assert defaults["on_gouge"] == "raise" and defaults["gouge_tol_mm"] == GOUGE_TOL_MM
