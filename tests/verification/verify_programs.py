"""Programs for the verification tests, built with the gcode program model."""

from __future__ import annotations

import math

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

    above = words[0].copy()
    above[2] += 10.0
    return Program((_block(above, Rapid), *(_block(r, Linear, feed=500.0) for r in words)))


def _block(row, cls, **kw):
    """A block of the joint words ``row`` (NaN: word left out), rounded to 0.1 um."""
    return cls(**{NAMES[i]: float(round(row[i], 4)) for i in range(6)
                  if not np.isnan(row[i])}, **kw)


def _lifted_pass(machine: Machine, tips, axes) -> list:
    """One pass at feed 800 through the poses ``tips``/``axes``, entered and left 5 mm up
    the axis by rapids; joints from the machine's inverse kinematics."""
    words = program_values(machine, inverse(machine, tips, axes))
    lifted = program_values(machine, inverse(machine, tips[[0, -1]] + 5.0 * axes[[0, -1]],
                                             axes[[0, -1]]))
    return [_block(lifted[0], Rapid), *(_block(r, Linear, feed=800.0) for r in words),
            _block(lifted[1], Rapid)]


def five_axis_cap(machine: Machine, cutter, sphere_radius_mm: float, *,
                  colatitudes_deg, longitude_deg=(-25.0, 25.0), points: int = 120,
                  lead_deg: float = 10.0, inside: bool = False) -> Program:
    """5-axis zigzag passes along parallels of a sphere about the origin, axis leading.

    Each pass runs along the longitudes at one colatitude (short blocks on a curve: the
    ball-centre chords merge within the tolerance and no further); the axis is the
    sphere's normal (inward for a bowl, ``inside``) leaned ``lead_deg`` along the pass.
    Joints from the machine's inverse kinematics; links lift 5 mm along the normal.
    """
    lon = np.radians(np.linspace(*longitude_deg, points))
    blocks: list = []
    for k, colat_deg in enumerate(colatitudes_deg):
        th = math.radians(colat_deg)
        phi = lon if k % 2 == 0 else lon[::-1]
        radial = np.column_stack([np.sin(th) * np.cos(phi), np.sin(th) * np.sin(phi),
                                  np.full(points, math.cos(th))])
        normals = -radial if inside else radial
        along = np.column_stack([-np.sin(phi), np.cos(phi), np.zeros(points)])
        if k % 2:
            along = -along
        lead = math.radians(lead_deg)
        axes = math.cos(lead) * normals + math.sin(lead) * along
        tips = cutter.tips_from_contacts(sphere_radius_mm * radial, normals, axes)
        blocks += _lifted_pass(machine, tips, axes)
    return Program(tuple(blocks))


DOME_MM = 1.5
BALL_MM = 3.0
LEVEL_MM, DEPTH_MM = 0.02, 0.02


def convex_dome_model():
    """A ball on 5-axis passes over a small convex dome; its coarse searches and fine model.

    Returns the dome (a :class:`~toolpath.planning.analytic.SpherePatch` of radius
    ``DOME_MM``), the whole-program searches (one level ``LEVEL_MM``, depth ``DEPTH_MM``)
    and the :class:`~verification.fine_model.FineModel` over them.
    """
    from machines import load_machine
    from toolpath.planning.analytic import SpherePatch
    from toolpath.planning.cutters import parse_cutter
    from verification.dexels import SweepIndex
    from verification.fine_model import FineModel
    from verification.options import DexelMethod
    from verification.pieces import ball_pieces
    from verification.replay import replay
    from verification.search import Dexels

    machine = load_machine("trunnion-ac")
    ball = parse_cutter("ball:6")
    step_deg = math.degrees(0.1 / DOME_MM)
    program = five_axis_cap(machine, ball, DOME_MM, longitude_deg=(-60.0, 60.0),
                            colatitudes_deg=np.arange(20.0, 80.0, step_deg), points=60)
    motion = replay(program, machine, chord_tol_mm=5e-4, radius_mm=BALL_MM)
    coarse = ball_pieces(motion, BALL_MM, 0.5, merge_tol_mm=1e-3)
    index = SweepIndex(coarse, coarse.taken(np.zeros(coarse.size, dtype=bool)), BALL_MM,
                       np.full(3, -DOME_MM), np.full(3, DOME_MM), base_cell_mm=0.25,
                       reach_limit_mm=BALL_MM + LEVEL_MM + DEPTH_MM)
    ev = Dexels(index, BALL_MM, (LEVEL_MM,), DEPTH_MM, DexelMethod.NORMAL)
    fine = FineModel(motion, machine, ev, lambda stretch: ball_pieces(stretch, BALL_MM, 0.5),
                     model_tol_mm=1.5e-3, chord_tol_mm=1e-5)
    dome = SpherePatch(radius_mm=DOME_MM, longitude_deg=(-40.0, 40.0),
                       colatitude_deg=(30.0, 70.0))
    return dome, ev, fine


def tilted_raster(machine: Machine, cutter, y_levels, x0: float, x1: float, *,
                  blocks_per_pass: int, tilt_deg: float = 15.0, depth_mm: float = 0.05
                  ) -> Program:
    """5-axis zigzag passes along X over the plane z = 0, ``depth_mm`` into it, axis leaned.

    Each pass runs at one Y level in ``blocks_per_pass`` equal blocks with the tool axis
    leaned ``tilt_deg`` in the YZ plane (the same axis throughout: every block of a pass
    cuts the plane as deep as the others, a tie-heavy program); joints from the machine's
    inverse kinematics, links lifted 5 mm.
    """
    th = math.radians(tilt_deg)
    axis = np.array([0.0, math.sin(th), math.cos(th)])
    blocks: list = []
    for k, y in enumerate(y_levels):
        x = np.linspace(x0, x1, blocks_per_pass + 1)
        if k % 2:
            x = x[::-1]
        n = x.shape[0]
        contacts = np.column_stack([x, np.full(n, float(y)), np.full(n, -depth_mm)])
        axes = np.tile(axis, (n, 1))
        tips = cutter.tips_from_contacts(contacts, np.tile([0.0, 0.0, 1.0], (n, 1)), axes)
        blocks += _lifted_pass(machine, tips, axes)
    return Program(tuple(blocks))
