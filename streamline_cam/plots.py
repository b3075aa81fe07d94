"""Job plots no single package owns (matplotlib, Agg): tool-axis angles, passes in (t, s)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from machines import Machine
from toolpath import MoveKind, ParametricSurface, Toolpath
from toolpath.planning.local import project_to_surface

#: Coarse grid for the starting guesses of the projection, and points per distance chunk.
GUESS_GRID = 64
CHUNK = 2048

__all__ = ["plot_passes_in_parameters", "plot_tool_axis_angles"]


def plot_tool_axis_angles(path: Toolpath, machine: Machine, out: Path) -> Path:
    """Write a PNG of the tool axis along the path (5-axis jobs).

    Top: the axis's angle from +Z and its azimuth (deg) in the workpiece frame against the
    cutting length (mm); bottom: the machine's rotary joints (deg) from its kinematics.
    Only cutting moves are drawn; their length accumulates along the path.
    """
    cutting = path.kinds != MoveKind.RAPID
    steps = np.concatenate(([0.0], path.segment_lengths_mm))
    along_mm = np.cumsum(np.where(cutting, steps, 0.0))
    axes = path.tool_axes
    tilt_deg = np.degrees(np.arccos(np.clip(axes[:, 2], -1.0, 1.0)))
    azimuth_deg = np.degrees(np.unwrap(np.arctan2(axes[:, 1], axes[:, 0])))
    joints = path.to_machine(machine).joints
    rotary = [(k, axis.letter) for k, axis in enumerate(machine.axes) if axis.letter in "ABC"]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(11, 7), sharex=True)
    top.plot(along_mm[cutting], tilt_deg[cutting], ".", ms=1, label="angle from +Z")
    top.plot(along_mm[cutting], azimuth_deg[cutting], ".", ms=1, label="azimuth")
    top.set_ylabel("tool axis (deg)")
    top.legend(loc="best", markerscale=8)
    top.set_title(f"tool axis along the path: {path.n_passes} passes, {len(path)} points")
    for k, letter in rotary:
        bottom.plot(along_mm[cutting], joints[cutting, k], ".", ms=1, label=letter)
    bottom.set_xlabel("cutting length (mm)")
    bottom.set_ylabel(f"{machine.name} rotary joints (deg)")
    if rotary:
        bottom.legend(loc="best", markerscale=8)
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return Path(out)


def _nearest_grid_parameters(surface: ParametricSurface, points: np.ndarray
                             ) -> tuple[np.ndarray, np.ndarray]:
    g = np.linspace(0.0, 1.0, GUESS_GRID)
    grid = surface(g, g, grid=True).reshape(-1, 3)
    best = np.empty(len(points), dtype=int)
    for lo in range(0, len(points), CHUNK):
        d = ((points[lo:lo + CHUNK, None, :] - grid[None]) ** 2).sum(axis=2)
        best[lo:lo + CHUNK] = d.argmin(axis=1)
    return g[best // GUESS_GRID], g[best % GUESS_GRID]


def plot_passes_in_parameters(surface: ParametricSurface, path: Toolpath, cutter_radius_mm: float,
                              out: Path) -> Path:
    """Write a PNG of the cutting moves in the surface's ``(t, s)`` square (flattened view).

    Each cutter location is mapped to the surface point nearest its ball centre
    (tip + R * axis), found by Newton projection from the nearest point of a coarse grid;
    passes (``s = const`` streamlines) show as horizontal lines, gaps as uncut areas.
    """
    cutting = np.flatnonzero(path.kinds == MoveKind.CUT)
    centres = path.positions_mm[cutting] + cutter_radius_mm * path.tool_axes[cutting]
    t0, s0 = _nearest_grid_parameters(surface, centres)
    t, s, _ = project_to_surface(surface, centres, t0, s0)
    fig, ax = plt.subplots(figsize=(9, 6))
    dots = ax.scatter(t, s, c=path.pass_index[cutting], s=0.5, cmap="viridis")
    fig.colorbar(dots, ax=ax, label="pass")
    ax.set_xlim(0.0, 1.0)
    ax.set_ylim(0.0, 1.0)
    ax.set_xlabel("t (along the sections)")
    ax.set_ylabel("s (across the sections)")
    ax.set_title(f"{path.n_passes} passes in the surface's parameters; blank = not cut")
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return Path(out)
