"""Benchmark: control points and time to reach a max error, ours vs FITPACK.

Run ``python benchmarks/bench_fit.py``. Cases: the paper's Ex 4 and Ex 5 (1001 points each,
with C0 corners) and a smooth 3-D blade-like curve (1001 points). For each max-error target
(0.05, 0.01, 0.001 mm):

* ``fit_streamline_curve(points, tol=target)`` and ``fit_bspline_curve(points, tol=target)``:
  control points, achieved max error (recomputed here from ``curve(curve.params)``), wall
  time (best of 3).
* ``scipy.interpolate.splprep`` (FITPACK, adaptive knots), cubic, on the same chord-length
  parameters, with the smoothing ``s`` found by bisection on ``log(s)`` as the largest ``s``
  whose max pointwise distance ``|spline(u_i) - X_i|`` is <= target. Reported: control points
  (``len(knots) - 4``), max error, time of one call at the found ``s`` (best of 3) and the
  time of the whole ``s`` search (one run).
* ``scipy.interpolate.make_splprep`` (scipy >= 1.15), the same way.

Ratios are ours / splprep: control points, time vs one splprep call ("t/FP1") and time vs
the whole splprep ``s`` search ("t/FPs"). The make_splprep rows show the same ratios vs
splprep for reference. All figures come from one run; nothing is cached between methods.
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy
import scipy.interpolate as si
from numpy.typing import NDArray

from toolpath import (
    fit_bspline_curve,
    fit_bspline_surface,
    fit_streamline_curve,
    fit_streamline_surface,
    read_sections,
)
from toolpath.paper_examples import bundled_data_path, example4, example5

TARGETS = (0.05, 0.01, 0.001)
REPEATS = 3
MAX_BISECTIONS = 30
S_REL_TOL = 1e-3  # stop the log(s) bisection when hi / lo < 1 + S_REL_TOL
TIME_FACTOR = 3.0

OURS = ("streamline", "bspline")
REFS = ("splprep", "make_splprep")


@dataclass
class Row:
    method: str
    cps: int
    max_error: float
    time_s: float
    search_s: float | None = None
    s: float | None = None
    note: str = ""


def smooth_3d_curve(n: int = 1001) -> NDArray[np.float64]:
    """A deterministic blade-like 3-D sweep: a tapering, twisting helix with varying curvature."""
    t = np.linspace(0.0, 1.0, n)
    theta = 2.5 * np.pi * t + 0.6 * np.sin(3.0 * np.pi * t)
    r = 60.0 - 25.0 * t + 6.0 * np.sin(5.0 * np.pi * t) ** 2
    z = 150.0 * t + 8.0 * np.sin(2.0 * np.pi * t)
    return np.c_[r * np.cos(theta), 0.7 * r * np.sin(theta), z]


def chord_params(x: NDArray[np.float64]) -> NDArray[np.float64]:
    steps = np.linalg.norm(np.diff(x, axis=0), axis=1)
    u = np.concatenate(([0.0], np.cumsum(steps)))
    return u / u[-1]


def best_time(fn: Callable[[], object], repeats: int = REPEATS) -> tuple[float, object]:
    best = math.inf
    result: object = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - t0)
    return best, result


# --- FITPACK wrappers: each returns (n_control_points, max_error) -------------------------

def run_splprep(x: NDArray[np.float64], u: NDArray[np.float64], s: float) -> tuple[int, float]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tck, _ = si.splprep(list(x.T), u=u, k=3, s=s, quiet=1)
    fitted = np.asarray(si.splev(u, tck)).T
    return len(tck[0]) - 4, float(np.linalg.norm(fitted - x, axis=1).max())


def run_make_splprep(x: NDArray[np.float64], u: NDArray[np.float64], s: float
                     ) -> tuple[int, float]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        spline, _ = si.make_splprep(list(x.T), u=u, k=3, s=s)
    fitted = np.asarray(spline(u))
    if fitted.shape != x.shape:
        fitted = fitted.T
    return len(spline.t) - 4, float(np.linalg.norm(fitted - x, axis=1).max())


def search_s(runner: Callable[[NDArray, NDArray, float], tuple[int, float]],
             x: NDArray[np.float64], u: NDArray[np.float64], target: float
             ) -> tuple[float, int, float, str]:
    """Largest s (bisection on log s) whose max pointwise error is <= target.

    Bracket: ``hi = m * target**2`` (an RMS of ``target`` forces max > target when FITPACK
    reaches ``fp = s``), ``lo = hi * 1e-8``. Returns (s, cps, max_error, note).
    """
    m = x.shape[0]
    hi = m * target**2
    lo = hi * 1e-8
    note = ""
    cps_hi, err_hi = runner(x, u, hi)
    if err_hi <= target:  # the bracket's top already meets it: take it (rare)
        return hi, cps_hi, err_hi, "s at upper bracket"
    cps_lo, err_lo = runner(x, u, lo)
    if err_lo > target:
        note = "lower bracket misses target"
    best = (lo, cps_lo, err_lo)
    for _ in range(MAX_BISECTIONS):
        if hi / lo < 1.0 + S_REL_TOL:
            break
        mid = math.sqrt(lo * hi)
        cps, err = runner(x, u, mid)
        if err <= target:
            lo, best = mid, (mid, cps, err)
        else:
            hi = mid
    return best[0], best[1], best[2], note


def bench_reference(name: str, runner, x, u, target) -> Row:
    t0 = time.perf_counter()
    s, _, _, note = search_s(runner, x, u, target)
    search = time.perf_counter() - t0
    cps, err = runner(x, u, s)
    single = _bare_fit_time(name, x, u, s)  # the fit alone, without the error evaluation
    return Row(name, cps, err, single, search, s, note)


def _bare_fit_time(name: str, x, u, s) -> float:
    coords = list(x.T)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if name == "splprep":
            t, _ = best_time(lambda: si.splprep(coords, u=u, k=3, s=s, quiet=1))
        else:
            t, _ = best_time(lambda: si.make_splprep(coords, u=u, k=3, s=s))
    return t


def bench_ours(name: str, x: NDArray[np.float64], target: float) -> Row:
    fit = fit_streamline_curve if name == "streamline" else fit_bspline_curve
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        elapsed, curve = best_time(lambda: fit(x, tol=target))
    fitted = np.asarray(curve(curve.params))
    err = float(np.linalg.norm(fitted - x, axis=1).max())
    note = "" if err <= target else "MISSES target"
    if not math.isclose(err, curve.max_error, rel_tol=1e-6, abs_tol=1e-12):
        note += f" (reported max_error {curve.max_error:.3g})"
    return Row(name, curve.n_control_points, err, elapsed, note=note.strip())


# --- reporting ------------------------------------------------------------------------------

def _fmt_ratio(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def print_table(case: str, results: dict[float, dict[str, Row]]) -> None:
    print(f"\n=== {case} ===")
    header = (f"{'target':>7} {'method':<13} {'CPs':>4} {'max err':>9} {'time ms':>9} "
              f"{'search ms':>10} {'CP/FP':>6} {'t/FP1':>7} {'t/FPs':>6}  note")
    print(header)
    print("-" * len(header))
    for target, rows in results.items():
        fp = rows["splprep"]
        for method in (*OURS, *REFS):
            row = rows.get(method)
            if row is None:
                continue
            search = "-" if row.search_s is None else f"{row.search_s * 1e3:.1f}"
            ratios = (None, None, None)
            if method != "splprep":
                ratios = (row.cps / fp.cps, row.time_s / fp.time_s,
                          row.time_s / fp.search_s if fp.search_s else None)
            note = row.note
            if row.s is not None:
                note = f"s={row.s:.3g} {note}".strip()
            print(f"{target:>7g} {method:<13} {row.cps:>4d} {row.max_error:>9.2e} "
                  f"{row.time_s * 1e3:>9.1f} {search:>10} {_fmt_ratio(ratios[0]):>6} "
                  f"{_fmt_ratio(ratios[1]):>7} {_fmt_ratio(ratios[2]):>6}  {note}")


def print_summary(all_results: dict[str, dict[float, dict[str, Row]]], refs: list[str]) -> None:
    print("\n=== summary (ours vs each reference; time rule: ours <= "
          f"{TIME_FACTOR:g}x reference) ===")
    for method in OURS:
        for ref in refs:
            total = cps_ok = t1_ok = ts_ok = err_ok = 0
            for results in all_results.values():
                for target, rows in results.items():
                    ours, fp = rows[method], rows[ref]
                    total += 1
                    err_ok += ours.max_error <= target
                    cps_ok += ours.cps <= fp.cps
                    t1_ok += ours.time_s <= TIME_FACTOR * fp.time_s
                    ts_ok += ours.time_s <= TIME_FACTOR * (fp.search_s or math.inf)
            print(f"{method:<10} vs {ref:<12}: meets target {err_ok}/{total}; "
                  f"CPs <= {ref} {cps_ok}/{total}; time <= {TIME_FACTOR:g}x one {ref} call "
                  f"{t1_ok}/{total}; time <= {TIME_FACTOR:g}x {ref} s-search {ts_ok}/{total}")


def bench_surfaces() -> None:
    """Blade surface fit to 0.01 mm, beside scipy's tensor least squares on the same knots."""
    blade = read_sections(bundled_data_path("dev_blade_15x142.csv"))
    print("\nSurface: dev blade 15 x 142 to max error 0.01 mm (target: under 0.5 s)")
    print(f"  {'method':<34}{'CPs':>8}{'max err':>10}{'time s':>9}{'/scipy':>8}")
    fits = {"streamline (Algorithm 4)": fit_streamline_surface,
            "bicubic B-spline (ours)": fit_bspline_surface}
    rows = {name: best_time(lambda f=fit: f(blade, tol=0.01)) for name, fit in fits.items()}
    surface = rows["bicubic B-spline (ours)"][1]
    grid_t, grid_s = np.meshgrid(surface.t_params, surface.s_params)
    data = np.stack(blade)
    inner_t, inner_s = surface.knots_t[4:-4], surface.knots_s[4:-4]

    def scipy_fit():
        # LSQBivariateSpline needs at least one interior knot each way; a clamped end knot
        # vector is implied at the data's bounds
        return [si.LSQBivariateSpline(grid_t.ravel(), grid_s.ravel(), data[..., k].ravel(),
                                      inner_t, inner_s, kx=3, ky=3) for k in range(3)]

    scipy_time, splines = best_time(scipy_fit)
    fitted = np.stack([sp.ev(grid_t, grid_s) for sp in splines], axis=-1)
    scipy_err = float(np.linalg.norm(fitted - data, axis=-1).max())
    for name, (seconds, surf) in rows.items():
        n_t, n_s = surf.n_control_points
        print(f"  {name:<34}{f'{n_t}x{n_s}':>8}{surf.max_error:>10.4g}{seconds:>9.3f}"
              f"{seconds / scipy_time:>8.1f}")
    n_t, n_s = len(inner_t) + 4, len(inner_s) + 4
    print(f"  {'scipy LSQBivariateSpline, same knots':<34}{f'{n_t}x{n_s}':>8}{scipy_err:>10.4g}"
          f"{scipy_time:>9.3f}{1.0:>8.1f}")
    print("  (scipy's row is one least-squares solve on knots we chose; ours includes the "
          "knot search, the frame choice and the leave-one-out check)")


