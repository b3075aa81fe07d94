"""The batch summary's row says a scallop above the measure's horizon, not a blank."""

from __future__ import annotations

import csv
from pathlib import Path

from streamline_cam.batch import BatchJob, _write_summary, summary_row
from streamline_cam.job_task import JobOutcome


def _row(plan: dict) -> dict:
    report = {"plan": {"n_passes": 3, "n_points": 40, **plan}, "check": {"errors": 0}}
    job = BatchJob("part", Path("part.csv"), "fingerprint", None)
    return summary_row(job, JobOutcome(report, seconds=1.0), status="done")


def test_a_scallop_above_the_horizon_reads_as_more_than_it(tmp_path):
    above = _row({"max_scallop_mm": None, "scallop_above_horizon": True,
                  "scallop_horizon_mm": 0.2})
    measured = _row({"max_scallop_mm": 0.004, "scallop_above_horizon": False,
                     "scallop_horizon_mm": 0.05})
    assert (above["max_scallop_mm"], above["scallop_above_mm"]) == (None, 0.2)
    assert (measured["max_scallop_mm"], measured["scallop_above_mm"]) == (0.004, None)
    csv_path, _ = _write_summary(tmp_path, [above, measured])
    with csv_path.open(newline="", encoding="utf-8") as stream:
        rows = list(csv.DictReader(stream))
    assert [(r["max_scallop_mm"], r["scallop_above_mm"]) for r in rows] == [("", "0.2"),
                                                                            ("0.004", "")]


def test_a_row_exits_as_toolpath_run_would():
    # check errors, or figures beyond the request: the plan's own unverified (the propeller
    # with flat:6 in 5 axes read 0.0152 mm asked 0.01), the verifier's when verified
    request = {"scallop_mm": 0.01, "chord_tol_mm": 0.02}
    job = BatchJob("part", Path("part.csv"), "fingerprint", None)

    def row(plan, verify=None):
        report = {"request": request, "check": {"errors": 0},
                  "plan": {"n_passes": 3, "n_points": 40, "chord_tol_mm": 0.02,
                           "scallop_request_mm": 0.01, **plan}}
        if verify is not None:
            report["verify"] = verify
        return summary_row(job, JobOutcome(report, seconds=1.0), status="done")

    within = row({"max_scallop_mm": 0.009, "max_chord_error_mm": 0.015})
    assert within["exit"] == 0 and within["error"] is None
    over = row({"max_scallop_mm": 0.0152, "scallop_interior_mm": 0.0152})
    assert over["exit"] == 1 and "scallop 0.0152 mm exceeds the 0.01 mm asked" in over["error"]
    above = row({"max_scallop_mm": None, "scallop_above_horizon": True,
                 "scallop_horizon_mm": 0.05})
    assert above["exit"] == 1 and "above 0.05 mm" in above["error"]
    # verified: the program's figures decide, not the plan's
    verified = row({"max_scallop_mm": 0.0152}, {"max_scallop_mm": 0.0095, "max_gouge_mm": 0.0})
    assert verified["exit"] == 0
    cut_deep = row({"max_scallop_mm": 0.009}, {"max_scallop_mm": 0.009, "max_gouge_mm": 0.03})
    assert cut_deep["exit"] == 1 and "deepest gouge 0.0300 mm" in cut_deep["error"]
