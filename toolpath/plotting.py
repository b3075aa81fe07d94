"""Headless plots of fits (matplotlib, Agg backend): the only module that imports it."""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from numpy.typing import NDArray

__all__ = ["plot_curve_fit", "plot_surface_fit"]


def plot_curve_fit(points: NDArray[np.float64], curve: Any, path: str | Path, *,
                   title: str = "") -> Path:
    """Write a PNG: the points and the fitted curve (top), the error along it (bottom).

    ``curve`` is any fitted curve with ``params`` and ``__call__``; the error at each point
    is ``|X(t_i) − X_i|`` in mm.
    """
    t = curve.params
    points = points[:t.size]  # a closed curve's repeated last point is its first
    end = 1.0 if getattr(curve, "closed", False) else t[-1]  # closed: round the seam
    fine = np.linspace(t[0], end, max(2000, 4 * t.size))
    xs = curve(fine)
    errors = np.linalg.norm(curve(t) - points, axis=1)
    fig = plt.figure(figsize=(8, 9))
    top = fig.add_subplot(2, 1, 1, projection="3d" if points.shape[1] == 3 else None)
    coords = points.T
    top.plot(*xs.T, "-", lw=1.0, label="fitted curve")
    top.scatter(*coords, s=6, c=errors, cmap="viridis", label="points (colour: error)")
    top.set_title(title or "fit")
    top.legend(loc="best")
    if points.shape[1] == 2:
        top.set_aspect("equal", adjustable="datalim")
    bottom = fig.add_subplot(2, 1, 2)
    bottom.plot(t, errors * 1000.0, "-", lw=0.8)
    bottom.set_xlabel("parameter t")
    bottom.set_ylabel("error (µm)")
    bottom.set_title(f"max {errors.max():.4g} mm, rms {np.sqrt(np.mean(errors**2)):.4g} mm")
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def plot_surface_fit(sections: NDArray[np.float64], surface: Any, path: str | Path, *,
                     title: str = "", streamlines_per_gap: int = 2) -> Path:
    """Write a PNG: sections and streamlines between them (left), the error map (right).

    The sections' points are coloured by their error; the map is over ``(t, section)``.

    ``surface`` is a fitted surface with ``t_params``, ``s_params`` and ``__call__``;
    ``sections`` the ``(m, n, 3)`` data it was fitted to (with the seam point when closed).
    """
    t, s = surface.t_params, surface.s_params
    errors = np.linalg.norm(surface(t[None, :], s[:, None]) - sections, axis=2)
    fig = plt.figure(figsize=(13, 6))
    left = fig.add_subplot(1, 2, 1, projection="3d")
    fine = np.linspace(0.0, 1.0, 400)
    between = np.concatenate([np.linspace(a, b, streamlines_per_gap + 2)[1:-1]
                              for a, b in itertools.pairwise(s)])
    for k, s_value in enumerate(between):
        line = surface(fine, s_value)
        left.plot(*line.T, "-", lw=0.6, color="tab:orange",
                  label="fitted streamlines" if k == 0 else None)
    dots = left.scatter(*sections.reshape(-1, 3).T, s=2, c=errors.ravel() * 1000.0,
                        cmap="viridis")
    fig.colorbar(dots, ax=left, shrink=0.6, label="error at the data (µm)")
    left.set_box_aspect(np.ptp(sections.reshape(-1, 3), axis=0))
    left.set_title(title or "surface fit")
    left.legend(loc="upper left")
    right = fig.add_subplot(1, 2, 2)
    image = right.pcolormesh(t, np.arange(len(s)), errors * 1000.0, cmap="viridis",
                             shading="nearest")
    fig.colorbar(image, ax=right, label="error (µm)")
    right.set_xlabel("t along the section")
    right.set_ylabel("section")
    right.set_title(f"max {errors.max():.4g} mm, rms {np.sqrt(np.mean(errors**2)):.4g} mm")
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
