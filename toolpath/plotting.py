"""Headless plots of fits (matplotlib, Agg backend): the only module that imports it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from numpy.typing import NDArray

__all__ = ["plot_curve_fit"]


def plot_curve_fit(points: NDArray[np.float64], curve: Any, path: str | Path, *,
                   title: str = "") -> Path:
    """Write a PNG: the points and the fitted curve (top), the error along it (bottom).

    ``curve`` is any fitted curve with ``params`` and ``__call__``; the error at each point
    is ``|X(t_i) − X_i|`` in mm.
    """
    t = curve.params
    fine = np.linspace(t[0], t[-1], max(2000, 4 * t.size))
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
