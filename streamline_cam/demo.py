"""``toolpath demo``: fit the bundled curves with both methods and report side by side.

For now (fitting only) the demo fits the development blade's half profile and the paper's
Examples 4 and 5, at 0.01 mm, with the streamline method and the B-spline baseline, writes
the fits (JSON) and plots (PNG) to ``demo/`` and prints a table.
"""

from __future__ import annotations

import json
from pathlib import Path

from toolpath import read_points
from toolpath.paper_examples import bundled_data_path, example4, example5
from toolpath.plotting import plot_curve_fit

from .fit_report import fit_curve_by_method

__all__ = ["run_demo"]

DEMO_TOL_MM = 0.01


def run_demo(out: Path) -> int:
    """Run the demo, writing into ``out``; returns 0."""
    out.mkdir(parents=True, exist_ok=True)
    cases = {
        "dev_half_profile_71": read_points(bundled_data_path("dev_half_profile_71.csv")),
        "paper_example4": example4(),
        "paper_example5": example5(),
    }
    print(f"Fitting the bundled curves to {DEMO_TOL_MM} mm (streamline vs B-spline baseline)")
    print(f"{'curve':<22}{'method':<12}{'CPs':>5}{'max mm':>11}{'rms mm':>11}{'s':>8}")
    summary = []
    for name, points in cases.items():
        for method in ("streamline", "bspline"):
            curve, report = fit_curve_by_method(points, method=method, tol=DEMO_TOL_MM)
            stem = out / f"{name}_{method}"
            stem.with_suffix(".json").write_text(json.dumps(curve.to_dict()), encoding="utf-8")
            plot_curve_fit(points, curve, stem.with_suffix(".png"), title=f"{name} {method}")
            print(f"{name:<22}{method:<12}{report.n_control_points:>5}"
                  f"{report.max_error_mm:>11.5f}{report.rms_error_mm:>11.5f}"
                  f"{report.seconds:>8.3f}")
            summary.append({"curve": name, **report.as_dict()})
    (out / "report.json").write_text(json.dumps(summary, indent=2), encoding="utf-8")
    print(f"wrote fits, plots and report.json to {out.resolve()}")
    return 0
