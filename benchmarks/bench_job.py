"""The whole job as a user runs it, cold and warm (issue 27).

Run: ``python benchmarks/bench_job.py [--quick] [--skip-run] [--skip-warm-up] [--split]``

Each command runs as a user types it (``python -m streamline_cam.cli ...`` from this
checkout, a fresh interpreter each time), twice:

* **cold**: with an empty kernel cache (``NUMBA_CACHE_DIR`` set to a new temporary folder
  for that command alone): the first run after a fresh install, compiling every kernel it
  uses;
* **warm**: the same command again, with the cache the cold run left.

Commands: ``toolpath --help``; ``toolpath check`` of the 5-axis program; ``toolpath plan``
(dev blade standing on ``trunnion-ac``, 5-axis lead 10, the README's coarse scallop 0.05 mm
and chord 0.02 mm: the issue's 127 s / 8.1 s row); ``toolpath run --verify`` on the dev
blade, 3-axis on ``grbl-router`` and 5-axis on ``trunnion-ac`` (ball 6, scallop 0.005,
chord 0.01; ``--quick``: scallop 0.05, chord 0.02), with the stage split of the run's report
(``seconds``), the planner's own (``plan.seconds``) and the wall seconds outside the stages
(start-up and imports, writing the files, the interpreter's exit). Then ``toolpath warm-up``
on an empty cache (what ``make install`` runs) and the 5-axis plan right after it: the first
job of an install that ran the warm-up.

``--split`` prints only where the warm-up's compiling goes: the recorded kernels compiled
one after the other in one process on an empty cache, with the CPU seconds of each
kernel's compile (its own, without the kernels it calls; numba's ``numba:compile`` events)
and the kernels compiled for more than one signature (each should have one).

Beside each figure: the issue's "today" figures, and the ratios the targets name, measured
in this run: ``cold - warm`` against the 15 s cold-start target, ``--help`` and ``check``
against 0.5 s, the planner's ``measure`` stage against its other stages (wall, from the
report: at most 1). The machine is shared: wall seconds move with the load (printed), the CPU
seconds of the command (user + system, all its threads) much less; read the ratios.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BLADE = ROOT / "toolpath" / "data" / "dev_blade_15x142.csv"

COLD_TARGET_S = 15.0
START_TARGET_S = 0.5
#: The issue's figures (2-core machine, quiet): command -> (cold s, warm s).
TODAY = {
    "help": (None, 2.6),
    "plan 5-axis coarse": (127.0, 8.1),
    "run 5-axis": (None, 13.5),
    "run 5-axis + verify": (None, 13.5 + 54.0),
}
PLAN_ARGS = ["--machine", "trunnion-ac", "--axis", "lead-tilt", "--lead", "10",
             "--rotate", "y:-90", "--on-table", "--scallop", "0.05", "--chord-tol", "0.02"]


def _run(argv: list[str], cache: Path, cwd: Path) -> tuple[float, float, str]:
    """Wall and CPU seconds of ``toolpath argv`` in a fresh interpreter, and its stdout."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": str(cache)}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "streamline_cam.cli", *argv], cwd=cwd, env=env,
                          capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode not in (0, 1):
        raise SystemExit(f"toolpath {' '.join(argv)} failed ({done.returncode}):\n"
                         f"{done.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, done.stdout


def _report(stdout: str) -> dict:
    """The JSON report a command printed first (``--json``)."""
    start = stdout.index("{")
    return json.JSONDecoder().raw_decode(stdout[start:])[0]


def _stages(seconds: dict | None) -> str:
    return " ".join(f"{k} {v:.1f}" for k, v in (seconds or {}).items())


def _measure_share(seconds: dict | None) -> str:
    """The planner's ``measure`` stage over its other stages (wall), against the target 1."""
    seconds = dict(seconds or {})
    measure = seconds.pop("measure", None)
    planning = sum(seconds.values())
    if measure is None or planning <= 0:
        return "measure/plan -"
    verdict = "ok" if measure <= planning else "OVER"
    return f"measure/plan {measure / planning:.2f} {verdict} (<= 1)"


def _outside_stages(wall_s: float, seconds: dict | None) -> float:
    """Wall seconds of a run outside its stages: start-up, imports, files, the exit."""
    return wall_s - sum((seconds or {}).values())


def _verdict(seconds: float, target_s: float) -> str:
    return "ok" if seconds <= target_s else "OVER"


class Table:
    """Rows of cold/warm figures, printed as they come."""

    def __init__(self) -> None:
        print(f"{'command':<28}{'today cold/warm':>16}{'cold s (cpu)':>16}"
              f"{'warm s (cpu)':>16}{'cold-warm':>11}  target")

    def row(self, name: str, cold: tuple[float, float] | None, warm: tuple[float, float],
            target: str = "cold") -> None:
        today = TODAY.get(name, (None, None))
        text = "/".join("-" if v is None else f"{v:g}" for v in today)
        cold_text = "-" if cold is None else f"{cold[0]:6.1f} ({cold[1]:5.1f})"
        line = f"{name:<28}{text:>16}{cold_text:>16}{f'{warm[0]:6.2f} ({warm[1]:5.2f})':>16}"
        if target == "cold" and cold is not None:
            extra, extra_cpu = cold[0] - warm[0], cold[1] - warm[1]
            line += (f"{extra:>10.1f}s  wall {_verdict(extra, COLD_TARGET_S)}, cpu "
                     f"{extra_cpu:.1f} s {_verdict(extra_cpu, COLD_TARGET_S)} "
                     f"(<= {COLD_TARGET_S:g} s)")
        elif target == "start":
            line += (f"{'':>11}  wall {_verdict(warm[0], START_TARGET_S)}, cpu "
                     f"{_verdict(warm[1], START_TARGET_S)} (<= {START_TARGET_S:g} s)")
        print(line, flush=True)


def compile_split() -> None:
    """The warm-up's kernels compiled in this process, and the CPU seconds of each compile.

    Run with an empty ``NUMBA_CACHE_DIR`` (``--split`` sets one). A compile's own time is
    its time less that of the compiles it started (the kernels it calls).
    """
    from collections import defaultdict

    from numba.core import event

    from streamline_cam.warmup import warm_up

    own: dict[str, float] = defaultdict(float)
    signatures: dict[str, list[str]] = defaultdict(list)
    running: list[list] = []  # [name, cpu at start, cpu of the compiles it started]

    class Compiles(event.Listener):
        def on_start(self, ev: event.Event) -> None:
            func = ev.data["dispatcher"].py_func
            running.append([f"{func.__module__}.{func.__qualname__}", time.process_time(), 0.0])

        def on_end(self, ev: event.Event) -> None:
            name, start, inner = running.pop()
            took = time.process_time() - start
            own[name] += took - inner
            signatures[name].append(str(ev.data["args"]))
            if running:
                running[-1][2] += took

    event.register("numba:compile", Compiles())
    cpu = time.process_time()
    wall = warm_up(lambda text: print(text, flush=True), processes=1)
    cpu = time.process_time() - cpu
    print(f"warm-up in one process: {wall:.1f} s wall, {cpu:.1f} s cpu, of which compiling "
          f"{sum(own.values()):.1f} s cpu; load {os.getloadavg()[0]:.1f}")
    print(f"{'cpu s':>7} {'share':>6} {'sigs':>4}  kernel (own compile time)")
    for name, seconds in sorted(own.items(), key=lambda item: -item[1]):
        if seconds >= 0.1:
            print(f"{seconds:7.2f} {seconds / cpu:6.1%} {len(signatures[name]):4d}  {name}")
    ours = ("toolpath.", "verification.", "streamline_cam.", "gcode.", "machines.")
    twice = {name: sigs for name, sigs in signatures.items()
             if len(sigs) > 1 and name.startswith(ours)}
    print("kernels compiled for more than one signature:", "none" if not twice else "")
    for name, sigs in twice.items():
        print(f"  {name}:", *sigs, sep="\n    ")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="run jobs at scallop 0.05 mm, chord 0.02 mm")
    parser.add_argument("--skip-run", action="store_true", help="no 'toolpath run' rows")
    parser.add_argument("--skip-warm-up", action="store_true", help="no 'warm-up' row")
    parser.add_argument("--split", action="store_true",
                        help="only the warm-up's compile time, kernel by kernel")
    parser.add_argument("--split-here", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.split_here:  # (the child --split starts, on an empty cache)
        compile_split()
        return
    if args.split:
        with tempfile.TemporaryDirectory(prefix="bench-job-split-") as cache:
            subprocess.run([sys.executable, __file__, "--split-here"], check=True,
                           env={**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": cache})
        return
    load = os.getloadavg()
    print(f"bench_job: {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
          f"{os.cpu_count()} CPUs, load average {load[0]:.1f} {load[1]:.1f} {load[2]:.1f} "
          "(shared: compare within this run)")
    with tempfile.TemporaryDirectory(prefix="bench-job-") as folder:
        work = Path(folder)
        caches = iter(work / f"cache{i}" for i in range(100))
        fit_cache = next(caches)
        _run(["fit", "surface", str(BLADE), "--tol", "0.01", "-o", "blade.json"], fit_cache,
             work)
        table = Table()

        cache = next(caches)
        help_cold = _run(["--help"], cache, work)[:2]
        help_warm = _run(["--help"], cache, work)[:2]
        table.row("help", help_cold, help_warm, target="start")

        cache = next(caches)
        plan_argv = ["plan", "blade.json", *PLAN_ARGS, "-o", "path.npz", "--json"]
        *plan_cold, _ = _run(plan_argv, cache, work)
        *plan_warm, out = _run(plan_argv, cache, work)
        table.row("plan 5-axis coarse", tuple(plan_cold), tuple(plan_warm))
        seconds = _report(out).get("seconds")
        print(f"{'':<4}planner stages (warm): {_stages(seconds)}; {_measure_share(seconds)}")

        _run(["post", "path.npz", "--machine", "trunnion-ac", "-o", "part5.nc"], cache, work)
        check_argv = ["check", "part5.nc", "--machine", "trunnion-ac"]
        check_cold = _run(check_argv, next(caches), work)[:2]
        check_warm = _run(check_argv, cache, work)[:2]
        table.row("check (5-axis program)", check_cold, check_warm, target="start")

        if not args.skip_run:
            fine = ["--scallop", "0.05", "--chord-tol", "0.02"] if args.quick else []
            for label, extra in (("3-axis", ["--machine", "grbl-router"]),
                                 ("5-axis", ["--machine", "trunnion-ac", "--axis", "lead-tilt",
                                             "--lead", "10"])):
                cache = next(caches)
                run_argv = ["run", str(BLADE), *extra, *fine, "--verify", "--quiet", "--json",
                            "-o", f"job-{label}/part.nc"]
                *cold, _ = _run(run_argv, cache, work)
                *warm, out = _run(run_argv, cache, work)
                table.row(f"run {label} + verify", tuple(cold), tuple(warm))
                report = _report(out)
                planner = report.get("plan", {}).get("seconds")
                print(f"{'':<4}stages (warm): {_stages(report.get('seconds'))}; planner: "
                      f"{_stages(planner)}, {_measure_share(planner)}; outside them "
                      f"{_outside_stages(warm[0], report.get('seconds')):.1f} (start-up, "
                      "files, exit)", flush=True)

        if not args.skip_warm_up:
            cache = next(caches)
            warm_up = _run(["warm-up", "--quiet"], cache, work)[:2]
            after = _run(plan_argv, cache, work)[:2]
            print(f"warm-up on an empty cache (make install): {warm_up[0]:.1f} s "
                  f"(cpu {warm_up[1]:.1f}); the 5-axis plan right after it: {after[0]:.1f} s "
                  f"(cpu {after[1]:.1f}), {after[0] - plan_warm[0]:+.1f} s against warm "
                  f"(target <= {COLD_TARGET_S:g} s)")


if __name__ == "__main__":
    main()
