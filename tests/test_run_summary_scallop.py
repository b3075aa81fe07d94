"""``toolpath run``'s and ``toolpath batch``'s summary lines: the scallop as measured.

A scallop above the measure's horizon has no number in the report's JSON (null, with
``scallop_above_horizon``); the summary says so instead of failing on it or printing 0.
Where the largest cusp stands beside an uncut area, the one away from it is given too.
Moves the chord check left whole (their gap did not fall when split) are told.
"""

from __future__ import annotations

from streamline_cam.commands.batch import _row_line
from streamline_cam.commands.run import report_lines


def _report(**plan) -> dict:
    plan = {"n_passes": 12, "n_points": 400, "scallop_request_mm": 0.01,
            "max_chord_error_mm": 0.0091, "chord_tol_mm": 0.01, "unreachable_fraction": 0.0,
            "linking": "zigzag", "scallop_horizon_mm": 0.1, "scallop_above_horizon": False,
            "scallop_interior_mm": plan.get("max_scallop_mm")} | plan
    return {"fit": {"method": "streamline", "n_control_points": [9, 9], "max_error_mm": 0.004,
                    "between_sections_mm": 0.003},
            "plan": plan, "program": {"lines": 420, "time_s": 60.0},
            "check": {"errors": 0, "warnings": 0, "issues": []}}


def _plan_line(**plan) -> str:
    return next(line for line in report_lines(_report(**plan)) if line.startswith("plan "))


def test_the_plan_line_gives_the_scallop_measured():
    assert "scallop 0.0041 mm (asked 0.01)" in _plan_line(max_scallop_mm=0.0041)


def test_a_scallop_above_the_horizon_reads_so():
    line = _plan_line(max_scallop_mm=None, scallop_above_horizon=True,
                      scallop_interior_mm=0.0043)
    assert ("scallop above 0.1 mm (the measure's horizon), 0.0043 mm away from uncut areas "
            "(asked 0.01)") in line


def test_a_cusp_beside_an_uncut_area_is_told_apart():
    line = _plan_line(max_scallop_mm=0.0366, scallop_interior_mm=0.0046)
    assert "scallop 0.0366 mm, 0.0046 mm away from uncut areas (asked 0.01)" in line


def test_moves_the_chord_check_left_whole_are_told_under_the_plan_line():
    # the chord figure of a plan with stalled moves (dev_prop_7x100 flat:6: 1.79 mm where
    # the verifier finds 0.05) is explained under it; fails if run's summary drops them
    lines = report_lines(_report(max_scallop_mm=0.13, max_chord_error_mm=1.7894,
                                 n_stalled_moves=199, stalled_gap_mm=2.3374))
    after = lines[lines.index(next(x for x in lines if x.startswith("plan "))) + 1]
    assert "199 move(s) left whole" in after and "2.3374 mm" in after
    assert not any("left whole" in x for x in report_lines(_report(max_scallop_mm=0.004)))


def test_the_batch_line_says_above_the_horizon_not_zero():
    row = {"name": "blade", "status": "done", "exit": 0, "error": None, "passes": 12,
           "points": 400, "max_scallop_mm": None, "scallop_above_mm": 0.2,
           "max_chord_error_mm": 0.009, "verified_scallop_mm": None,
           "verified_gouge_mm": None, "check_errors": 0, "seconds": 1.5, "worker": "h:1"}
    assert "scallop above 0.2 mm (the measure's horizon), chord 0.0090 mm" in _row_line(row)
