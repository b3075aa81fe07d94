"""``toolpath batch``: one ``toolpath run`` job per sections file, on a Dask cluster."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..cli_types import positive_int
from .run import add_job_arguments, request_from_args, scallop_text

__all__ = ["register"]


def _row_line(row: dict) -> str:
    """One finished job, one line."""
    if row["error"] and row["exit"] == 2:
        return f"{row['name']:<24} failed    {row['error']}"
    figures = (f"{row['passes']} passes, {row['points']} points, scallop "
               f"{scallop_text(row['max_scallop_mm'], row.get('scallop_above_mm'))}, chord "
               f"{row['max_chord_error_mm'] or 0.0:.4f} mm")
    if row["verified_scallop_mm"] is not None or row["verified_gouge_mm"] is not None:
        figures += (f", verified scallop {row['verified_scallop_mm'] or 0.0:.4f} mm, gouge "
                    f"{row['verified_gouge_mm'] or 0.0:.4f} mm")
    if row["exit"] and row["check_errors"]:
        figures += f"; {row['check_errors']} check error(s): {row['error']}"
    elif row["exit"]:
        figures += f"; beyond the request: {row['error']}"
    return f"{row['name']:<24} {row['status']:<9} {figures} ({row['seconds']} s, {row['worker']})"


def _batch(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from ..batch import find_inputs, needs_run, plan_batch, run_batch
    from ..dask_engine import SchedulerError, dashboard_link, job_client

    out_dir = Path(args.output)
    jobs = plan_batch(find_inputs(args.inputs), request_from_args(Path(), args),
                      verify=args.verify, plots=args.plots)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        print(f"toolpath batch: error: cannot make the output folder {out_dir} (-o): "
              f"{exc.strerror or exc}", file=sys.stderr)
        return 2
    to_run = sum(needs_run(job, out_dir) for job in jobs)
    where = (f"the scheduler at {args.scheduler}" if args.scheduler else
             f"a local cluster of {args.workers or 'one worker per core'}"
             + (" worker(s)" if args.workers else ""))
    print(f"toolpath batch: {len(jobs)} job(s), {to_run} to run"
          + (f" on {where}" if to_run else "") + f"; results in {out_dir}", flush=True)
    bar = tqdm(total=len(jobs), unit="job", disable=args.quiet, file=sys.stderr)

    def done(row: dict) -> None:
        bar.update(1)
        bar.write(_row_line(row), file=sys.stdout)

    try:
        if not to_run:  # every job finished before (or unreadable): no cluster needed
            summary = run_batch(jobs, out_dir, None, on_done=done)
        else:
            with job_client(args.scheduler, workers=args.workers) as client:
                link = dashboard_link(client)
                if link:
                    bar.write(f"toolpath batch: dashboard {link}", file=sys.stdout)
                summary = run_batch(jobs, out_dir, client, on_done=done)
    except SchedulerError as exc:
        print(f"toolpath batch: error: {exc} (--scheduler)", file=sys.stderr)
        return 2
    finally:
        bar.close()
    counts = {s: sum(r["status"] == s for r in summary.rows) for s in ("done", "skipped",
                                                                        "failed")}
    held = sum(r["exit"] == 0 for r in summary.rows)
    print(f"toolpath batch: {held} of {len(summary.rows)} job(s) held ({counts['done']} run, "
          f"{counts['skipped']} skipped as finished, {counts['failed']} failed); summary in "
          f"{summary.csv_path} and {summary.json_path}")
    return 0 if summary.all_held else 1


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``toolpath batch``."""
    parser = commands.add_parser(
        "batch", help="one `toolpath run` job per sections file, on a Dask cluster",
        description="Run a `toolpath run` job for each sections file (files, folders of *.csv, "
        "globs) as Dask tasks: on a local cluster by default, on any Dask scheduler with "
        "--scheduler. Each job's files go to OUT_DIR/<name>/ as `toolpath run` writes them; "
        "a rerun into the same OUT_DIR skips the jobs already finished. Exit status 0 when "
        "every job made a program that checked clean.")
    parser.add_argument("inputs", nargs="+", metavar="INPUT",
                        help="sections CSV files, folders of them, or globs ('blades/*.csv')")
    add_job_arguments(parser)
    parser.add_argument("-o", "--output", required=True, metavar="OUT_DIR",
                        help="folder for the jobs' folders and summary.csv / summary.json")
    engine = parser.add_mutually_exclusive_group()
    engine.add_argument("--scheduler", metavar="tcp://HOST:8786",
                        help="a running Dask scheduler (`dask scheduler`) whose workers run "
                             "the jobs")
    engine.add_argument("--workers", type=positive_int,
                        help="worker processes of the local cluster (default: one per core)")
    parser.add_argument("--verify", action="store_true",
                        help="replay each program and measure what it cuts")
    parser.add_argument("--plots", action="store_true", help="write each job's plots")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.set_defaults(handler=_batch)
