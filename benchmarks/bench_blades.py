"""Benchmark: the whole job (``toolpath run --verify``) on every bundled blade x every machine.

Run ``python benchmarks/bench_blades.py`` (coarse passes: scallop 0.02 mm, chord 0.01 mm;
``--fine`` for the defaults, scallop 0.005 mm). Blades: every ``section,x,y,z`` file in
``toolpath/data/`` (the dev blade and the real-like sets). Machines: ``grbl-router`` (3-axis,
zigzag: the reachable side), ``trunnion-ac`` and ``head-table-bc`` (5-axis lead/tilt). Every
case runs with the default ``--linking auto`` (spiral round a closed blade under 5-axis,
zigzag otherwise); the row names the linking the plan chose. One row per case:

- ``exit``: the command's exit status, and its last error line when it failed;
- ``passes``, ``points``: of the plan;
- ``scallop``: the verifier's largest scallop against the request (mm);
- ``gouge``: the verifier's deepest cut into the design surface against the chord tolerance;
- ``uncut``: the plan's uncut fraction of the surface (%); ``unreach``: the verifier's
  unreachable fraction (facing away from every tool axis the program cuts with, or
  covered by no pass), for 3-axis and 5-axis programs alike (%);
- seconds per stage (fit, plan, post, check, verify) and the whole command.

Each case runs in a fresh process (a cold start, as a user's command), so the plan column
includes the compiled kernels' cache load.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from toolpath import as_sections, read_sections

DATA = Path(__file__).resolve().parent.parent / "toolpath" / "data"
MACHINES = (("grbl-router", "3"), ("trunnion-ac", "lead-tilt"), ("head-table-bc", "lead-tilt"))
STAGES = ("fit", "plan", "post", "check", "verify")


def blade_files() -> list[Path]:
    """Every sections file (header ``section,x,y,z``) in the project's blade data.

    A ``*truth*`` file is a reference surface to measure fits against, not a blade to cut.
    """
    return sorted(p for p in DATA.glob("*.csv") if "truth" not in p.name
                  and p.read_text().splitlines()[0].replace(" ", "").lower() == "section,x,y,z")


def run_case(blade: Path, machine: str, axis: str, closed: bool, scallop_mm: float,
             chord_mm: float, out: Path) -> dict:
    """One ``toolpath run --verify``; the report (or the error) and the wall time."""
    command = [sys.executable, "-m", "streamline_cam.cli", "run", str(blade),
               "--machine", machine, "--axis", axis,
               "--scallop", str(scallop_mm), "--chord-tol", str(chord_mm),
               "-o", str(out / "part.nc"), "--verify", "--quiet"]
    start = time.perf_counter()
    done = subprocess.run(command, capture_output=True, text=True, timeout=1800)
    wall_s = time.perf_counter() - start
    report_path = out / "report.json"
    report = json.loads(report_path.read_text()) if done.returncode in (0, 1) \
        and report_path.exists() else None
    error = (done.stderr.strip().splitlines() or [""])[-1] if done.returncode else ""
    # the default linking ("auto"): spiral round a closed blade under 5-axis, else zigzag
    linking = report["plan"]["linking"] if report else ("spiral?" if closed and axis != "3"
                                                        else "zigzag?")
    return {"exit": done.returncode, "error": error, "report": report, "wall_s": wall_s,
            "linking": linking}


def row(blade: Path, machine: str, case: dict) -> str:
    """One printed row of figures."""
    name = f"{blade.stem[:22]:22} {machine:13} {case['linking']:6}"
    report = case["report"]
    if report is None:
        return f"{name} exit {case['exit']}  {case['wall_s']:6.1f} s  {case['error'][:110]}"
    plan, verify, seconds = report["plan"], report.get("verify", {}), report["seconds"]
    gouge = (verify.get("max_gouge") or {}).get("deviation_mm") or 0.0
    scallop = verify.get("max_scallop_mm") or 0.0
    stages = " ".join(f"{seconds.get(s, 0.0):6.1f}" for s in STAGES)
    # the verifier's (facing away from every axis the program cuts with, or covered by no
    # pass: 5-axis programs too), else the plan's
    unreachable = verify.get("unreachable_fraction", plan["unreachable_fraction"])
    return (f"{name} exit {case['exit']} {plan['n_passes']:5d} {plan['n_points']:7d} "
            f"{scallop:7.4f}/{plan['scallop_request_mm']:<6} {-min(gouge, 0.0):7.4f}/"
            f"{plan['chord_tol_mm']:<6} {100 * plan['uncut_fraction']:6.1f} "
            f"{100 * unreachable:6.1f}  {stages} {case['wall_s']:7.1f}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fine", action="store_true", help="default passes (scallop 0.005)")
    parser.add_argument("--blade", action="append", help="only blades whose name has this")
    args = parser.parse_args()
    scallop_mm, chord_mm = (0.005, 0.01) if args.fine else (0.02, 0.01)
    print(f"toolpath run --verify, ball 6 mm, scallop {scallop_mm} mm, chord {chord_mm} mm")
    print(f"{'blade':22} {'machine':13} {'link':6} {'exit':6} {'passes':>5} {'points':>7} "
          f"{'scallop/asked':>14} {'gouge/tol':>14} {'uncut%':>6} {'unrch%':>6}  "
          + " ".join(f"{s:>6}" for s in STAGES) + f" {'wall s':>7}")
    failed = 0
    for blade in blade_files():
        if args.blade and not any(b in blade.name for b in args.blade):
            continue
        closed = as_sections(read_sections(blade)).closed
        for machine, axis in MACHINES:
            with tempfile.TemporaryDirectory() as tmp:
                case = run_case(blade, machine, axis, closed, scallop_mm, chord_mm, Path(tmp))
            failed += case["exit"] != 0
            print(row(blade, machine, case), flush=True)
    print(f"{failed} case(s) failed")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
