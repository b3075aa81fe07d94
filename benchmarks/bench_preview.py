"""Benchmark: the 3-D preview of a 250,000-point toolpath (``GET /jobs/{id}/preview``).

The toolpath is synthetic: zig-zag passes of 500 points over a wavy sheet, a link between
passes (500 passes: 999 runs, each kept whole at its ends). Prints, for each budget, the
median over ``--repeat`` runs of

* decimation alone (RDP weights with a point budget, :func:`decimate_polyline`);
* the whole preview body: surface grid, runs, decimation, JSON encoding;

with the points kept and the largest distance of a dropped point from the line drawn. Times
are wall clock and, in brackets, this process's CPU time (on a shared machine the wall
clock includes waiting for a core). The endpoint caches its answer in the job folder, so
only a job's first request pays this.
Run: ``python benchmarks/bench_preview.py [--points 250000] [--repeat 5]``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import numpy as np

from streamline_cam.service.preview import decimate_polyline, preview, toolpath_runs
from toolpath.path import Toolpath


def synthetic(points: int, per_pass: int = 500) -> Toolpath:
    """Zig-zag passes over ``z = 5 sin(x / 10) + cos(y / 7)`` (mm), links between them."""
    n_passes = points // per_pass
    u = np.linspace(0.0, 1.0, per_pass)
    xyz, kinds, passes = [], [], []
    for j in range(n_passes):
        x = 100.0 * (u if j % 2 == 0 else 1.0 - u)
        y = np.full(per_pass, 0.2 * j)
        xyz.append(np.column_stack((x, y, 5.0 * np.sin(x / 10.0) + np.cos(y / 7.0))))
        kinds += [5] + [3] * (per_pass - 1)
        passes += [-1] + [j] * (per_pass - 1)
    xyz = np.concatenate(xyz)
    return Toolpath(xyz, np.array([0.0, 0.0, 1.0]), np.asarray(kinds, dtype=np.uint8),
                    np.full(len(xyz), 1000.0), np.asarray(passes))


class Sheet:
    """A flat 100 x 100 mm surface (the surface grid is not what is measured)."""

    closed_t = False

    def __call__(self, t, s, *, grid=False):
        t, s = np.meshgrid(t, s, indexing="ij")
        return np.stack((100.0 * t, 100.0 * s, np.zeros_like(t)), axis=-1)


def _median_s(run, repeat: int) -> tuple[float, float, object]:
    """Median wall and CPU time of ``run()`` (s) and its last answer."""
    times, cpu, out = [], [], None
    for _ in range(repeat):
        start, start_cpu = time.perf_counter(), time.process_time()
        out = run()
        times.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
    return statistics.median(times), statistics.median(cpu), out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=250_000)
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    path = synthetic(args.points)
    runs = toolpath_runs(path.kinds, path.pass_index)
    fixed = np.zeros(len(path.positions_mm), dtype=bool)
    for _, _, first, last in runs:
        fixed[first - 1] = fixed[last] = True
    print(f"toolpath: {len(path.positions_mm)} points, {len(runs)} runs")
    print(f"{'budget':>8} {'decimate ms (cpu)':>18} {'preview ms (cpu)':>17} "
          f"{'kept':>7} {'max dev mm':>11} {'JSON MB':>8}")
    for budget in (10_000, 50_000, 100_000):
        dec_s, dec_cpu, kept = _median_s(
            lambda b=budget: decimate_polyline(path.positions_mm, b, fixed), args.repeat)
        body_s, body_cpu, body = _median_s(
            lambda b=budget: json.dumps(preview(Sheet(), path, max_points=b),
                                        separators=(",", ":")), args.repeat)
        print(f"{budget:>8} {1e3 * dec_s:>9.0f} ({1e3 * dec_cpu:>4.0f}) "
              f"{1e3 * body_s:>10.0f} ({1e3 * body_cpu:>4.0f}) "
              f"{int(kept.keep.sum()):>7} {kept.max_deviation_mm:>11.4f} "
              f"{len(body) / 1e6:>8.2f}")


if __name__ == "__main__":
    main()
