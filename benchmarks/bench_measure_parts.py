"""Where a ball plan's measurement spends its CPU: per part, against the planning's.

For each ball case of ``bench_toolpath.py``'s default table (ball 6, scallop 0.005 mm,
chord 0.01 mm): the planning's process CPU (``measure=False``, the fastest of
:data:`REPEATS`), then the measurement's two calls (:func:`measure_chord`,
:func:`measure_scallop`) on that plan's result, the fastest of :data:`REPEATS` runs each
(process CPU, all threads), then again under ``cProfile`` on the same clock, split by the
functions :data:`PARTS` names (their cumulative CPU, with the profiler's overhead; a part's
calls inside another part count in both). ``m/p`` is the measurement's CPU over the
planning's (issue 27: at most 1). The counts: seeds, seeds ray cast, moves measured.

``stand5ac`` is ``stand5`` planned and measured for the ``trunnion-ac`` machine, whose
joint interpolation the plan is checked under: the measure places the cutter inside each
move as the joints move it (issue 27's own case is such a job); the others move
tip-linear.

Opt-in, not run by default: ``bull5ac``, issue 27's user job as the CLI runs it
(:data:`JOBS`: the dev blade's points fitted and placed by ``toolpath run``, 5-axis under
trunnion-ac, bull:8:1, lead 10 degrees, scallop 0.005 mm, chord 0.01 mm); its planning and
measure are timed on the arguments that run passes to ``plan_finishing``, the fastest of
:data:`JOB_REPEATS` (its measure takes about half a minute).

Run: ``python benchmarks/bench_measure_parts.py [CASE ...]`` (cases by the short names of
:data:`CASES` and :data:`JOBS`; default all of :data:`CASES`).
"""

from __future__ import annotations

import cProfile
import pstats
import sys
import tempfile
import time

from bench_toolpath import _cases

from machines import load_machine
from streamline_cam import cli, pipeline
from toolpath.paper_examples import bundled_data_path
from toolpath.planning import finishing, plan_finishing

#: Short name -> (bench_toolpath's case name, axis mode[, machine]).
CASES = {"cap3": ("sphere R50 cap", "3"), "cap5": ("sphere R50 cap", "lead-tilt"),
         "ell3": ("elliptic blade", "3"), "ell5": ("elliptic blade", "lead-tilt"),
         "dome5": ("sphere R150 dome", "lead-tilt"),
         "stand5": ("dev blade (standing)", "lead-tilt"),
         "stand5ac": ("dev blade (standing)", "lead-tilt", "trunnion-ac"),
         "lying3": ("dev blade (lying)", "3")}

#: Opt-in cases: short name -> the ``toolpath run`` arguments of a whole job (its points
#: fitted and placed as the CLI does), whose ``plan_finishing`` call is timed.
JOBS = {"bull5ac": ["run", str(bundled_data_path("dev_blade_15x142.csv")), "--machine",
                    "trunnion-ac", "--axis", "lead-tilt", "--lead", "10", "--cutter",
                    "bull:8:1", "--scallop", "0.005", "--chord-tol", "0.01"]}

#: Column -> (module file, function name) whose cumulative CPU it shows.
PARTS = {"contacts": ("chord_measure.py", "_end_contacts"),
         "gaps": ("chord_measure.py", "_move_chunk_gaps"),
         "seeds": ("chord_measure.py", "_cusp_seeds"),
         "volume": ("cut_volume.py", "__init__"),
         "uncut": ("uncut_area.py", "on_grid"),
         "estimate": ("cusp_estimates.py", "ball_cusp_estimates"),
         "torus": ("cusp_estimates.py", "torus_cusp_bounds"),
         "ridges": ("cusp_kernel.py", "ridges"),
         "casts": ("cusp_search.py", "run")}

#: Runs per case; each figure is the fastest (a shared machine's noise is one-sided).
REPEATS = 3

#: ... per opt-in job (:data:`JOBS`).
JOB_REPEATS = 2


def _plan_inputs(surface, extra: dict, axis: str, machine: str | None = None
                 ) -> tuple[float, tuple, tuple]:
    """The planning's CPU and the arguments the plan's measure stage passes on."""
    kw = dict(scallop_mm=0.005, chord_tol_mm=0.01, axis_mode=axis)
    if axis != "3":
        kw.update(lead_deg=10.0, linking=extra.get("linking", "zigzag"))
    if machine is not None:
        kw.update(machine=load_machine(machine))
    return _timed_plan((surface, "ball:6"), kw, REPEATS)


class _Captured(Exception):
    """Raised to stop a job once its plan_finishing arguments are captured."""


