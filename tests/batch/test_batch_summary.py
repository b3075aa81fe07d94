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
