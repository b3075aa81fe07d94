"""The true error of curve and surface fits *between* the data points of the real-like blades.

The real-like blades (``toolpath/data/dev_*``, made by ``make_real_like.py``) are analytic:
each section is evaluated here again, 40-100x denser than its data (a polyline whose chord
sag is under 0.01 um), and each fit is sampled :data:`PER_INTERVAL` times inside every data
interval; the true error there is the distance from those samples to the dense section.
Printed per blade and section: the true largest error between the data, where, the
``between data`` estimate (``toolpath.between_data``) and the count of data intervals whose
true error is over the tolerance.

    PYTHONPATH=$PWD python benchmarks/between_data_truth.py [--method streamline|bspline]
        [--surface] [--tol 0.01] [--blade dca|blunt|prop]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings

import numpy as np
from scipy.spatial import cKDTree

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import make_real_like as mrl

from toolpath import (
    as_sections,
    fit_bspline_curve,
    fit_bspline_surface,
    fit_streamline_curve,
    fit_streamline_surface,
)
from toolpath.between_data import between_data_estimate, surface_between_data

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "toolpath", "data")
FILES = {"dca": "dev_rotor_dca_11x181.csv", "blunt": "dev_rotor_blunt_9x120.csv",
         "prop": "dev_prop_7x100.csv"}
#: Fit samples inside each data interval.
PER_INTERVAL = 24
DENSE = 200001


def true_sections(blade: str) -> list[np.ndarray]:
    """Each section of ``blade`` sampled densely (closed ones end with their first point)."""
    out = []
    if blade == "dca":
        for k in range(mrl.DCA_N_SECTIONS):
            p = mrl.dca_laws(k / (mrl.DCA_N_SECTIONS - 1))
            prof = mrl.DCAProfile(p["camber_deg"], p["t_rel"])
            dense = prof.at(np.linspace(0.0, prof.length, 40001)[:-1])
            cen = mrl.polygon_centroid(dense[:, 0], dense[:, 1])
            u = np.linspace(0.0, prof.length, DENSE)[:-1]
            sec = mrl.dca_to_3d(prof.at(u), p, cen)
            out.append(np.vstack((sec, sec[:1])))
    elif blade == "blunt":
        for k in range(mrl.BL_N_SECTIONS):
            p = mrl.blunt_laws(k / (mrl.BL_N_SECTIONS - 1))
            c, r = p["chord"], p["r"]
            prof = mrl.BluntProfile(p, c)
            curve = mrl.ParamCurve(lambda q, c=c, prof=prof: c * prof(q), 4)
            dense = curve.at_arclength(np.linspace(0.0, curve.length, 40001))
            cx, cy = mrl.polygon_centroid(dense[:, 0], dense[:, 1])
            p2 = curve.at_arclength(np.linspace(0.0, curve.length, DENSE))
            g = np.radians(p["stagger_deg"])
            u, v = p2[:, 0] - cx, p2[:, 1] - cy
            m = u * np.cos(g) - v * np.sin(g) + mrl.BL_Z0 + p["sweep"]
            s = u * np.sin(g) + v * np.cos(g) + r * np.radians(mrl.BL_THETA0_DEG) + p["lean"]
            out.append(np.column_stack([r * np.cos(s / r), r * np.sin(s / r), m]))
    else:
        saved = mrl.PR_N_POINTS
        mrl.PR_N_POINTS = saved * 400  # the same cosine stations, 400x denser
        try:
            sections, _ = mrl.make_prop()
        finally:
            mrl.PR_N_POINTS = saved
        out = [np.vstack((sec, sec[:1])) for sec in sections]
    return out


def distance(query: np.ndarray, dense: np.ndarray, tree: cKDTree) -> np.ndarray:
    """Distance (mm) from each query point to the dense polyline (nearest two segments)."""
    _, idx = tree.query(query)
    best = np.full(len(query), np.inf)
    for shift in (-1, 0):
        a = dense[np.clip(idx + shift, 0, len(dense) - 2)]
        ab = dense[np.clip(idx + shift + 1, 1, len(dense) - 1)] - a
        w = np.clip(np.einsum("ij,ij->i", query - a, ab)
                    / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(query - a - w[:, None] * ab, axis=1))
    return best


def between_true(at, t: np.ndarray, dense: np.ndarray, tree: cKDTree) -> np.ndarray:
    """True largest error (mm) of ``at(u)`` inside each data interval ``t_i .. t_(i+1)``."""
    frac = np.arange(1, PER_INTERVAL) / PER_INTERVAL
    u = (t[:-1, None] + np.diff(t)[:, None] * frac[None, :]).ravel()
    d = distance(np.asarray(at(np.mod(u, 1.0))).reshape(u.size, -1), dense, tree)
    return d.reshape(t.size - 1, -1).max(axis=1)


def load(blade: str) -> list[np.ndarray]:
    data = np.loadtxt(os.path.join(DATA, FILES[blade]), delimiter=",", skiprows=1)
    return [data[data[:, 0] == k, 1:] for k in range(int(data[:, 0].max()) + 1)]


def curves(blade: str, method: str, tol: float) -> tuple[float, int, float]:
    """Fit every section; print a row each; return (worst true, intervals over, seconds)."""
    fit = fit_streamline_curve if method == "streamline" else fit_bspline_curve
    worst, over, seconds = 0.0, 0, 0.0
    for k, (points, dense) in enumerate(zip(load(blade), true_sections(blade), strict=True)):
        start = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            curve = fit(points, tol=tol, closed=None)
        seconds += time.perf_counter() - start
        t = np.asarray(curve.params, dtype=float)
        data = points
        if curve.closed and t[-1] < 1.0:
            t, data = np.append(t, 1.0), np.vstack((points, points[:1]))
        true = between_true(curve, t, dense, cKDTree(dense))
        estimate, _ = between_data_estimate(curve, t, data, closed=bool(curve.closed))
        i = int(np.argmax(true))
        n_over = int((true > tol).sum())
        worst, over = max(worst, float(true[i])), over + n_over
        print(f"  {blade} {k:2d} {'closed' if curve.closed else 'open  '} "
              f"{curve.n_control_points:3d} CPs  at data {curve.max_error:.4f}  "
              f"between: true {true[i]:.4f} at t={0.5 * (t[i] + t[i + 1]):.4f} "
              f"(step {np.linalg.norm(data[i + 1] - data[i]):.3f} mm), "
              f"estimate {estimate:.4f}, {n_over} intervals over tol"
              + (f"  [{len(caught)} warnings]" if caught else ""))
    return worst, over, seconds


def surface(blade: str, method: str, tol: float) -> tuple[float, int, float]:
    fit = fit_streamline_surface if method == "streamline" else fit_bspline_surface
    grid = as_sections(load(blade))
    start = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fitted = fit(grid, tol=tol)
    seconds = time.perf_counter() - start
    worst, over = 0.0, 0
    mask = grid.data_mask
    for j, (s_j, dense) in enumerate(zip(grid.s, true_sections(blade), strict=True)):
        t = grid.t[mask[j]]
        if grid.closed:
            t = np.append(t, 1.0)
        true = between_true(lambda u, s_j=s_j: fitted(u, np.full(np.shape(u), s_j)), t,
                            dense, cKDTree(dense))
        worst, over = max(worst, float(true.max())), over + int((true > tol).sum())
    estimate, where_j, _ = surface_between_data(fitted, grid)
    print(f"  {blade} surface {'closed' if grid.closed else 'open'}: at data "
          f"{fitted.max_error:.4f}, between: true {worst:.4f}, estimate {estimate:.4f} "
          f"(section {where_j}), {over} intervals over tol, fit {seconds:.1f} s")
    return worst, over, seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--method", choices=("streamline", "bspline"), default="streamline")
    parser.add_argument("--surface", action="store_true")
    parser.add_argument("--tol", type=float, default=0.01)
    parser.add_argument("--blade", choices=tuple(FILES), action="append")
    args = parser.parse_args()
    for blade in args.blade or list(FILES):
        run = surface if args.surface else curves
        worst, over, seconds = run(blade, args.method, args.tol)
        print(f"{blade} {args.method}: true max between data {worst:.4f} mm, "
              f"{over} intervals over {args.tol:g} mm, fits {seconds:.1f} s")


if __name__ == "__main__":
    main()
