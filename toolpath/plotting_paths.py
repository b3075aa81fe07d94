"""Headless plots of toolpaths over their surface (matplotlib, Agg backend).

:func:`plot_toolpath` writes a PNG with the cutting passes (coloured by pass) and the
linking moves over a wireframe of the surface, in 3-D and seen from above, with the
report's figures as a caption.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import LineCollection
from mpl_toolkits.mplot3d.art3d import Line3DCollection
from numpy.typing import NDArray

from .path import MoveKind, Toolpath
from .surface import ParametricSurface

__all__ = ["plot_toolpath"]


def _segments(path: Toolpath, max_segments: int) -> tuple[NDArray[np.float64], ...]:
    """Cutting segments (with their pass) and linking segments, decimated to a budget."""
    pos = path.positions_mm
    kinds = path.kinds[1:]
    cutting = (kinds == MoveKind.CUT) & (path.pass_index[1:] >= 0)
    cut_idx = np.flatnonzero(cutting)
    link_idx = np.flatnonzero(~cutting & (kinds != MoveKind.RAPID))
    rapid_idx = np.flatnonzero(kinds == MoveKind.RAPID)
    if cut_idx.size > max_segments:
        passes = path.pass_index[cut_idx + 1]
        keep_every = int(np.ceil(cut_idx.size / max_segments))
        cut_idx = cut_idx[passes % keep_every == 0]
    segs = np.stack([pos[cut_idx], pos[cut_idx + 1]], axis=1)
    links = np.stack([pos[link_idx], pos[link_idx + 1]], axis=1)
    rapids = np.stack([pos[rapid_idx], pos[rapid_idx + 1]], axis=1)
    return segs, path.pass_index[cut_idx + 1].astype(float), links, rapids


def plot_toolpath(surface: ParametricSurface, path: Toolpath, out: str | Path, *,
                  report: Any = None, title: str = "", max_segments: int = 150_000,
                  show_rapids: bool = False) -> Path:
    """Write a PNG of ``path`` over ``surface``.

    Parameters
    ----------
    surface : ParametricSurface
        Drawn as a 24 x 24 wireframe of iso-curves.
    path : Toolpath
        Cutting moves coloured by pass; lead, link and plunge moves in grey.
    out : str or Path
        The PNG file.
    report : PlanningReport, optional
        Its first lines become the caption.
    title : str
        Figure title.
    max_segments : int
        Passes are thinned (every k-th drawn) above this many cutting segments.
    show_rapids : bool
        Also draw rapids (dotted).
    """
    segs, colour, links, rapids = _segments(path, max_segments)
    g = np.linspace(0.0, 1.0, 24)
    fine = np.linspace(0.0, 1.0, 120)
    iso_t = surface(fine, g, grid=True)  # curves along t at fixed s
    iso_s = surface(g, fine, grid=True)  # curves along s at fixed t
    fig = plt.figure(figsize=(13, 6.5))
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    for k in range(g.size):
        ax3.plot(*iso_t[:, k].T, color="0.8", lw=0.4)
        ax3.plot(*iso_s[k].T, color="0.8", lw=0.4)
    norm = plt.Normalize(vmin=float(colour.min()) if colour.size else 0.0,
                         vmax=float(colour.max()) if colour.size else 1.0)
    if len(segs):
        ax3.add_collection3d(Line3DCollection(segs, colors=plt.cm.viridis(norm(colour)),
                                              linewidths=0.5))
    if len(links):
        ax3.add_collection3d(Line3DCollection(links, colors="0.45", linewidths=0.5))
    if show_rapids and len(rapids):
        ax3.add_collection3d(Line3DCollection(rapids, colors="tab:red", linewidths=0.4,
                                              linestyles=":"))
    pts = np.concatenate([iso_t.reshape(-1, 3), path.positions_mm[path.kinds != MoveKind.RAPID]
                          if len(path) else np.zeros((0, 3))])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    half = 0.5 * float((hi - lo).max())
    mid = 0.5 * (lo + hi)
    ax3.set_xlim(mid[0] - half, mid[0] + half)
    ax3.set_ylim(mid[1] - half, mid[1] + half)
    ax3.set_zlim(mid[2] - half, mid[2] + half)
    ax3.set_xlabel("x (mm)")
    ax3.set_ylabel("y (mm)")
    ax3.set_zlabel("z (mm)")
    ax3.set_title(title or "toolpath")
    top = fig.add_subplot(1, 2, 2)
    for k in range(g.size):
        top.plot(iso_t[:, k, 0], iso_t[:, k, 1], color="0.85", lw=0.4)
    if len(segs):
        top.add_collection(LineCollection(segs[:, :, :2], colors=plt.cm.viridis(norm(colour)),
                                          linewidths=0.5))
    if len(links):
        top.add_collection(LineCollection(links[:, :, :2], colors="0.45", linewidths=0.5))
    top.autoscale()
    top.set_aspect("equal", adjustable="datalim")
    top.set_xlabel("x (mm)")
    top.set_ylabel("y (mm)")
    top.set_title(f"seen from +z: {path.n_passes} passes (colour), links grey")
    if report is not None:
        caption = "\n".join(report.lines()[:8])
        fig.text(0.01, 0.01, caption, family="monospace", fontsize=7, va="bottom")
        fig.subplots_adjust(bottom=0.22)
    out = Path(out)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
