"""Benchmark: 8 coarse blade jobs one after another in one process vs on 2 Dask workers.

Run ``python benchmarks/bench_batch.py`` (``--workers N`` for another cluster size). The jobs:
the bundled blades (``toolpath/data/``: the dev blade, the propeller, the blunt and the DCA
rotors), each twice, coarse (scallop 0.3 mm, chord 0.1 mm) on ``grbl-router``. Both sides
run the same task (:func:`streamline_cam.job_task.run_packed_job`) after a warm-up (the
compiled kernels loaded once per process: in the one process, and in each worker by its
set-up plugin), so the figures compare running, not starting: the cluster's start and
warm-up are printed apart. The speed-up is printed beside the ideal (the number of
workers); on a 2-core machine other load takes from it directly.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path

from streamline_cam.batch import plan_batch, run_batch
from streamline_cam.dask_engine import job_client
from streamline_cam.job_task import run_packed_job
from streamline_cam.pipeline import JobRequest
from streamline_cam.warmup import load_kernels

DATA = Path(__file__).resolve().parent.parent / "toolpath" / "data"
BLADES = ("dev_blade_15x142.csv", "dev_prop_7x100.csv", "dev_rotor_blunt_9x120.csv",
          "dev_rotor_dca_11x181.csv")
OPTIONS = {"scallop_mm": 0.3, "chord_tol_mm": 0.1}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench-batch-") as folder:
        inputs = Path(folder) / "in"
        inputs.mkdir()
        paths = []
        for copy in (1, 2):
            for name in BLADES:
                paths.append(inputs / f"{Path(name).stem}-{copy}.csv")
                shutil.copy(DATA / name, paths[-1])
        jobs = plan_batch(paths, JobRequest(Path(), **OPTIONS))

        warm_s = load_kernels()
        start = time.perf_counter()
        for job in jobs:
            outcome = run_packed_job(job.packed)
            assert outcome.ok, outcome.error
        sequential_s = time.perf_counter() - start

        start = time.perf_counter()
        with job_client(None, workers=args.workers, dashboard=False) as client:
            ready_s = time.perf_counter() - start
            start = time.perf_counter()
            summary = run_batch(jobs, Path(folder) / "out", client)
            cluster_s = time.perf_counter() - start
        assert summary.all_held, [r["error"] for r in summary.rows if r["exit"]]
        workers = sorted({row["worker"] for row in summary.rows})

    load = os.getloadavg()[0]
    print(f"{len(jobs)} coarse jobs ({', '.join(OPTIONS)} = "
          f"{', '.join(str(v) for v in OPTIONS.values())} mm), {os.cpu_count()} cores, "
          f"load {load:.1f}")
    print(f"one process     {sequential_s:7.1f} s  (warm-up {warm_s:.1f} s before)")
    print(f"{args.workers} Dask workers  {cluster_s:7.1f} s  (cluster start and warm-up "
          f"{ready_s:.1f} s before; jobs ran on {len(workers)} worker(s))")
    print(f"speed-up        {sequential_s / cluster_s:7.2f}    (ideal {float(args.workers):.1f})")


if __name__ == "__main__":
    main()
