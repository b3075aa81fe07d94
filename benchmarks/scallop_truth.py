"""The material a program, or its toolpath unrounded, leaves at design points: brute force.

For telling a planner's scallop from a verifier's when they differ (the planner measures
its toolpath, the verifier the program as written, every joint rounded to the G-code's
grid). At a design point ``Q`` with outward normal ``n`` the machined surface stands at
the least ``l`` with ``Q + l n`` inside the cutter solid (:meth:`Cutter.signed_distance`)
at some pose. The poses: the controller's joint interpolation
(:func:`verification.replay.replay`, then the blocks near ``Q`` again to
:data:`CHORD_MM`), each step cut into pieces of at most :data:`STEP_MM` of tip travel (tip
linear, axis renormalized: a step that short is straight to well under a nanometre).
Along the normal through a cut surface the removed material is entered once within
``+-WINDOW_MM`` of the design, so ``l`` is found by bisection to :data:`BISECTIONS` steps.
Nothing of the planner's or the verifier's measurement is used: slow and exact.

The toolpath is posted as the post moves it (split for the joint interpolation to the
post's tolerance, :func:`verification.verify.program_of_toolpath`), unrounded.

Run (the dev blade, bull:8:1 in 5 axes, at the verifier's deepest cusp)::

    python benchmarks/scallop_truth.py --surface job/surface.json --machine trunnion-ac \
        --cutter bull:8:1 --program job/part.nc --toolpath job/toolpath.npz \
        --at 0.5263894 0.0297438 [--ridge 0.5 0.12 11 41]

``--ridge ALONG ACROSS NT NS``: heights on an ``NT x NS`` grid spanning ``+-ALONG`` mm
along ``t`` and ``+-ACROSS`` mm along ``s``; prints the crest (the largest over ``s``)
at each ``t``.
"""

from __future__ import annotations

import argparse

import numpy as np

from gcode.parser import parse_file
from gcode.post import DEFAULT_JOINT_TOLERANCE_MM
from machines import load_machine
from streamline_cam.cli_files import load_surface
from toolpath.joint_refine import refine_for_joint_interpolation
from toolpath.path import Toolpath
from toolpath.planning.cutters import parse_cutter
from verification.replay import replay, replay_rows
from verification.verify import program_of_toolpath

#: The replay's chord tolerance near the points, mm.
CHORD_MM = 1e-5
#: Tip travel per pose, mm (a pose spacing ``d`` leaves ridges of about ``d^2 / 8 r``).
STEP_MM = 0.004
#: The heights searched, mm either side of the design.
WINDOW_MM = 0.03
#: Bisection steps over the window (to ``2 WINDOW_MM / 2^34``, about 4e-12 mm).
BISECTIONS = 34
#: Blocks whose ends come within this of the point, plus the cutter radius, are replayed.
NEAR_MM = 3.0


def poses_near(motion, machine, centre, radius_mm):
    """Tips and axes of the cutting poses near ``centre``, finely (module docstring)."""
    near = np.linalg.norm(motion.tips_mm - centre, axis=1) < radius_mm + NEAR_MM
    seg = motion.rows.of_instance[np.flatnonzero(near)]
    rows = np.unique(np.clip(np.concatenate([seg, seg + 1]), 0, len(motion.rows.move) - 1))
    rows = rows[~motion.rapid[motion.rows.move[rows]]]
    fine, starts = replay_rows(motion, machine, rows, chord_tol_mm=CHORD_MM,
                               radius_mm=radius_mm)
    tips, axes = fine.tips_mm, fine.axes
    joined = np.ones(len(tips) - 1, dtype=bool)
    joined[starts[1:] - 1] = False  # no step from one stretch's end to the next's start
    a0, a1 = tips[:-1][joined], tips[1:][joined]
    x0, x1 = axes[:-1][joined], axes[1:][joined]
    n = np.maximum(np.ceil(np.linalg.norm(a1 - a0, axis=1) / STEP_MM), 1).astype(np.int64)
    step = np.repeat(np.arange(len(a0)), n)
    u = ((np.arange(step.size) - np.repeat(np.cumsum(n) - n, n)) / np.repeat(n, n))[:, None]
    t = np.vstack([a0[step] * (1 - u) + a1[step] * u, a1[-1:]])
    x = np.vstack([x0[step] * (1 - u) + x1[step] * u, x1[-1:]])
    return t, x / np.linalg.norm(x, axis=1)[:, None]


def height_mm(cutter, q, n, tips, axes):
    """The least ``l`` in the window with ``q + l n`` inside a pose (nan: none or all)."""
    near = np.linalg.norm(tips - q, axis=1) < cutter.radius_mm + 2.0 * WINDOW_MM + 0.1
    tips, axes = tips[near], axes[near]

    def inside(lam):
        return bool((cutter.signed_distance(q + lam * n, tips, axes) <= 0.0).any())

    lo, hi = -WINDOW_MM, WINDOW_MM
    if inside(lo) or not inside(hi):
        return float("nan")
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if inside(mid) else (mid, hi)
    return hi


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--surface", required=True)
    parser.add_argument("--machine", required=True)
    parser.add_argument("--cutter", required=True)
    parser.add_argument("--program", help="the G-code as written")
    parser.add_argument("--toolpath", help="the planner's toolpath (.npz), unrounded")
    parser.add_argument("--at", nargs=2, type=float, required=True, metavar=("T", "S"))
    parser.add_argument("--ridge", nargs=4, type=float,
                        metavar=("ALONG_MM", "ACROSS_MM", "NT", "NS"))
    args = parser.parse_args()
    surface, machine = load_surface(args.surface), load_machine(args.machine)
    cutter = parse_cutter(args.cutter)
    t0, s0 = args.at
    q, n = surface.points_and_normals(np.array([t0]), np.array([s0]))
    sources = []
    if args.program:
        sources.append(("program", parse_file(args.program)))
    if args.toolpath:
        path = refine_for_joint_interpolation(Toolpath.load(args.toolpath), machine,
                                              DEFAULT_JOINT_TOLERANCE_MM)
        sources.append(("toolpath", program_of_toolpath(path, machine)))
    for name, program in sources:
        motion = replay(program, machine, chord_tol_mm=5e-4, radius_mm=cutter.radius_mm)
        tips, axes = poses_near(motion, machine, q[0], cutter.radius_mm
                                + (2.0 * max(args.ridge[:2]) if args.ridge else 0.0))
        print(f"{name}: {height_mm(cutter, q[0], n[0], tips, axes):.7f} mm at "
              f"(t, s) = ({t0:.7f}, {s0:.7f}), {len(tips)} poses", flush=True)
        if not args.ridge:
            continue
        along, across, nt, ns = args.ridge
        parts = surface.partials_many(np.array([t0]), np.array([s0]), ((1, 0), (0, 1)))
        ts = t0 + along / np.linalg.norm(parts[1, 0]) * np.linspace(-1, 1, int(nt))
        ss = s0 + across / np.linalg.norm(parts[0, 1]) * np.linspace(-1, 1, int(ns))
        for t in ts:
            qq, nn = surface.points_and_normals(np.full(ss.size, t), ss)
            h = np.array([height_mm(cutter, qq[j], nn[j], tips, axes) for j in range(ss.size)])
            j = int(np.nanargmax(h))
            print(f"  t {t:.6f}: crest {h[j]:.7f} mm at s {ss[j]:.6f}", flush=True)


if __name__ == "__main__":
    main()
