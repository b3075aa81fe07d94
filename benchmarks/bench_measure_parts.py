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

Run: ``python benchmarks/bench_measure_parts.py [CASE ...]`` (cases by the short names of
:data:`CASES`; default all).
"""

from __future__ import annotations

import cProfile
import pstats
import sys
import time

from bench_toolpath import _cases

from machines import load_machine
from toolpath.planning import finishing, plan_finishing

#: Short name -> (bench_toolpath's case name, axis mode[, machine]).
CASES = {"cap3": ("sphere R50 cap", "3"), "cap5": ("sphere R50 cap", "lead-tilt"),
         "ell3": ("elliptic blade", "3"), "ell5": ("elliptic blade", "lead-tilt"),
         "dome5": ("sphere R150 dome", "lead-tilt"),
         "stand5": ("dev blade (standing)", "lead-tilt"),
         "stand5ac": ("dev blade (standing)", "lead-tilt", "trunnion-ac"),
         "lying3": ("dev blade (lying)", "3")}

#: Column -> (module file, function name) whose cumulative CPU it shows.
PARTS = {"contacts": ("chord_measure.py", "_end_contacts"),
         "gaps": ("chord_measure.py", "_move_chunk_gaps"),
         "seeds": ("chord_measure.py", "_cusp_seeds"),
         "volume": ("cut_volume.py", "__init__"),
         "uncut": ("uncut_area.py", "on_grid"),
         "estimate": ("cusp_estimates.py", "ball_cusp_estimates"),
         "ridges": ("cusp_kernel.py", "ridges"),
         "casts": ("cusp_search.py", "run")}

#: Runs per case; each figure is the fastest (a shared machine's noise is one-sided).
REPEATS = 3


def _plan_inputs(surface, extra: dict, axis: str, machine: str | None = None
                 ) -> tuple[float, tuple, tuple]:
    """The planning's CPU and the arguments the plan's measure stage passes on."""
    kw = dict(scallop_mm=0.005, chord_tol_mm=0.01, axis_mode=axis)
    if axis != "3":
        kw.update(lead_deg=10.0, linking=extra.get("linking", "zigzag"))
    if machine is not None:
        kw.update(machine=load_machine(machine))
    plan_finishing(surface, "ball:6", **kw)  # the kernels loaded
    plan_cpu = float("inf")
    for _ in range(REPEATS):
        c0 = time.process_time()
        plan_finishing(surface, "ball:6", measure=False, **kw)
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
        plan_finishing(surface, "ball:6", **kw)
    finally:
        finishing.measure_chord, finishing.measure_scallop = chord_call, scallop_call
    return plan_cpu, captured["chord"], captured["scallop"]


def main() -> None:
    names = sys.argv[1:] or list(CASES)
    surfaces = {name: (surface, extra) for name, surface, extra in _cases(quick=False)}
    print(f"process CPU, ms (fastest of {REPEATS}); m/p: measure over plan")
    print(f"{'case':<8}{'plan':>7}{'chord':>7}{'scallop':>8}{'m/p':>6}"
          + "".join(f"{p:>9}" for p in PARTS) + f"{'seeds':>8}{'cast':>6}{'moves':>7}")
    for name in names:
        case, axis, *machine = CASES[name]
        surface, extra = surfaces[case]
        plan_cpu, (c_args, c_kw), (s_args, s_kw) = _plan_inputs(surface, extra, axis,
                                                                 *machine)
        best = {"chord": float("inf"), "scallop": float("inf")}
        parts = dict.fromkeys(PARTS, float("inf"))
        for _ in range(REPEATS):
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
