"""The whole job on the bundled blades with scattered points: which run, which stop and why.

Run ``python benchmarks/scatter_jobs.py [--um 1 2] [--seeds 8] [--machine trunnion-ac]``
(about 5 s a job on a 2-core machine). Each bundled blade gets a Gaussian scatter of
``--um`` micrometres on every coordinate (``--seeds`` draws, seeded as
``tests/toolpath/test_cli_fit.py`` draws them, written with 6 decimals), and
``toolpath run`` plans it with the defaults (ball 6, scallop 0.005 mm, chord 0.01 mm,
``--fit-tol 0.01``; 5-axis lead 10 on a 5-axis machine), as a user types it. Per blade and
scatter it prints how many jobs ran (exit 0) of those drawn, then each job that did not:
its seed, exit code, and the error's last clause (what the user is told to do). The
seam rule, the fit's frames and knots and the planner's gouge checks all meet the scatter
here; ``benchmarks/scatter_traits.py`` measures the seam rule and the scatter estimate
alone.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from toolpath.paper_examples import bundled_data_path
from toolpath.pointio import read_sections

BLADES = ("dev_rotor_dca_11x181", "dev_prop_7x100", "dev_rotor_blunt_9x120",
          "dev_blade_15x142")
FIVE_AXIS = {"trunnion-ac", "head-table-bc"}


def _write_scattered(name: str, um: float, seed: int, path: Path) -> None:
    """The bundled blade ``name`` with ``um`` of scatter (seed ``seed``) as a CSV at ``path``."""
    rng = np.random.default_rng(seed)
    with path.open("w") as out:
        out.write("section,x,y,z\n")
        for j, section in enumerate(read_sections(bundled_data_path(f"{name}.csv"))):
            for x, y, z in section + rng.normal(0.0, 1e-3 * um, section.shape):
                out.write(f"{j},{x:.6f},{y:.6f},{z:.6f}\n")


def _last_clause(stderr: str) -> str:
    """The error line's last clause (after its last ';'; its last 160 characters)."""
    errors = [line for line in stderr.splitlines() if line.startswith("toolpath: error:")]
    line = errors[-1] if errors else (stderr.strip().splitlines() or [""])[-1]
    return line.rsplit(";", 1)[-1].strip()[-160:]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--um", type=float, nargs="+", default=[1.0, 2.0],
                        help="scatter, um (1 2)")
    parser.add_argument("--seeds", type=int, default=8, help="draws per scatter (8)")
    parser.add_argument("--machine", default="trunnion-ac", help="machine (trunnion-ac)")
    args = parser.parse_args()
    axis = (["--axis", "lead-tilt", "--lead", "10"] if args.machine in FIVE_AXIS else [])
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for name in BLADES:
            for um in args.um:
                stopped = []
                for seed in range(args.seeds):
                    points = folder / f"{name}_{um:g}um_{seed}.csv"
                    _write_scattered(name, um, seed, points)
                    job = subprocess.run(
                        [sys.executable, "-m", "streamline_cam.cli", "run", str(points),
                         "--machine", args.machine, *axis, "--quiet",
                         "-o", str(folder / points.stem / "part.nc")],
                        capture_output=True, text=True, timeout=1200)
                    if job.returncode:
                        stopped.append((seed, job.returncode, _last_clause(job.stderr)))
                ran = args.seeds - len(stopped)
                print(f"{name:24s} {um:g} um: {ran}/{args.seeds} ran", flush=True)
                for seed, code, clause in stopped:
                    print(f"    seed {seed}: exit {code}: ... {clause}", flush=True)


if __name__ == "__main__":
    main()
