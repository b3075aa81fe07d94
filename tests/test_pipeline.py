"""The pipeline for a 5-axis job: placement upright, G93 program, checked, plots."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from streamline_cam.pipeline import JobRequest, run_job
from toolpath.paper_examples import bundled_data_path
from toolpath.planning.errors import GougeError


def test_five_axis_job_posts_inverse_time_and_writes_every_plot(tmp_path):
    request = JobRequest(Path(bundled_data_path("dev_blade_15x142.csv")),
                         machine="trunnion-ac", axis_mode="lead-tilt", lead_deg=10.0,
                         scallop_mm=0.05, chord_tol_mm=0.03)
    result = run_job(request, tmp_path, plots=True)
    report = json.loads(result.files["report"].read_text())
    assert report["placement"]["mode"] == "upright"
    assert report["plan"]["unreachable_fraction"] == 0.0
    assert report["plan"]["max_scallop_mm"] <= 0.05
    assert report["check"]["errors"] == 0
    text = result.files["gcode"].read_text()
    assert "G93" in text and " A" not in text.splitlines()[0]
    for name in ("fit_plot", "toolpath_plot", "axis_plot"):
        assert result.files[name].read_bytes()[:4] == b"\x89PNG"


def test_bad_parameter_is_named_before_any_work(tmp_path):
    request = JobRequest(Path(bundled_data_path("dev_blade_15x142.csv")), scallop_mm=-1.0)
    try:
        run_job(request, tmp_path)
    except ValueError as exc:
        assert "scallop_mm" in str(exc)
    else:
        raise AssertionError("a negative scallop was accepted")
    assert not (tmp_path / "report.json").exists()


def test_coarse_5_axis_job_keeps_the_request_at_the_first_plan(tmp_path):
    # this coarse request used to overshoot its chord tolerance at the hub pass (0.0549
    # for 0.05): chords checked before the axes were smoothed again with new points, and
    # moves that stand above the surface on one side of an inflection and cut in on the
    # other were judged on one side only. The planner now keeps it (no second attempt),
    # and plans for less than asked by what the G-code's rounding can move the cutter.
    request = JobRequest(Path(bundled_data_path("dev_blade_15x142.csv")),
                         machine="trunnion-ac", axis_mode="lead-tilt", scallop_mm=0.1,
                         chord_tol_mm=0.05)
    report = run_job(request, tmp_path).report
    plan = report["plan"]
    assert len(plan["attempts"]) == 1
    assert plan["rounding_reserve_mm"] > 0.5 * np.sqrt(3.0) * 0.001  # rotary joints too
    assert plan["max_chord_error_mm"] <= plan["planned_chord_tol_mm"] < 0.05
    assert plan["max_scallop_mm"] <= plan["planned_scallop_mm"] < 0.1
    # the plan's figures are its toolpath's: the summary says so, and what the G-code's
    # rounding may make of its scallop (the verifier measures the program as written)
    from streamline_cam.commands.run import report_lines

    bound = plan["max_scallop_mm"] + plan["rounding_reserve_mm"]
    assert plan["written_scallop_bound_mm"] == pytest.approx(bound)
    assert (f"the toolpath's, before the G-code's rounding of up to "
            f"{plan['rounding_reserve_mm']:.4f} mm: as written, scallop at most about "
            f"{bound:.4f} mm") in "\n".join(report_lines(report))


def _job_measured_at_first(tmp_path, monkeypatch, largest, interior):
    """Run the demo job with its first plan's scallops made ``largest`` and ``interior``
    times the request (the later plans as measured); the scallops asked, and the plan."""
    return _job_measured(tmp_path, monkeypatch, [(largest, interior)])


def _job_measured(tmp_path, monkeypatch, scallops):
    """Run the demo job with its k-th plan's scallops made ``scallops[k]`` (largest,
    interior) times the user's request (the later plans as measured); the scallops
    asked, and the plan."""
    import dataclasses

    import streamline_cam.pipeline as pipeline

    real = pipeline.plan_finishing
    asked = []

    def measured(surface, cutter, **kw):
        path, report = real(surface, cutter, **kw)
        asked.append(kw["scallop_mm"])
        if len(asked) <= len(scallops):  # (the first plan is asked the user's request)
            largest, interior = scallops[len(asked) - 1]
            report = dataclasses.replace(report, max_scallop_mm=largest * asked[0],
                                         scallop_interior_mm=interior * asked[0])
        return path, report

    monkeypatch.setattr(pipeline, "plan_finishing", measured)
    request = JobRequest(Path(bundled_data_path("dev_blade_15x142.csv")), scallop_mm=0.05,
                         chord_tol_mm=0.03)
    return asked, run_job(request, tmp_path).report["plan"]


def test_a_plan_measured_over_the_request_is_planned_again_tighter(tmp_path, monkeypatch):
    # the guard behind the planner: when its own independent measurement of the result
    # exceeds the request (here made to, by 25 %, on the first attempt), the job asks
    # again with the tolerance tightened by the excess and keeps the second plan
    import streamline_cam.pipeline as pipeline

    asked, plan = _job_measured_at_first(tmp_path, monkeypatch, 1.25, 1.25)
    assert asked == [0.05, 0.05 * pipeline.REPLAN_MARGIN / 1.25]
    assert [a["scallop_mm"] for a in plan["attempts"]] == asked
    assert plan["planned_for_scallop_mm"] == asked[1]
    assert plan["max_scallop_mm"] <= asked[1] < 0.05


def test_a_re_plan_within_the_request_is_kept_though_over_what_it_was_asked(
        tmp_path, monkeypatch):
    # the second plan, asked 0.05 * 0.97 / 1.25 = 0.0388 mm, measures 0.045 mm: over what
    # it was asked, within the user's 0.05 mm: the job ends there (a third plan would cost
    # as much again and not be kept)
    asked, plan = _job_measured(tmp_path, monkeypatch, [(1.25, 1.25), (0.9, 0.9)])
    assert len(asked) == len(plan["attempts"]) == 2
    assert plan["kept_attempt"] == 2
    assert plan["max_scallop_mm"] == pytest.approx(0.9 * 0.05)


def test_a_cusp_beside_an_uncut_area_alone_is_not_planned_again(tmp_path, monkeypatch):
    # a cusp beside an area no cutter reaches stands higher than the step-over makes it
    # and no tighter request lowers it: with the interior scallop within the request the
    # job keeps its first plan (a re-plan would double the planning for nothing)
    asked, plan = _job_measured_at_first(tmp_path, monkeypatch, 1.25, 0.9)
    assert asked == [0.05]
    assert plan["max_scallop_mm"] == pytest.approx(1.25 * 0.05)


def test_a_re_plan_that_gouges_keeps_the_plans_made(tmp_path, monkeypatch):
    # dev_rotor_dca's 5-axis flat:6 job at scallop 0.01 mm measured 0.0117 mm; its re-plan
    # at 0.0083 mm met the hub edge 0.0014 mm deep and the job ended on that gouge, its
    # own plan (no gouge) lost. Here the first plan reads 1.25 times the request and the
    # re-plan raises a gouge: the job keeps the first plan and tells why it stopped
    import dataclasses

    import streamline_cam.pipeline as pipeline
    from streamline_cam.verdict import plan_excess
    from toolpath.planning.errors import GougeError

    real = pipeline.plan_finishing
    asked = []

    def gouges_when_tighter(surface, cutter, **kw):
        asked.append(kw["scallop_mm"])
        if len(asked) > 1:
            raise GougeError("gouge on pass 46 point 277: the cutter would cut 0.0014 mm "
                             "into the surface", pass_index=46, point_index=277)
        path, report = real(surface, cutter, **kw)
        return path, dataclasses.replace(report, max_scallop_mm=1.25 * kw["scallop_mm"],
                                         scallop_interior_mm=1.25 * kw["scallop_mm"])

    monkeypatch.setattr(pipeline, "plan_finishing", gouges_when_tighter)
    request = JobRequest(Path(bundled_data_path("dev_blade_15x142.csv")), scallop_mm=0.05,
                         chord_tol_mm=0.03)
    report = run_job(request, tmp_path).report
    plan = report["plan"]
    assert len(asked) == 2 and len(plan["attempts"]) == 1 and plan["kept_attempt"] == 1
    assert plan["max_scallop_mm"] == pytest.approx(1.25 * 0.05)
    assert plan["replan_stopped"].startswith(
        f"a re-plan at scallop {asked[1]:.4g} mm, chord 0.03 mm stopped: gouge on pass 46")
    excess = plan_excess(report)
    assert excess.startswith("scallop 0.0625 mm exceeds the 0.05 mm asked (--scallop)")
    assert "a re-plan at scallop" in excess
    from streamline_cam.commands.run import _attempts_line

    (line,) = _attempts_line(plan)
    assert line.startswith("re-plan    a re-plan at scallop")


def _job_report(*, scallop_mm, gouge_mm):
    """The report of a finished job whose verification measured these figures."""
    return {
        "fit": {"method": "streamline", "n_control_points": [20, 11], "max_error_mm": 0.005,
                "between_sections_mm": 0.006},
        "plan": {"n_passes": 10, "n_points": 1000, "max_scallop_mm": 0.019,
                 "scallop_request_mm": 0.02, "max_chord_error_mm": 0.009, "chord_tol_mm": 0.01,
                 "unreachable_fraction": 0.0, "linking": "zigzag"},
        "program": {"lines": 1100, "time_s": 60.0},
        "check": {"errors": 0, "warnings": 0, "issues": []},
        "verify": {"max_scallop_mm": scallop_mm, "max_gouge_mm": gouge_mm,
                   "max_gouge": {"line": 412} if gouge_mm else None,
                   "max_scallop": {"line": 97}},
    }


def _run_finishing_with(report, tmp_path, monkeypatch, capsys, *flags):
    """``toolpath run`` of a job that finishes with ``report``: (exit code, stderr, G-code)."""
    from streamline_cam import cli, pipeline
    from streamline_cam.pipeline import JobResult

    gcode = tmp_path / "part.nc"
    gcode.write_text("G0 Z5\n")

    def finished(request, out_dir, **kwargs):
        assert kwargs["verify"] == ("--verify" in flags)
        return JobResult(report, {"gcode": gcode})

    monkeypatch.setattr(pipeline, "run_job", finished)  # run imports it when it runs
    blade = str(bundled_data_path("dev_blade_15x142.csv"))  # (run reads it before the job)
    code = cli.main(["run", blade, *flags, "--quiet"])
    return code, capsys.readouterr().err, gcode


def _assert_kept_and_told(code, err, gcode, exceeded, told):
    """Exit 1 and one line on stderr with ``told`` and what ``exceeded`` (None: exit 0, silent)."""
    assert code == (1 if exceeded else 0)
    assert gcode.exists()  # the outputs are kept
    if exceeded:
        assert err.count("\n") == 1 and exceeded in err and told in err
    else:
        assert told not in err


@pytest.mark.parametrize(("scallop_mm", "gouge_mm", "exceeded"), [
    (0.0195, 0.0096, None),
    (0.0195, 0.0123, "deepest gouge 0.0123 mm exceeds the chord tolerance 0.01 mm "
                     "(--chord-tol) at line 412"),
    (0.148, 0.0, "scallop 0.1480 mm exceeds the 0.02 mm asked (--scallop) at line 97"),
])
def test_run_verify_fails_when_the_program_cuts_beyond_the_request(
        tmp_path, monkeypatch, capsys, scallop_mm, gouge_mm, exceeded):
    told = _run_finishing_with(_job_report(scallop_mm=scallop_mm, gouge_mm=gouge_mm),
                               tmp_path, monkeypatch, capsys, "--verify")
    _assert_kept_and_told(*told, exceeded, "verify failed")


@pytest.mark.parametrize(("plan_fields", "exceeded"), [
    ({}, None),
    # kept over the request (the propeller with flat:6 in 5 axes, scallop 0.01 mm, read
    # 0.0152 mm at its leading edge, too far over to re-plan): it exited 0 unverified
    ({"max_scallop_mm": 0.0304, "scallop_interior_mm": 0.0304, "scallop_at": [0.5042, 0.242]},
     "scallop 0.0304 mm exceeds the 0.02 mm asked (--scallop) at t=0.5042, s=0.2420"),
    # beside an uncut area only: the figure away from it is what a job is held to
    ({"max_scallop_mm": 0.0304, "scallop_interior_mm": 0.0195}, None),
    ({"max_chord_error_mm": 0.0123},
     "chord error 0.0123 mm exceeds the chord tolerance 0.01 mm (--chord-tol)"),
])
def test_run_fails_when_the_plan_measures_beyond_the_request(
        tmp_path, monkeypatch, capsys, plan_fields, exceeded):
    report = _job_report(scallop_mm=0.0, gouge_mm=0.0)
    del report["verify"]
    report["plan"].update(plan_fields)
    report["request"] = {"scallop_mm": 0.02, "chord_tol_mm": 0.01}
    told = _run_finishing_with(report, tmp_path, monkeypatch, capsys)
    _assert_kept_and_told(*told, exceeded, "the plan's measurement does not meet the request")


def test_the_plan_nearest_the_request_is_kept_when_re_plans_read_worse(tmp_path, monkeypatch):
    # a tighter request usually lowers the measured scallop, not always (dev_rotor_blunt's
    # flat:6 5-axis job measured 0.0563, 0.0503 and 0.0591 mm asked 0.05, 0.0431 and
    # 0.0358, and wrote the last): here made to read 1.1, 1.3 and 1.2 times the request,
    # the job plans three times and writes the first plan, the nearest to it
    import streamline_cam.pipeline as pipeline

    asked, plan = _job_measured(tmp_path, monkeypatch, [(1.1, 1.1), (1.3, 1.3), (1.2, 1.2)])
    assert len(asked) == len(plan["attempts"]) == 1 + pipeline.REPLANS == 3
    assert plan["kept_attempt"] == 1
    assert plan["planned_for_scallop_mm"] == asked[0] == 0.05
    assert plan["max_scallop_mm"] == pytest.approx(1.1 * 0.05)
    assert [a["judged_scallop_mm"] for a in plan["attempts"]] == pytest.approx(
        [1.1 * 0.05, 1.3 * 0.05, 1.2 * 0.05])
    from streamline_cam.commands.run import _attempts_line

    (line,) = _attempts_line(plan)
    assert line.startswith("re-plan    3 plans") and line.endswith(
        "plan 1 kept, the nearest to the request")
    assert "asked 0.0500/0.0300, measured 0.0550/" in line


def test_a_gouge_where_a_fit_of_scattered_points_stays_unfair_names_the_fit_tol_that_cures_it(
        tmp_path, monkeypatch):
    # the blunt rotor with 1 um of scatter (seed 1), placed upright, stayed unfair within
    # --fit-tol 0.01 in every cone frame (99 control points for 120 points a section) and
    # a 6 mm ball gouged 8.8 um where it dents: the scatter, ten times below the
    # tolerance, said nothing. Which fits come out unfair there turns on a knot search
    # that rounding differences of 1e-15 tip either way, so here the bundled rotor's fit is
    # told unfair and scattered, and the plan stops on a gouge; the job fits again wider
    # (the bundled rotor is fair within 0.012 mm) and says so
    import streamline_cam.pipeline as pipeline

    fit = pipeline.fit_surface_by_method

    def unfair_fit(sections, **kw):
        surface, report = fit(sections, **kw)
        return surface, dataclasses.replace(report, scatter_mm=0.001, fairness={
            **report.fairness, "concave_stretches": 5})

    def gouging(*args, **kwargs):
        raise GougeError("the cutter would cut 0.0088 mm into the surface (test)")

    monkeypatch.setattr(pipeline, "plan_finishing", gouging)
    monkeypatch.setattr(pipeline, "fit_surface_by_method", unfair_fit)
    request = JobRequest(Path(bundled_data_path("dev_rotor_blunt_9x120.csv")),
                         machine="trunnion-ac", axis_mode="lead-tilt", lead_deg=10.0)
    with pytest.raises(GougeError, match=r"\(test\); the fit within --fit-tol 0.01 stays "
                       r"unfair, .* where the points scatter 0.0010 mm about smooth curves "
                       r"through them: --fit-tol 0.012 fits them fair$"):
        run_job(request, tmp_path / "unfair")
    # a fair fit (the bundled points as they are): the gouge as the planner told it
    monkeypatch.setattr(pipeline, "fit_surface_by_method", fit)
    with pytest.raises(GougeError, match=r"\(test\)$"):
        run_job(request, tmp_path / "fair")


def test_a_job_hands_its_freed_memory_back_once_however_it_ends(tmp_path, monkeypatch):
    # run_job is the job a service's or batch's worker runs: as_job's release comes after
    # it whole, not after a helper of it (040b8fb had left the decorator on the sections'
    # reading, run_job unwrapped)
    from streamline_cam import job_process

    calls = []
    monkeypatch.setattr(job_process, "release_freed_memory", lambda: calls.append("released"))
    monkeypatch.setattr(job_process, "_freezes_at_exit", False)  # (a long-lived process)
    request = JobRequest(Path(bundled_data_path("dev_blade_15x142.csv")), scallop_mm=-1.0)
    with pytest.raises(ValueError, match="scallop_mm"):
        run_job(request, tmp_path)
    assert calls == ["released"]
