"""``toolpath demo``: the whole job on bundled data, with nothing attached.

1. Fits the bundled curves (the dev blade's half profile, the paper's Examples 4 and 5) with
   the streamline method and the B-spline baseline at 0.01 mm.
2. Runs the pipeline on the bundled 15 x 142 dev blade: streamline surface, 3-axis
   finishing with a 6 mm ball (scallop 0.005 mm, chord 0.01 mm) on the ``grbl-router``,
   G-code posted, checked and verified (the program replayed and the material it leaves
   measured against the surface), then streamed into the built-in GRBL simulator over a
   real pseudo-terminal, whose journal proves every block ran exactly once.

Writes ``demo/`` (curve fits, ``blade/`` with the G-code, surface, toolpath, plots and
journal, and ``report.json``) and prints where.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from toolpath import read_points
from toolpath.paper_examples import bundled_data_path, example4, example5
from toolpath.plotting import plot_curve_fit

from .commands.run import report_lines
from .fit_report import fit_curve_by_method
from .pipeline import JobRequest, run_job
from .progress import StageBars
from .streaming import make_streamer

__all__ = ["run_demo"]

DEMO_TOL_MM = 0.01
#: ``--quick``: coarser finishing so the whole demo runs in seconds (tests use it).
QUICK_SCALLOP_MM = 0.05
QUICK_CHORD_MM = 0.02


def _curves(out: Path) -> list[dict[str, Any]]:
    out.mkdir(parents=True, exist_ok=True)
    cases = {
        "dev_half_profile_71": read_points(bundled_data_path("dev_half_profile_71.csv")),
        "paper_example4": example4(),
        "paper_example5": example5(),
    }
    print(f"Curves to {DEMO_TOL_MM} mm (streamline vs B-spline baseline)")
    print(f"  {'curve':<22}{'method':<12}{'CPs':>5}{'max mm':>11}{'rms mm':>11}{'s':>8}")
    summary = []
    for name, points in cases.items():
        for method in ("streamline", "bspline"):
            curve, report = fit_curve_by_method(points, method=method, tol=DEMO_TOL_MM)
            stem = out / f"{name}_{method}"
            stem.with_suffix(".json").write_text(json.dumps(curve.to_dict()), encoding="utf-8")
            plot_curve_fit(points, curve, stem.with_suffix(".png"), title=f"{name} {method}")
            print(f"  {name:<22}{method:<12}{report.n_control_points:>5}"
                  f"{report.max_error_mm:>11.5f}{report.rms_error_mm:>11.5f}"
                  f"{report.seconds:>8.3f}")
            summary.append({"curve": name, **report.as_dict()})
    return summary


def run_demo(out: Path, *, quick: bool = False) -> int:
    """Run the demo, writing into ``out``; returns 0 when the program ran exactly once."""
    out.mkdir(parents=True, exist_ok=True)
    curves = _curves(out / "curves")
    request = JobRequest(bundled_data_path("dev_blade_15x142.csv"))
    if quick:
        request = JobRequest(request.sections_path, scallop_mm=QUICK_SCALLOP_MM,
                             chord_tol_mm=QUICK_CHORD_MM)
    print(f"\nBlade: {request.sections_path.name} -> {request.machine}, {request.cutter}, "
          f"scallop {request.scallop_mm} mm, chord {request.chord_tol_mm} mm, streamed into "
          "the built-in simulator")
    bars = StageBars()
    try:
        result = run_job(request, out / "blade", progress=bars, stream=make_streamer("simulate"),
                         plots=True, verify=True)
    finally:
        bars.close()
    print("\n".join(report_lines(result.report)))
    (out / "report.json").write_text(
        json.dumps({"curves": curves, "blade": result.report}, indent=2), encoding="utf-8")
    print(f"wrote {out.resolve()}: report.json, curves/, blade/ "
          f"({', '.join(p.name for p in result.files.values())})")
    stream = result.report.get("stream", {})
    return 0 if stream.get("ok") and stream.get("exactly_once") else 1
