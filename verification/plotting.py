"""The deviation map as a PNG (matplotlib, Agg backend): the only module that imports it.

Left: the deviation over the surface's parameter square (``t`` along the passes, ``s``
across), diverging colours centred on zero: red is a gouge (material missing below the
design), blue is material left; grey is *not cut* (more than the horizon left), white is
*hidden* (a Z-map cannot see it). The deepest gouge is marked with a cross, the largest
scallop (away from uncut areas) with a circle. Right: the area of the surface per deviation bin.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from .errors import VerificationError
from .report import VerificationReport

__all__ = ["plot_deviation_map"]


def _colour_limit_mm(report: VerificationReport) -> float:
    """Half-range of the colour scale, mm: the larger of the worst gouge and scallop."""
    candidates = [report.max_gouge_mm, 5.0 * report.gouge_tol_mm]
    if report.max_scallop is not None:
        candidates.append(report.max_scallop.deviation_mm)
    if np.isfinite(report.requested_scallop_mm):
        candidates.append(report.requested_scallop_mm)
    return float(max(candidates))


def plot_deviation_map(report: VerificationReport, path: str | Path, *,
                       title: str = "", limit_mm: float | None = None) -> Path:
    """Write the deviation map and its histogram as a PNG.

    Parameters
    ----------
    report : VerificationReport
        A report with its ``deviation_map``.
    path : str or Path
        The PNG to write.
    title : str
        Figure title (default: machine, cutter and the extremes).
    limit_mm : float, optional
        Half-range of the colour scale, mm (default: the worst gouge or excess).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    VerificationError
        When the report carries no deviation map.
    """
    m = report.deviation_map
    if m is None:
        raise VerificationError("the report has no deviation map to plot")
    lim = limit_mm if limit_mm is not None else _colour_limit_mm(report)
    dev = m.deviation_mm.T  # rows: s, columns: t
    uncut = np.isposinf(dev)
    shown = np.ma.masked_invalid(np.where(uncut, np.nan, dev))
    fig, (left, right) = plt.subplots(1, 2, figsize=(13, 5.5),
                                      gridspec_kw={"width_ratios": [2.2, 1]})
    extent = (float(m.t[0]), float(m.t[-1]), float(m.s[0]), float(m.s[-1]))
    if uncut.any():
        left.imshow(np.where(uncut, 1.0, np.nan), origin="lower", extent=extent,
                    aspect="auto", cmap="Greys", vmin=0.0, vmax=4.0, interpolation="nearest")
    image = left.imshow(shown * 1000.0, origin="lower", extent=extent, aspect="auto",
                        cmap="RdBu", vmin=-lim * 1000.0, vmax=lim * 1000.0,
                        interpolation="nearest")
    fig.colorbar(image, ax=left, label="deviation (um): red gouge, blue material left")
    if report.max_gouge is not None:
        g = report.max_gouge
        left.plot([g.t], [g.s], "x", color="black", ms=10, mew=2,
                  label=f"gouge {report.max_gouge_mm * 1000:.1f} um, line {g.line}")
    if report.max_scallop is not None:
        e = report.max_scallop
        left.plot([e.t], [e.s], "o", mfc="none", color="black", ms=9,
                  label=f"scallop {e.deviation_mm * 1000:.1f} um, line {e.line}")
    if report.max_gouge is not None or report.max_scallop is not None:
        left.legend(loc="upper right", fontsize=8)
    left.set_xlabel("t (along the passes)")
    left.set_ylabel("s (across the passes)")
    s = report.stats
    edges = np.asarray(s.histogram_edges_mm) * 1000.0
    if edges.size:
        right.bar(edges[:-1], s.histogram_area_mm2, width=np.diff(edges), align="edge",
                  color="tab:blue", edgecolor="white")
    right.set_xlabel("deviation (um)")
    right.set_ylabel("area (mm^2)")
    right.set_title(f"cut {s.cut_area_mm2:.0f} mm^2, not cut {s.uncut_area_mm2:.0f}, "
                    f"hidden {s.hidden_area_mm2:.0f}", fontsize=9)
    fig.suptitle(title or (f"{report.machine}, {report.cutter}: gouge "
                           f"{report.max_gouge_mm * 1000:.1f} um, scallop "
                           f"{report.max_scallop_mm * 1000:.1f} um"))
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
