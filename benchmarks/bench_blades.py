"""Benchmark: the whole job (``toolpath run --verify``) on every bundled blade x every machine.

Run ``python benchmarks/bench_blades.py`` (ball 6 mm, coarse passes: scallop 0.02 mm, chord
0.01 mm; ``--fine`` for the defaults, scallop 0.005 mm; ``--cutter``, ``--scallop``,
``--chord-tol``, ``--machine``, ``--no-verify`` to choose). Blades: every ``section,x,y,z`` file in
``toolpath/data/`` (the dev blade and the real-like sets). Machines: ``grbl-router`` (3-axis,
zigzag: the reachable side), ``trunnion-ac`` and ``head-table-bc`` (5-axis lead/tilt). Every
case runs with the default ``--linking auto`` (spiral round a closed blade under 5-axis,
zigzag otherwise); the row names the linking the plan chose. One row per case:

- ``exit``: the command's exit status, and its last error line when it failed;
- ``passes``, ``points``: of the plan;
- ``scallop``: the verifier's largest scallop against the request (mm; ``--no-verify``:
  the plan's own measurement as the run judged it);
- ``gouge``: the verifier's deepest cut into the design surface against the chord tolerance
  (``--no-verify``: the plan's measured chord error);
- ``uncut``: the plan's uncut fraction of the surface (%); ``unreach``: the verifier's
  unreachable fraction (facing away from every tool axis the program cuts with, or
  covered by no pass), for 3-axis and 5-axis programs alike (%);
- seconds per stage (fit, plan, post, check, verify) and the whole command;
- ``tries``: the plans the run made (a plan measured over the request is made again,
  tighter); ``m/p``: the kept plan's ``measure`` stage over its other stages (issue 27:
  at most 1); ``peak GB``: the command's peak resident memory (its process, from
  ``wait4``).

Each case runs in a fresh process (a cold start, as a user's command), so the plan column
includes the compiled kernels' cache load.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

from toolpath import as_sections, read_sections

DATA = Path(__file__).resolve().parent.parent / "toolpath" / "data"
MACHINES = (("grbl-router", "3"), ("trunnion-ac", "lead-tilt"), ("head-table-bc", "lead-tilt"))
STAGES = ("fit", "plan", "post", "check", "verify")
#: A case still running after this long is killed (and its row says so, exit -9).
CASE_TIMEOUT_S = 1800.0


def blade_files() -> list[Path]:
    """Every sections file (header ``section,x,y,z``) in the project's blade data.

    A ``*truth*`` file is a reference surface to measure fits against, not a blade to cut.
    """
    return sorted(p for p in DATA.glob("*.csv") if "truth" not in p.name
                  and p.read_text().splitlines()[0].replace(" ", "").lower() == "section,x,y,z")


def run_case(blade: Path, machine: str, axis: str, closed: bool, scallop_mm: float,
             chord_mm: float, out: Path, cutter: str = "ball:6", verify: bool = True) -> dict:
    """One ``toolpath run``; the report (or the error), the wall time and the peak memory."""
    command = [sys.executable, "-m", "streamline_cam.cli", "run", str(blade),
               "--machine", machine, "--axis", axis, "--cutter", cutter,
               "--scallop", str(scallop_mm), "--chord-tol", str(chord_mm),
               "-o", str(out / "part.nc"), "--quiet"] + (["--verify"] if verify else [])
    start = time.perf_counter()
    with open(out / "stderr.txt", "w+") as stderr:
        job = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=stderr)
        timer = threading.Timer(CASE_TIMEOUT_S, job.kill)  # (wait4 takes no time-out)
        timer.start()
        _, status, usage = os.wait4(job.pid, 0)  # (the child's own rusage: its peak RSS)
        timer.cancel()
        job.returncode = os.waitstatus_to_exitcode(status)
        stderr.seek(0)
        error_text = stderr.read()
    wall_s = time.perf_counter() - start
    report_path = out / "report.json"
    report = json.loads(report_path.read_text()) if job.returncode in (0, 1) \
        and report_path.exists() else None
    error = (error_text.strip().splitlines() or [""])[-1] if job.returncode else ""
    # the default linking ("auto"): spiral round a closed blade under 5-axis, else zigzag
    linking = report["plan"]["linking"] if report else ("spiral?" if closed and axis != "3"
                                                        else "zigzag?")
    return {"exit": job.returncode, "error": error, "report": report, "wall_s": wall_s,
            "linking": linking, "peak_gb": usage.ru_maxrss / 1e6}  # (KiB on Linux)


def row(blade: Path, machine: str, case: dict) -> str:
    """One printed row of figures."""
    name = f"{blade.stem[:22]:22} {machine:13} {case['linking']:6}"
    report = case["report"]
    if report is None:
        return f"{name} exit {case['exit']}  {case['wall_s']:6.1f} s  {case['error'][:110]}"
    plan, seconds = report["plan"], report["seconds"]
    verify = report.get("verify") or {}
    if verify:
        gouge = (verify.get("max_gouge") or {}).get("deviation_mm") or 0.0
        scallop = verify.get("max_scallop_mm") or 0.0
    else:  # (the plan's own measurement as the run judged it)
        kept = plan["attempts"][plan["kept_attempt"] - 1]
        scallop = kept["judged_scallop_mm"] or 0.0
        gouge = -(kept["measured_chord_mm"] or 0.0)
    stages = " ".join(f"{seconds.get(s, 0.0):6.1f}" for s in STAGES)
    # the verifier's (facing away from every axis the program cuts with, or covered by no
    # pass: 5-axis programs too), else the plan's
    unreachable = verify.get("unreachable_fraction", plan["unreachable_fraction"])
    measure_s = plan["seconds"].get("measure", 0.0)
    per_plan = measure_s / max(sum(plan["seconds"].values()) - measure_s, 1e-9)
    return (f"{name} exit {case['exit']} {plan['n_passes']:5d} {plan['n_points']:7d} "
            f"{scallop:7.4f}/{plan['scallop_request_mm']:<6} {-min(gouge, 0.0):7.4f}/"
            f"{plan['chord_tol_mm']:<6} {100 * plan['uncut_fraction']:6.1f} "
            f"{100 * unreachable:6.1f}  {stages} {case['wall_s']:7.1f} "
            f"{len(plan.get('attempts', [])):5d} {per_plan:5.2f} {case['peak_gb']:7.2f}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fine", action="store_true", help="default passes (scallop 0.005)")
    parser.add_argument("--blade", action="append", help="only blades whose name has this")
    parser.add_argument("--machine", action="append", help="only these machines")
    parser.add_argument("--cutter", default="ball:6", help="as toolpath run's (ball:6)")
    parser.add_argument("--scallop", type=float, help="mm (0.02; --fine 0.005)")
    parser.add_argument("--chord-tol", type=float, help="mm (0.01)")
    parser.add_argument("--no-verify", action="store_true",
                        help="the plan's own measurement only (no --verify)")
    args = parser.parse_args()
    scallop_mm, chord_mm = (0.005, 0.01) if args.fine else (0.02, 0.01)
    scallop_mm = args.scallop or scallop_mm
    chord_mm = args.chord_tol or chord_mm
    verify = not args.no_verify
    print(f"toolpath run{' --verify' if verify else ''}, {args.cutter}, scallop {scallop_mm} mm, "
          f"chord {chord_mm} mm")
    print(f"{'blade':22} {'machine':13} {'link':6} {'exit':6} {'passes':>5} {'points':>7} "
          f"{'scallop/asked':>14} {'gouge/tol':>14} {'uncut%':>6} {'unrch%':>6}  "
          + " ".join(f"{s:>6}" for s in STAGES) + f" {'wall s':>7} {'tries':>5} {'m/p':>5} "
          f"{'peak GB':>7}")
    failed = 0
    for blade in blade_files():
        if args.blade and not any(b in blade.name for b in args.blade):
            continue
        closed = as_sections(read_sections(blade)).closed
        for machine, axis in MACHINES:
            if args.machine and machine not in args.machine:
                continue
            with tempfile.TemporaryDirectory() as tmp:
                case = run_case(blade, machine, axis, closed, scallop_mm, chord_mm, Path(tmp),
                                args.cutter, verify)
            failed += case["exit"] != 0
            print(row(blade, machine, case), flush=True)
    print(f"{failed} case(s) failed")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
