"""Programs for the verification tests, built with the gcode program model."""

from __future__ import annotations

import numpy as np

from gcode import Linear, Program, Rapid
from gcode.machine_frame import program_values
from machines import Machine, inverse

NAMES = "xyzabc"


def zigzag_raster(y_levels, x0: float, x1: float, *, z: float = 0.0,
                  shift: dict[int, float] | None = None, feed: float = 800.0) -> Program:
    """A 3-axis zigzag over the plane z = 0: passes along X at the given Y levels.

    ``shift`` maps a pass number to a Z offset of that pass (mm, negative = into the part);
    the links between passes run outside the part (beyond ``x0``/``x1``).
    """
    shift = shift or {}
    blocks = [Rapid(z=5.0), Rapid(x=x0, y=float(y_levels[0])), Linear(z=z, feed=300.0)]
    for k, y in enumerate(y_levels):
        zk = z + shift.get(k, 0.0)
        ends = (x0, x1) if k % 2 == 0 else (x1, x0)
        blocks.append(Linear(x=ends[0], y=float(y), z=zk, feed=feed))
        blocks.append(Linear(x=ends[1], y=float(y), z=zk, feed=feed))
    blocks.append(Rapid(z=5.0))
    return Program(tuple(blocks))


def five_axis_line(machine: Machine, cutter, n_blocks: int, *, tilt_deg=(10.0, 50.0),
                   length_mm: float = 20.0, lean: str = "x") -> Program:
    """A ball on the plane z = 0 along +X while the tool axis leans from one tilt to another.

    The contact runs along the X axis at y = 0 (the ball centre on a straight line 3 mm up),
    the axis leans in the XZ plane (``lean="x"``) or the YZ plane (``"y"``); the joints come
    from the machine's inverse kinematics at ``n_blocks + 1`` points, so each block turns
    the tilt axis by the total / n_blocks.
    """
    n = n_blocks + 1
    x = np.linspace(0.0, length_mm, n)
    th = np.radians(np.linspace(*tilt_deg, n))
    side = np.sin(th)
    axes = (np.column_stack([side, np.zeros(n), np.cos(th)]) if lean == "x"
            else np.column_stack([np.zeros(n), side, np.cos(th)]))
    contacts = np.column_stack([x, np.zeros(n), np.zeros(n)])
    normals = np.tile([0.0, 0.0, 1.0], (n, 1))
    tips = cutter.tips_from_contacts(contacts, normals, axes)
    words = program_values(machine, inverse(machine, tips, axes))

    def block(row, cls, **kw):
        return cls(**{NAMES[k]: float(round(row[k], 4)) for k in range(6)
                      if not np.isnan(row[k])}, **kw)

    above = words[0].copy()
    above[2] += 10.0
    return Program((block(above, Rapid), *(block(r, Linear, feed=500.0) for r in words)))