def main() -> int:
    cases = {
        "Ex 4 (1001 pts, 2-D, two 63 deg corners)": example4(1001),
        "Ex 5 (1001 pts, 2-D, one 20 deg corner)": example5(1001),
        "smooth 3-D blade-like helix (1001 pts)": smooth_3d_curve(1001),
    }
    have_make = hasattr(si, "make_splprep")
    print(f"numpy {np.__version__}, scipy {scipy.__version__}; "
          f"times: best of {REPEATS} (perf_counter), s-search: one run, "
          f"bisection on log(s) up to {MAX_BISECTIONS} steps (stop at hi/lo < {1 + S_REL_TOL:g})")
    if not have_make:
        print("scipy.interpolate.make_splprep unavailable (scipy < 1.15): skipped")
    refs = ["splprep", *(["make_splprep"] if have_make else [])]
    print("columns: CP/FP = CPs / splprep CPs; t/FP1 = time / one splprep call at the found s; "
          "t/FPs = time / whole splprep s-search")

    all_results: dict[str, dict[float, dict[str, Row]]] = {}
    t_start = time.perf_counter()
    for case, x in cases.items():
        u = chord_params(x)
        results: dict[float, dict[str, Row]] = {}
        for target in TARGETS:
            rows = {name: bench_ours(name, x, target) for name in OURS}
            rows["splprep"] = bench_reference("splprep", run_splprep, x, u, target)
            if have_make:
                rows["make_splprep"] = bench_reference("make_splprep", run_make_splprep,
                                                       x, u, target)
            results[target] = rows
        all_results[case] = results
        print_table(case, results)
    print_summary(all_results, refs)
    bench_surfaces()
    print(f"\ntotal wall time {time.perf_counter() - t_start:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
