"""``toolpath batch`` on a local Dask cluster: a bad input, a killed worker, a rerun."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

from _batch_support import counted_task, killing_task, numba_threads, strip_csv

from streamline_cam.batch import find_inputs, plan_batch, run_batch
from streamline_cam.cli import _parser, main
from streamline_cam.commands.run import request_from_args
from streamline_cam.dask_engine import WARM_UP_TOPIC
from toolpath.paper_examples import bundled_data_path

#: Coarse jobs: seconds each.
COARSE_FLAGS = ["--scallop", "0.5", "--chord-tol", "0.2", "--fit-tol", "0.05"]
TIMEOUT_S = 120.0


def _inputs(folder: Path, *, bad: bool) -> Path:
    """The propeller blade (7 sections), a small strip (6 sections) and a bad file."""
    folder.mkdir()
    shutil.copy(bundled_data_path("dev_prop_7x100.csv"), folder / "prop.csv")
    (folder / "strip.csv").write_bytes(strip_csv(6, twist_deg=3.0))
    if bad:
        (folder / "bad.csv").write_text("section,x,y,z\n0,1.0,2.0\n", encoding="utf-8")
    return folder


def _template():
    """The job options as ``toolpath batch`` reads them from its flags."""
    args = _parser().parse_args(["batch", "x.csv", *COARSE_FLAGS, "-o", "out"])
    return request_from_args(Path(), args)


def _log_lines(log: Path) -> list[str]:
    return log.read_text(encoding="utf-8").splitlines() if log.exists() else []


def test_a_bad_input_fails_alone_and_a_rerun_skips_the_finished_jobs(client, tmp_path,
                                                                    capsys):
    inputs = _inputs(tmp_path / "in", bad=True)
    out, log = tmp_path / "out", tmp_path / "runs.log"
    jobs = plan_batch(find_inputs([str(inputs)]), _template())
    assert [j.name for j in jobs] == ["bad", "prop", "strip"]
    summary = run_batch(jobs, out, client, task=counted_task(str(log)), timeout_s=TIMEOUT_S)

    rows = {row["name"]: row for row in summary.rows}
    assert not summary.all_held
    assert rows["bad"]["exit"] == 2 and rows["bad"]["status"] == "failed"
    assert "bad.csv:2" in rows["bad"]["error"] and "\n" not in rows["bad"]["error"]
    for name in ("strip", "prop"):
        assert rows[name]["exit"] == 0 and rows[name]["status"] == "done"
        assert rows[name]["passes"] > 0 and rows[name]["points"] > rows[name]["passes"]
        assert rows[name]["worker"] and rows[name]["seconds"] > 0
        report = json.loads((out / name / "report.json").read_text())
        assert report["plan"]["n_points"] == rows[name]["points"]
        assert report["request"]["sections_path"] == str(inputs / f"{name}.csv")
        assert (out / name / "part.nc").read_text().count("\n") == report["program"]["lines"]
    assert not (out / "bad").exists()
    assert sorted(p.name for p in out.iterdir()) == ["prop", "strip", "summary.csv",
                                                     "summary.json"]  # no partial folder
    with (out / "summary.csv").open() as stream:
        assert [r["name"] for r in csv.DictReader(stream)] == ["bad", "prop", "strip"]
    assert json.loads((out / "summary.json").read_text())["all_held"] is False
    assert sorted(_log_lines(log)) == sorted(f"{e} {n}.csv" for e in ("start", "done")
                                             for n in ("bad", "strip", "prop"))
    # one job per worker process, its compiled kernels on one thread
    assert set(client.run(numba_threads).values()) == {1}
    assert {w["nthreads"] for w in client.scheduler_info()["workers"].values()} == {1}

    # the same batch again, through the command line and the cluster's address: the
    # finished jobs are skipped (their folders untouched), the failed one is run again
    (out / "prop" / "part.nc").touch()
    stamp = (out / "prop" / "part.nc").stat().st_mtime_ns
    address = client.scheduler.address
    assert address.startswith("tcp://127.0.0.1:")
    code = main(["batch", str(inputs / "*.csv"), *COARSE_FLAGS, "--scheduler", address,
                 "-o", str(out), "--quiet"])
    assert code == 1  # the bad input still fails
    rows = {row["name"]: row for row in json.loads((out / "summary.json").read_text())["jobs"]}
    assert [rows[n]["status"] for n in ("bad", "strip", "prop")] == ["failed", "skipped",
                                                                      "skipped"]
    assert rows["prop"]["points"] == summary.rows[1]["points"]
    assert (out / "prop" / "part.nc").stat().st_mtime_ns == stamp
    # only finished jobs: no cluster is started (none named), every one held
    assert main(["batch", str(inputs / "prop.csv"), str(inputs / "strip.csv"), *COARSE_FLAGS,
                 "-o", str(out), "--quiet"]) == 0
    assert "2 job(s), 0 to run;" in capsys.readouterr().out


def test_a_worker_killed_during_a_job_has_the_job_run_again_once(client, tmp_path):
    inputs = _inputs(tmp_path / "in", bad=False)
    out, log, marker = tmp_path / "out", tmp_path / "runs.log", tmp_path / "killed"
    jobs = plan_batch(find_inputs([str(inputs / "*.csv")]), _template())
    summary = run_batch(jobs, out, client, timeout_s=TIMEOUT_S,
                        task=killing_task(str(log), "strip.csv", str(marker)))

    assert marker.exists()  # the worker running strip.csv was killed while planning
    assert summary.all_held
    assert [row["status"] for row in summary.rows] == ["done", "done"]
    lines = _log_lines(log)
    assert lines.count("start strip.csv") == 2  # killed, then run again on a new worker
    assert lines.count("done strip.csv") == 1 and lines.count("done prop.csv") == 1
    killed_pid = int(marker.read_text())
    assert summary.rows[1]["name"] == "strip"
    assert not summary.rows[1]["worker"].endswith(f":{killed_pid}")
    for name in ("strip", "prop"):
        assert {p.name for p in (out / name).iterdir()} == {
            "batch_job.json", "part.nc", "report.json", "surface.json", "toolpath.npz"}
    # the kernels were warmed once per worker process, not per job nor per batch (the
    # command-line batch of the other test registered the set-up again on these workers)
    pids = [event["pid"] for _, event in client.get_events(WARM_UP_TOPIC)]
    assert len(pids) == len(set(pids)) and killed_pid in pids


def test_inputs_are_files_folders_and_globs_each_once_with_distinct_names(tmp_path):
    import pytest

    from toolpath.errors import ToolpathError

    for folder in ("rotor", "stator"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "blade.csv").write_text("section,x,y,z\n")
    (tmp_path / "rotor" / "notes.txt").write_text("")
    paths = find_inputs([str(tmp_path / "rotor"), str(tmp_path / "*" / "*.csv"),
                         str(tmp_path / "stator" / "blade.csv")])
    assert paths == [tmp_path / "rotor" / "blade.csv", tmp_path / "stator" / "blade.csv"]
    jobs = plan_batch(paths, _template())
    assert [j.name for j in jobs] == ["rotor-blade", "stator-blade"]
    assert jobs[0].fingerprint == jobs[1].fingerprint  # same bytes, same options
    for pattern, message in ((tmp_path / "none", "no such file or folder"),
                             (tmp_path / "*.xyz", "no file matches"),
                             (tmp_path / "rotor" / "*.nc", "no file matches")):
        with pytest.raises(ToolpathError, match=message):
            find_inputs([str(pattern)])
    (tmp_path / "empty").mkdir()
    with pytest.raises(ToolpathError, match=r"no sections files \(\*\.csv\)"):
        find_inputs([str(tmp_path / "empty")])
