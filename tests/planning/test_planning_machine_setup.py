"""Issue 24 item 5: the part placed inside the travel, the tool axis leaned inside the tilt."""

import json
from pathlib import Path

import numpy as np
import pytest

from gcode.post import post
from machines import load_machine
from machines.kinematics import solve_inverse, tilt_reach_deg
from machines.limits import check_travel
from toolpath import as_sections, read_sections, surface_from_dict
from toolpath.placement import Placement
from toolpath.planning import PlaneSurface, PlanTravelLimitError, plan_finishing
from toolpath.planning.analytic import CylinderPatch
from toolpath.planning.cutters import parse_cutter
from toolpath.planning.options import TILT_MARGIN_DEG
from toolpath.planning.tool_axis import angle_deg, lean_within_tilt
from toolpath.planning.travel import TRAVEL_MARGIN_MM, fit_travel
from verification import VerifyOptions, verify_program

BLADE = Path(__file__).resolve().parents[2] / "toolpath" / "data" / "dev_blade_15x142.csv"
COARSE = {"scallop_mm": 0.1, "chord_tol_mm": 0.05}
Z = np.array([0.0, 0.0, 1.0])


def _within_travel(machine, path):
    return check_travel(machine, solve_inverse(machine, path.positions_mm,
                                               path.tool_axes).joints) == []


def test_router_part_past_the_bed_edge_is_moved_onto_it():
    # a 20 x 6 mm plate whose far end is past the router's X travel (X <= 0 at x = 400)
    plate = PlaneSurface(origin_mm=(385.0, 0.0, 0.0), t_vector_mm=(20.0, 0.0, 0.0),
                         s_vector_mm=(0.0, 6.0, 0.0))
    machine = load_machine("grbl-router")
    path, rep = plan_finishing(plate, "ball:6", machine=machine, on_limit="report",
                               measure=False, **COARSE)
    assert rep.travel_violations
    fit = fit_travel(machine, path.positions_mm, path.tool_axes)
    assert fit.fits and fit.uniform and not fit.binding
    # the smallest shift: back in X by the overrun and the margin, nothing else
    overrun = machine.work_origin[0] + path.positions_mm[:, 0].max()
    assert fit.offset_mm[0] == pytest.approx(-overrun - TRAVEL_MARGIN_MM, abs=1e-6)
    assert fit.offset_mm[1:] == pytest.approx([0.0, 0.0], abs=1e-9)
    moved = path.positions_mm + fit.offset_mm
    joints = solve_inverse(machine, moved, path.tool_axes).joints
    assert check_travel(machine, joints) == []
    # toolpath plan's error names the shift as a command-line option, not a keyword
    with pytest.raises(PlanTravelLimitError) as err:
        plan_finishing(plate, "ball:6", machine=machine, measure=False, **COARSE)
    text = str(err.value)
    assert f"--translate {fit.offset_mm[0]:.3f},0.000,0.000" in text
    assert "--on-limit report" in text and "on_limit=" not in text


def test_part_taller_than_the_travel_names_the_binding_axis():
    # 150 mm above the spoilboard: the router's Z reaches 110 mm above it at most, and the
    # part cannot go down into the table
    plate = PlaneSurface(origin_mm=(0.0, 0.0, 150.0), t_vector_mm=(20.0, 0.0, 0.0),
                         s_vector_mm=(0.0, 6.0, 0.0))
    with pytest.raises(PlanTravelLimitError) as err:
        plan_finishing(plate, "ball:6", machine="grbl-router", measure=False, **COARSE)
    text = str(err.value)
    assert "no position of the part" in text and "axis 'Z' needs" in text
    assert "travel -120..0 mm" in text
    # taller than the head-table machine's 800 mm Z travel, in any position
    machine = load_machine("head-table-bc")
    tips = np.column_stack([np.zeros(50), np.zeros(50), np.linspace(0.0, 900.0, 50)])
    fit = fit_travel(machine, tips, np.tile(Z, (50, 1)))
    assert not fit.fits
    (binding,) = fit.binding
    assert binding.letter == "Z" and binding.travel_mm == (-800.0, 0.0)
    assert binding.needed_mm[1] - binding.needed_mm[0] == pytest.approx(900.0)


