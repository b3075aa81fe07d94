"""Auto linking: a spiral round a closed blade under 5-axis (C one way, no retracts), zigzag
with extended ends on an open blunt blade (verified), and the blunt face reported."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

from streamline_cam.commands.run import report_lines
from streamline_cam.pipeline import JobRequest, run_job
from toolpath.paper_examples import bundled_data_path
from toolpath.path import MoveKind, Toolpath
from toolpath.planning.options import AxisMode, Linking, chosen_linking

WORD = re.compile(r"([A-Z])(-?\d+(?:\.\d*)?)")


def _closed_blade_csv(path: Path) -> Path:
    # elliptic sections (nose radius about 1 mm) twisting up a 40 mm span, 60 points each,
    # the first point not repeated: read closed, fitted periodic
    theta = np.linspace(0.0, 2 * np.pi, 60, endpoint=False) + 0.1
    rows = ["section,x,y,z"]
    for j, h in enumerate(np.linspace(0.0, 1.0, 6)):
        a, b, twist = 15.0 - h, 4.0 - 0.5 * h, 0.3 * h
        x, y = a * np.cos(theta), b * np.sin(theta)
        c, s = np.cos(twist), np.sin(twist)
        rows += [f"{j},{p:.6f},{q:.6f},{8.0 * j:.6f}"
                 for p, q in zip(c * x - s * y, s * x + c * y, strict=True)]
    path.write_text("\n".join(rows) + "\n")
    return path


def _moves(text: str) -> list[tuple[int, dict[str, float], bool]]:
    """(G motion mode, words, inverse time) per motion block of a posted program."""
    mode, inverse, out = None, False, []
    for line in text.splitlines():
        line = re.sub(r"\(.*?\)|;.*", "", line).upper()
        words = WORD.findall(line)
        for letter, value in words:
            if letter == "G" and float(value) in (0.0, 1.0):
                mode = int(float(value))
            elif letter == "G" and float(value) in (93.0, 94.0):
                inverse = float(value) == 93.0
        axes = {k: float(v) for k, v in words if k in "XYZAC" or k == "F"}
        if mode is not None and set(axes) - {"F"}:
            out.append((mode, axes, inverse))
    return out


@pytest.mark.parametrize(("closed", "axis", "want"), [
    (True, AxisMode.LEAD_TILT, Linking.SPIRAL), (True, AxisMode.FIXED, Linking.ZIGZAG),
    (False, AxisMode.LEAD_TILT, Linking.ZIGZAG), (False, AxisMode.FIXED, Linking.ZIGZAG)])
def test_auto_linking_is_spiral_only_round_closed_sections_in_5_axis(closed, axis, want):
    chosen, why = chosen_linking(Linking.AUTO, closed, axis)
    assert chosen is want and why.startswith("auto")
    assert chosen_linking(Linking.ONEWAY, closed, axis)[0] is Linking.ONEWAY


def test_spiral_round_a_closed_blade_turns_c_one_way_without_retracts(tmp_path):
    request = JobRequest(_closed_blade_csv(tmp_path / "closed.csv"), machine="trunnion-ac",
                         axis_mode="lead-tilt", scallop_mm=0.1, chord_tol_mm=0.03)
    result = run_job(request, tmp_path)
    plan = result.report["plan"]
    assert plan["linking"] == "spiral" and "closed" in plan["linking_reason"]
    assert result.report["check"]["errors"] == 0
    # the toolpath: nothing but cuts and links from the first to the last cutting move
    path = Toolpath.load(result.files["toolpath"])
    cut = np.flatnonzero(path.kinds == MoveKind.CUT)
    between = path.kinds[cut[0]:cut[-1] + 1]
    assert np.isin(between, [MoveKind.CUT, MoveKind.LINK]).all()
    # the posted program: C never turns back, over the whole program, and no rapid (nor a
    # switch out of inverse time) between the first and the last feed move that turns C
    moves = _moves(result.files["gcode"].read_text())
    c = np.array([m[1]["C"] for m in moves if "C" in m[1]])
    steps = np.diff(c)
    assert abs(c[-1] - c[0]) > 10 * 360.0  # many turns round the blade
    assert (np.sign(steps[steps != 0.0]) == np.sign(c[-1] - c[0])).all()
    turning = [i for i, (mode, words, _) in enumerate(moves) if mode == 1 and "C" in words]
    inside = moves[turning[0]:turning[-1] + 1]
    assert all(mode == 1 and inverse for mode, _, inverse in inside)
    # the rotary rates: reported, and the program keeps C within the machine's rate (the
    # inverse-time F is moves per minute: |dC| * F / 60 deg/s)
    rot = plan["rotary_rates"]
    assert rot["c_one_way"] and rot["max_deg_per_mm"] > 0.0
    assert rot["limit_deg_per_s"] == pytest.approx(18000.0 / 60.0)
    last_c, programmed = None, []
    for _, words, inverse in moves:
        if "C" in words and last_c is not None and inverse:
            programmed.append(abs(words["C"] - last_c) * words.get("F", np.nan) / 60.0)
        last_c = words.get("C", last_c)
    programmed = np.array(programmed)
    assert np.nanmax(programmed) <= rot["limit_deg_per_s"] * 1.001
    assert plan["max_axis_rate_deg_per_mm"] <= plan["axis_rate_limit_deg_per_mm"] * 1.001
    assert any(line.startswith("rotary ") and "C turns one way" in line
               for line in report_lines(result.report))


@pytest.mark.slow
def test_open_blunt_blade_extended_zigzag_verifies_and_reports_the_face(tmp_path):
    # the open rotor's 0.4 mm TE base is not sampled: passes run 3 mm past both corners
    # and link there; the independent verifier finds no gouge beyond the chord tolerance
    request = JobRequest(Path(bundled_data_path("dev_rotor_blunt_9x120.csv")),
                         machine="trunnion-ac", axis_mode="lead-tilt", scallop_mm=0.5,
                         chord_tol_mm=0.05, planning_options={"extend_mm": 3.0})
    result = run_job(request, tmp_path, verify=True)
    report = json.loads(result.files["report"].read_text())
    plan = report["plan"]
    assert plan["linking"] == "zigzag" and "open" in plan["linking_reason"]
    gouge = (report["verify"].get("max_gouge") or {}).get("deviation_mm") or 0.0
    assert -gouge <= 0.05
    face = plan["blunt_face"]
    assert face["min_width_mm"] == pytest.approx(0.4, abs=0.02)
    assert face["max_width_mm"] == pytest.approx(0.4, abs=0.02)
    assert 60.0 < face["span_mm"] < 120.0
    assert any(line.startswith("uncut ") and "blunt edge face" in line
               for line in report_lines(report))


def test_blunt_face_is_the_gap_between_an_open_sections_ends_not_an_open_sheet():
    from toolpath import fit_streamline_surface
    from toolpath.planning.analytic import PlaneSurface
    from toolpath.planning.blunt_edge import blunt_face

    # elliptic sections opened by 2 delta about the x = a end: ends 2 b sin(delta) apart
    delta, b = 0.05, 4.0
    theta = np.linspace(delta, 2 * np.pi - delta, 80)
    sections = [np.c_[15.0 * np.cos(theta), b * np.sin(theta), np.full(theta.size, z)]
                for z in (0.0, 10.0, 20.0, 30.0)]
    surface = fit_streamline_surface(sections, tol=0.005, closed=False)
    face = blunt_face(surface, min_width_mm=0.01)
    assert face.min_width_mm == pytest.approx(2 * b * np.sin(delta), abs=0.005)
    assert face.span_mm == pytest.approx(30.0, abs=0.05)
    assert blunt_face(surface, min_width_mm=0.5) is None  # narrower than the tolerance
    assert blunt_face(PlaneSurface(), min_width_mm=0.01) is None  # a sheet's far edges


def test_one_way_azimuth_holds_the_table_through_a_back_turn():
    from toolpath.planning.one_way import one_way_azimuth

    # horizontal axes turning two turns round +Z, turning back twice a turn (a concave
    # pressure side); the normals are the axes themselves
    x = np.linspace(0.0, 4 * np.pi, 721)
    phi = x - 0.7 * np.sin(2 * x)
    axes = np.c_[np.cos(phi), np.sin(phi), np.zeros_like(phi)]
    assert (np.diff(np.unwrap(phi)) < 0).any()
    done = one_way_azimuth(axes, axes, max_lean_deg=60.0)
    turned = np.unwrap(np.arctan2(done.axes[:, 1], done.axes[:, 0]))
    assert (np.diff(turned) >= -1e-12).all()
    assert np.allclose(np.linalg.norm(done.axes, axis=1), 1.0)
    back = np.max(np.maximum.accumulate(phi) - phi)
    assert 0.0 < done.max_turn_deg <= np.degrees(back) / 2 + 1e-9
    # already monotone where phi was: untouched far from the back-turns
    far = np.cos(2 * x) < -0.5
    assert np.allclose(turned[far], phi[far], atol=1e-9)
    # a lean limit the turn would break: the axes stay as they were
    assert one_way_azimuth(axes, axes, max_lean_deg=done.max_turn_deg / 2).turned_points == 0
