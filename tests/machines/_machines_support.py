"""Shared helpers for the machines tests (imported by conftest and the test modules)."""

import numpy as np

from machines import Axis, AxisKind, KinematicType, Machine, Wrap, load_machine

SHIPPED = ("grbl-router", "trunnion-ac", "head-table-bc")


def _linear(letter, lo, hi):
    return Axis(letter, AxisKind.LINEAR, lo, hi, max_rate=20000.0, max_accel=2000.0)


def synthetic(kind: KinematicType, *, c_wrap=Wrap.CONTINUOUS, c_limits=None) -> Machine:
    """A machine of any kinematic type with deliberately awkward, non-zero geometry."""
    axes = [_linear("X", -900, 900), _linear("Y", -900, 900), _linear("Z", -900, 900)]
    if kind.tilt_letter:
        axes.append(
            Axis(kind.tilt_letter, AxisKind.ROTARY, -115.0, 95.0, max_rate=5400.0, max_accel=400.0)
        )
        lo, hi = c_limits if c_limits else (-np.inf, np.inf)
        axes.append(
            Axis("C", AxisKind.ROTARY, lo, hi, max_rate=10800.0, max_accel=900.0, wrap=c_wrap)
        )
    geo = {"work_origin": (12.5, -30.0, -410.0)}
    if kind in (KinematicType.TABLE_TABLE_AC, KinematicType.TABLE_TABLE_BC):
        geo.update(rotary_centre=(3.0, -7.0, -300.0), c_offset=(1.5, 2.0, -95.0))
    elif kind.tilting_head:
        geo.update(rotary_centre=(-20.0, 15.0, -500.0), head_pivot_length=165.0)
    # reverse the rotary columns to prove joint arrays follow the machine's own order
    order = axes[:3] + axes[3:][::-1]
    return Machine(
        name=f"synthetic-{kind.value}",
        kinematics=kind,
        axes=tuple(order),
        dialect="linuxcnc",
        tool_length=87.0,
        **geo,
    )


ALL_MACHINES = [*SHIPPED, *(f"synthetic:{k.value}" for k in KinematicType)]


def get_machine(name: str) -> Machine:
    if name.startswith("synthetic:"):
        return synthetic(KinematicType(name.split(":", 1)[1]))
    return load_machine(name)


def random_joints(machine: Machine, rng, n: int) -> np.ndarray:
    """Joint values uniformly within travel (continuous rotaries within +-720 deg)."""
    j = np.empty((n, machine.n_axes))
    for i, ax in enumerate(machine.axes):
        lo, hi = (ax.min, ax.max) if ax.is_limited else (-720.0, 720.0)
        j[:, i] = rng.uniform(lo, hi, n)
    return j
