"""Plots of a job that no single package owns (matplotlib, Agg): tool-axis angles."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from machines import Machine
from toolpath import MoveKind, Toolpath

__all__ = ["plot_tool_axis_angles"]


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