@pytest.mark.parametrize("name", ["trunnion-ac", "head-table-bc"])
def test_travel_fit_from_the_joints_a_path_carries_is_the_fit_solved_anew(name):
    # a 5-axis path whose axis swings round, too low for the travel: the fit reads the
    # joints the path carries and solves only the middles of the split moves (issue 27)
    from toolpath.errors import InvalidParameterError

    machine = load_machine(name)
    n = 120
    angle = np.linspace(0.0, 3.0 * np.pi, n)
    tilt = np.radians(np.linspace(5.0, 40.0, n))
    axes = np.column_stack([np.sin(tilt) * np.cos(angle), np.sin(tilt) * np.sin(angle),
                            np.cos(tilt)])
    tips = np.column_stack([20.0 * np.cos(angle / 3.0), np.linspace(-15.0, 15.0, n),
                            np.full(n, -900.0)])
    split = np.arange(n - 1) % 7 != 0
    known = solve_inverse(machine, tips, axes)
    anew = fit_travel(machine, tips, axes, split_moves=split)
    carried = fit_travel(machine, tips, axes, split_moves=split, joints=known)
    assert anew.offset_mm[2] > 0.0
    np.testing.assert_array_equal(carried.offset_mm, anew.offset_mm)
    assert (carried.fits, carried.ranges, carried.violations, carried.uniform) == (
        anew.fits, anew.ranges, anew.violations, anew.uniform)
    with pytest.raises(InvalidParameterError, match="119 rows solved for a path of 120"):
        fit_travel(machine, tips, axes, split_moves=split,
                   joints=solve_inverse(machine, tips[1:], axes[1:]))


def test_head_table_job_raises_the_blade_into_the_z_travel(tmp_path):
    from streamline_cam.pipeline import JobRequest, run_job

    # standing on the table (base 0), the tool pointing below the horizon at the hub
    # needs Z below the head-table machine's -800 mm
    request = JobRequest(sections_path=BLADE, machine="head-table-bc", axis_mode="lead-tilt",
                         fit_tol_mm=0.05, base_mm=0.0, scallop_mm=0.1, chord_tol_mm=0.05,
                         planning_options={"measure": False})
    result = run_job(request, tmp_path)
    shift = np.asarray(result.report["placement"]["travel_shift_mm"])
    assert shift[2] > 0.0 and shift[:2] == pytest.approx([0.0, 0.0])
    assert result.report["check"]["errors"] == 0
    assert result.report["plan"]["travel_violations"] == []
    from streamline_cam.commands.run import _setup_lines

    assert any(line.startswith("setup      part moved by (0.000, 0.000, ")
               for line in _setup_lines(result.report))
    # the saved surface, the placement and the path are in the same (shifted) frame
    surface = surface_from_dict(json.loads(result.files["surface"].read_text()))
    place = result.report["placement"]
    placement = Placement(np.asarray(place["rotation"]), np.asarray(place["offset_mm"]),
                          place["mode"])
    data = placement.apply(as_sections(read_sections(BLADE)).points)
    on_surface = surface(surface.t_params, surface.s_params, grid=True).transpose(1, 0, 2)
    assert np.abs(on_surface - data).max() <= result.report["fit"]["max_error_mm"] + 1e-6
    # its lowest point now stands on a riser of that height
    assert data[..., 2].min() == pytest.approx(shift[2])


# the underside of a horizontal cylinder: normals 95..140 deg from +Z, beyond what the
# trunnion's A (-120..30 deg) turns the tool axis to at the lower edge
UNDERSIDE = CylinderPatch(radius_mm=20.0, centre_mm=(0.0, 0.0, 60.0), angle_deg=(95.0, 140.0),
                          length_mm=(-10.0, 10.0))


def test_trunnion_leans_the_tool_axis_to_keep_a_in_travel_without_gouging():
    machine = load_machine("trunnion-ac")
    path, rep = plan_finishing(UNDERSIDE, "ball:6", axis_mode="lead-tilt", lead_deg=10.0,
                               machine=machine, measure=False, **COARSE)
    assert rep.travel_violations == () and _within_travel(machine, path)
    # the lower edge's axis (140 + 10 deg lead) leans back 30 deg to the reach
    assert rep.tilt_leaned_points > 0
    assert rep.max_tilt_deg == pytest.approx(tilt_reach_deg(machine) - TILT_MARGIN_DEG)
    assert rep.max_tilt_lean_deg == pytest.approx(30.0 + TILT_MARGIN_DEG, abs=0.05)
    assert "points leaned toward +Z" in "\n".join(rep.lines())
    cut = path.pass_index >= 0
    assert angle_deg(path.tool_axes[cut], Z).max() <= 120.0
    # smoothed: the lean does not make the axis turn faster than the rate limit allows
    assert rep.max_axis_rate_deg_per_mm <= rep.axis_rate_limit_deg_per_mm + 1e-6
    # the independent verifier on the posted program: no gouge beyond the chord tolerance
    cutter = parse_cutter("ball:6")
    program = post(path, machine)
    report = verify_program(program, UNDERSIDE, machine, cutter, options=VerifyOptions(
        spacing_mm=0.4, gouge_tol_mm=COARSE["chord_tol_mm"]))
    assert report.max_gouge is None


