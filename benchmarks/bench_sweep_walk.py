"""The bull-nose walk's shared work between neighbouring dexels, against each walking alone.

Run:  PYTHONPATH=$PWD python benchmarks/bench_sweep_walk.py [--rows 60] [--per-row 400]

A 5-axis-like workload: bull:8:1 passes 0.4 mm apart over a wavy sheet, the axis on the
normal led by an angle that turns along each pass (so the runs of pieces are short and
halved, as on the bull-nose blade), and dexels along rows of the sheet 0.05 mm apart (the
order the design grid hands them over). The near search
(:func:`verification.sweep_search.lowest_sweep_entries`) runs, in the same process, each
dexel alone and unseeded (``grouped=False, seeded=False``: the walk before issue 27's
session 30), then grouped and seeded (the default): CPU seconds of each (fastest of
``--repeat``), their ratio, and whether every value, piece and side is bit-identical.
"""

from __future__ import annotations

import argparse
import functools
import os
import time

import numpy as np

from verification.pieces import Pieces
from verification.sweep_search import lowest_sweep_entries

RADIUS_MM, CORNER_MM = 4.0, 1.0


def _sheet(x, y):
    z = 0.8 * np.sin(0.3 * x) * np.cos(0.25 * y)
    n = np.column_stack((-0.24 * np.cos(0.3 * x) * np.cos(0.25 * y),
                         0.2 * np.sin(0.3 * x) * np.sin(0.25 * y), np.ones_like(x)))
    return z, n / np.linalg.norm(n, axis=1)[:, None]


def workload(rows: int, per_row: int, rng: np.random.Generator):
    """Pieces of the passes, and dexels (points, directions) along rows."""
    ys = np.arange(-6.0, 6.01, 0.4)
    xs = np.arange(-2.0, 22.0, 0.03)
    x, y = (g.ravel() for g in np.meshgrid(xs, ys))
    z, n = _sheet(x, y)
    lead = 0.2 * np.sin(0.7 * x + y)
    axis = n + np.column_stack((lead, 0.5 * lead, np.zeros_like(x)))
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    side = n - (n * axis).sum(axis=1)[:, None] * axis
    side /= np.maximum(np.linalg.norm(side, axis=1), 1e-12)[:, None]
    bottom = np.column_stack((x, y, z)) + CORNER_MM * n - (RADIUS_MM - CORNER_MM) * side
    k = np.flatnonzero(np.arange(x.shape[0]) % xs.shape[0] != xs.shape[0] - 1)
    a, e = bottom[k], bottom[k + 1] - bottom[k]
    m, ee = a.shape[0], np.einsum("ij,ij->i", bottom[k + 1] - bottom[k], e)
    pieces = Pieces(a, e, ee, a + 0.5 * e, 0.5 * np.sqrt(ee), np.arange(m, dtype=np.int64),
                    np.zeros(m, dtype=bool), axis[k], np.full(m, np.nan), np.full(m, np.nan),
                    np.zeros(1), np.zeros(1, dtype=np.int64),
                    np.full(m, RADIUS_MM - 2.0 * CORNER_MM))
    px = np.concatenate([rng.uniform(0.0, 2.0) + 0.05 * np.arange(per_row)
                         for _ in range(rows)])
    py = np.repeat(rng.uniform(-5.0, 5.0, rows), per_row)
    pz, dirs = _sheet(px, py)
    return pieces, np.column_stack((px, py, pz)), dirs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=60)
    ap.add_argument("--per-row", type=int, default=400)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    import verification.dexels as dexels_module

    pieces, points, dirs = workload(args.rows, args.per_row, np.random.default_rng(27))
    none = pieces.taken(np.zeros(pieces.size, dtype=bool))
    index = dexels_module.SweepIndex(pieces, none, RADIUS_MM, points.min(0), points.max(0),
                                     1.0, 10.0, corner_radius_mm=CORNER_MM)
    reach = np.full(points.shape[0], 3.5)
    centres = points + CORNER_MM * dirs
    index.sweep_entries("near", points[:64], dirs[:64], centres[:64], reach[:64])  # compile

    def walk(**how):
        # the index's own call, with the walk's switches set
        dexels_module.lowest_sweep_entries = functools.partial(lowest_sweep_entries, **how)
        best, out = np.inf, None
        for _ in range(args.repeat):
            start = time.process_time()
            out = index.sweep_entries("near", points, dirs, centres, reach, built=True)
            best = min(best, time.process_time() - start)
        dexels_module.lowest_sweep_entries = lowest_sweep_entries
        return best, out

    alone_s, alone = walk(grouped=False, seeded=False)
    shared_s, shared = walk()
    same = all(np.array_equal(u, v) for u, v in zip(alone[:3], shared[:3], strict=True))
    print(f"sweep walk, {points.shape[0]:,} dexels, {pieces.size:,} bull:8:1 pieces "
          f"(CPU s, fastest of {args.repeat}; load {os.getloadavg()[0]:.2f})")
    print(f"  each alone, unseeded  {alone_s:7.2f} s  pairs {alone[3]:,}")
    print(f"  grouped and seeded    {shared_s:7.2f} s  pairs {shared[3]:,}")
    print(f"  ratio {shared_s / alone_s:.2f}; values, pieces, sides bit-identical: {same}")


if __name__ == "__main__":
    main()