def _job_inputs(argv: list[str]) -> tuple[float, tuple, tuple]:
    """As :func:`_plan_inputs`, for the ``plan_finishing`` call of a ``toolpath run`` job."""
    captured = {}
    plan_call = pipeline.plan_finishing

    def plan(*args, **kwargs):
        captured["plan"] = (args, {k: v for k, v in kwargs.items() if k != "progress"})
        raise _Captured

    pipeline.plan_finishing = plan
    try:
        with tempfile.TemporaryDirectory() as out:
            cli.main([*argv, "--quiet", "-o", f"{out}/part.nc"])
    except _Captured:
        pass
    finally:
        pipeline.plan_finishing = plan_call
    args, kwargs = captured["plan"]
    return _timed_plan(args, kwargs, JOB_REPEATS)


def _timed_plan(args: tuple, kw: dict, repeats: int) -> tuple[float, tuple, tuple]:
    """The planning's CPU (fastest of ``repeats``) and its measure calls' arguments."""
    plan_finishing(*args, **kw)  # the kernels loaded
    plan_cpu = float("inf")
    for _ in range(repeats):
        c0 = time.process_time()
        plan_finishing(*args, measure=False, **kw)
        plan_cpu = min(plan_cpu, time.process_time() - c0)
    captured = {}
    chord_call, scallop_call = finishing.measure_chord, finishing.measure_scallop

    def chord(*args, **kwargs):
        captured["chord"] = (args, kwargs)
        return chord_call(*args, **kwargs)

    def scallop(*args, **kwargs):
        captured["scallop"] = (args, kwargs)
        return scallop_call(*args, **kwargs)

    finishing.measure_chord, finishing.measure_scallop = chord, scallop
    try:
        plan_finishing(*args, **kw)
    finally:
        finishing.measure_chord, finishing.measure_scallop = chord_call, scallop_call
    return plan_cpu, captured["chord"], captured["scallop"]


def main() -> None:
    names = sys.argv[1:] or list(CASES)
    unknown = [name for name in names if name not in CASES and name not in JOBS]
    if unknown:
        raise SystemExit(f"unknown case(s) {', '.join(unknown)}: choose from "
                         f"{', '.join([*CASES, *JOBS])}")
    surfaces = ({name: (surface, extra) for name, surface, extra in _cases(quick=False)}
                if any(name in CASES for name in names) else {})
    print(f"process CPU, ms (fastest of {REPEATS}, jobs {JOB_REPEATS}); m/p: measure over plan")
    print(f"{'case':<8}{'plan':>7}{'chord':>7}{'scallop':>8}{'m/p':>6}"
          + "".join(f"{p:>9}" for p in PARTS) + f"{'seeds':>8}{'cast':>6}{'moves':>7}")
    for name in names:
        if name in JOBS:
            repeats = JOB_REPEATS
            plan_cpu, (c_args, c_kw), (s_args, s_kw) = _job_inputs(JOBS[name])
        else:
            repeats = REPEATS
            case, axis, *machine = CASES[name]
            surface, extra = surfaces[case]
            plan_cpu, (c_args, c_kw), (s_args, s_kw) = _plan_inputs(surface, extra, axis,
                                                                     *machine)
        best = {"chord": float("inf"), "scallop": float("inf")}
        parts = dict.fromkeys(PARTS, float("inf"))
        for _ in range(repeats):
            # timed without the profiler (its overhead on Python-level steps would count),
            # then profiled for the parts
            c0 = time.process_time()
            chord = finishing.measure_chord(*c_args, **c_kw)
            c1 = time.process_time()
            scallop = finishing.measure_scallop(*s_args[:4], chord, **s_kw)
            c2 = time.process_time()
            best["chord"] = min(best["chord"], c1 - c0)
            best["scallop"] = min(best["scallop"], c2 - c1)
            profile = cProfile.Profile(time.process_time)
            profile.enable()
            chord = finishing.measure_chord(*c_args, **c_kw)
            finishing.measure_scallop(*s_args[:4], chord, **s_kw)
            profile.disable()
            stats = pstats.Stats(profile).stats
            for part, (module, func) in PARTS.items():
                cum = sum(v[3] for (path, _, f), v in stats.items()
                          if f == func and path.endswith("/planning/" + module))
                parts[part] = min(parts[part], cum)
        measure = best["chord"] + best["scallop"]
        print(f"{name:<8}{1e3 * plan_cpu:>7.0f}{1e3 * best['chord']:>7.0f}"
              f"{1e3 * best['scallop']:>8.0f}{measure / plan_cpu:>6.2f}"
              + "".join(f"{1e3 * parts[p]:>9.1f}" for p in PARTS)
              + f"{scallop.n_samples:>8}{scallop.n_cast:>6}{chord.n_moves:>7}", flush=True)


if __name__ == "__main__":
    main()