def test_no_allowed_tool_axis_fails_naming_point_joint_and_best_value():
    # normals 150..175 deg from +Z; leaning at most 30 deg from them leaves the head-table
    # machine's B (-110..110 deg) short everywhere
    surface = CylinderPatch(radius_mm=20.0, centre_mm=(0.0, 0.0, 60.0),
                            angle_deg=(150.0, 175.0), length_mm=(-10.0, 10.0))
    with pytest.raises(PlanTravelLimitError) as err:
        plan_finishing(surface, "ball:6", axis_mode="lead-tilt", machine="head-table-bc",
                       max_lean_deg=30.0, measure=False, **COARSE)
    text = str(err.value)
    assert "axis 'B'" in text and "at best" in text and "pass 0 point 0" in text
    (violation,) = err.value.violations
    # the first point lies on the 150 deg edge: the best axis is 120 deg from +Z
    assert abs(violation.value) == pytest.approx(120.0, abs=0.5)
    assert "--on-limit report" in text and "on_limit=" not in text


def test_lean_covers_the_need_and_ramps_along_the_pass():
    # one pass, axes dipping below the reach (100 deg) over its middle
    x = np.linspace(0.0, 40.0, 201)
    theta = 90.0 + 20.0 * np.exp(-((x - 20.0) / 3.0) ** 2)
    axes = np.column_stack([np.sin(np.radians(theta)), np.zeros_like(x),
                            np.cos(np.radians(theta))])
    lean = lean_within_tilt(axes, axes, x, np.zeros(x.size, np.int64), max_tilt_deg=100.0,
                            max_lean_deg=60.0, smoothing_mm=3.0, max_rate_deg_per_mm=10.0)
    after = angle_deg(lean.axes, Z)
    assert after.max() <= 100.0 + 1e-9 and not lean.impossible.any()
    assert lean.lean_deg.max() == pytest.approx(10.0, abs=0.5)
    # the lean starts before the need and changes by at most a quarter of the rate limit
    rate = np.abs(np.diff(lean.lean_deg)) / np.diff(x)
    assert rate.max() <= 2.5 + 1e-6
    assert lean.lean_deg[np.argmax(theta > 100.0) - 5] > 0.0


def test_run_command_leaves_the_travel_to_the_placement_unless_told():
    """`toolpath run` plans with on_limit="report" and then moves the part into the travel;
    the shared gouge flags must not pass --on-limit's default over that (they did: the
    dev blade stopped at Z -802.7 mm on head-table-bc)."""
    from streamline_cam.cli import _parser
    from streamline_cam.commands.run import request_from_args

    args = _parser().parse_args(["run", "blade.csv", "--machine", "head-table-bc"])
    assert "on_limit" not in request_from_args(Path("blade.csv"), args).planning_options
    args = _parser().parse_args(["run", "blade.csv", "--on-limit", "raise"])
    assert request_from_args(Path("blade.csv"), args).planning_options["on_limit"] == "raise"


@pytest.mark.parametrize("inside_mm", [1.0, 0.5 * TRAVEL_MARGIN_MM])
def test_a_path_within_the_margin_stays_and_one_past_it_moves_by_the_excess(inside_mm):
    # the router's X travel ends at 0 (x = 400 with its work origin): a row of tips whose
    # last point ends inside_mm short of it; within the margin no linear program is needed
    machine = load_machine("grbl-router")
    end = -machine.work_origin[0] - inside_mm
    tips = np.column_stack([np.linspace(end - 20.0, end, 40), np.zeros(40), np.zeros(40)])
    fit = fit_travel(machine, tips, np.tile(Z, (40, 1)))
    assert fit.fits and fit.uniform and not fit.binding
    if inside_mm >= TRAVEL_MARGIN_MM:
        assert fit.offset_mm.tolist() == [0.0, 0.0, 0.0]
        assert fit.ranges[0].needed_mm[1] == pytest.approx(-inside_mm)
    else:  # the full method: back by what the margin lacks
        assert fit.offset_mm[0] == pytest.approx(inside_mm - TRAVEL_MARGIN_MM, abs=1e-9)
        assert fit.offset_mm[1:].tolist() == [0.0, 0.0]
