"""``toolpath plan``: finishing passes on a fitted blade surface, checked on a machine.

Reads a surface JSON (``toolpath fit surface ... -o blade.json``, or an analytic surface's
``to_dict()``), optionally places it in the workpiece frame (``--rotate``, ``--translate``,
``--on-table``), plans with :func:`toolpath.planning.plan_finishing` under a progress bar
(stderr), prints the report (stdout), and writes the toolpath (``-o path.npz``) and a PNG
of the passes (``--plot``). Exit code 0 when the measured result meets the request, 1 when
it does not (the report says where), 2 on bad input (``main`` prints the one-line error).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from machines.catalog import list_machines
from toolpath.planning.defaults import CUTTER_SPEC_HELP, DEFAULT_FEED_MM_PER_MIN, GOUGE_TOL_MM

from ..cli_files import load_surface, output_file
from ..surface_args import add_placement_arguments, parse_vector, placed_surface

__all__ = ["add_gouge_arguments", "gouge_options", "load_surface", "register", "run_plan"]


def add_gouge_arguments(parser: argparse.ArgumentParser) -> None:
    """``--on-gouge``, ``--gouge-tol``, ``--on-limit``, ``--lead-radius``, ``--approach``.

    Shared by ``plan`` and ``run``: the flags planner messages name as remedies.
    """
    parser.add_argument(
        "--on-gouge", default="raise", choices=["raise", "lift", "retilt"],
        help="where the cutter would cut deeper than --gouge-tol into the surface: stop "
             "naming the place (raise), lift it clear along its axis, leaving material "
             "(lift), or try other lead/tilt angles (retilt, 5-axis) (raise)")
    parser.add_argument(
        "--gouge-tol", type=float, default=GOUGE_TOL_MM,
        help=f"deepest cut into the surface not counted as a gouge, mm ({GOUGE_TOL_MM:g}); "
             "a concave radius smaller than the cutter costing less (a fit's ripple) passes")
    parser.add_argument("--on-limit", default=None, choices=["raise", "report"],
                        help="machine travel exceeded: stop (raise) or only report (raise; "
                             "'toolpath run' first moves the part into the travel)")
    parser.add_argument("--lead-radius", type=float, default=None,
                        help="radius of the lead-in/out arcs, mm (0: none; default the "
                             "cutter radius)")
    parser.add_argument("--approach", type=float, default=2.0,
                        help="rapid down to this height above a lead-in, then plunge, mm (2)")


def gouge_options(args: argparse.Namespace) -> dict[str, Any]:
    """The planner's options set by :func:`add_gouge_arguments`.

    Unset ones are left out, so the planner's or the pipeline's defaults hold.
    """
    given = {"on_gouge": args.on_gouge, "gouge_tol_mm": args.gouge_tol,
             "on_limit": args.on_limit, "lead_radius_mm": args.lead_radius,
             "approach_mm": args.approach}
    return {name: value for name, value in given.items() if value is not None}


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``plan`` to the ``toolpath`` sub-commands."""
    p = commands.add_parser(
        "plan", help="plan finishing passes on a fitted surface",
        description="Streamline finishing passes (s = const) spaced by the scallop height, "
                    "points by the chord tolerance, checked for gouges and on the machine.")
    p.add_argument("surface", help="surface JSON (from 'toolpath fit surface -o')")
    p.add_argument("--machine", required=True,
                   help=f"machine name or TOML file (shipped: {', '.join(list_machines())})")
    p.add_argument("--cutter", default="ball:6", help=CUTTER_SPEC_HELP + " (ball:6)")
    p.add_argument("--scallop", type=float, default=0.005, help="scallop height, mm (0.005)")
    p.add_argument("--chord-tol", type=float, default=0.01, help="chord tolerance, mm (0.01)")
    p.add_argument("--axis", default="3", choices=["3", "lead-tilt"],
                   help="3: fixed tool axis; lead-tilt: 5-axis from the surface frame")
    p.add_argument("--lead", type=float, default=0.0, help="lead angle, deg (lead-tilt)")
    p.add_argument("--tilt", type=float, default=0.0, help="tilt angle, deg (lead-tilt)")
    p.add_argument("--linking", default="auto", choices=["auto", "spiral", "zigzag", "oneway"],
                   help="auto (default): spiral round closed sections under --axis "
                        "lead-tilt, zigzag otherwise")
    p.add_argument("--fixed-axis", default="0,0,1", help="tool axis for --axis 3 (0,0,1)")
    p.add_argument("--feed", type=float, default=DEFAULT_FEED_MM_PER_MIN,
                   help=f"cutting feed, mm/min ({DEFAULT_FEED_MM_PER_MIN:g})")
    p.add_argument("--clearance", type=float, default=5.0, help="clearance, mm (5)")
    p.add_argument("--extend", type=float, default=None,
                   help="extend passes past open edges, mm (default: 0 for a ball, the "
                        "core radius R - r for flat and bull-nose cutters)")
    p.add_argument("--min-cone", type=float, default=None,
                   help="keep the tool axis this far from +Z, deg (singular cone)")
    add_gouge_arguments(p)
    add_placement_arguments(p)
    p.add_argument("--no-measure", action="store_true",
                   help="skip measuring scallop and chord error on the result")
    p.add_argument("-o", "--output", help="write the toolpath (.npz)")
    p.add_argument("--plot", help="write a PNG of the passes over the surface")
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.set_defaults(handler=run_plan)


def run_plan(args: argparse.Namespace) -> int:
    """Plan, print the report, write the outputs; returns the exit code."""
    from ..background_compile import background_compile, job_kernels, say_on_stderr

    output, plot = output_file(args.output, "-o"), output_file(args.plot, "--plot")
    # a bad surface file is one error line, before anything is said of compiling
    loaded = load_surface(args.surface)
    # on a cold kernel cache, helper processes compile the job's kernels too (started
    # before the planner's modules load: the cache check loads one kernel's module)
    with background_compile(job_kernels(args.axis, ("plan",), args.cutter), say=say_on_stderr):
        from tqdm import tqdm

        from toolpath.planning.errors import PlanTravelLimitError
        from toolpath.planning.finishing import plan_finishing

        surface = placed_surface(loaded, args)
        options: dict[str, Any] = {
            "fixed_axis": parse_vector(args.fixed_axis, "--fixed-axis"),
            "feed_mm_per_min": args.feed, "clearance_mm": args.clearance,
            "extend_mm": args.extend, "min_cone_deg": args.min_cone,
            "measure": not args.no_measure} | gouge_options(args)
        with tqdm(total=100, desc="planning", unit="%", file=sys.stderr, leave=False,
                  bar_format="{desc:<22}{bar}| {percentage:3.0f}% {elapsed}") as bar:
            def progress(stage: str, fraction: float) -> None:
                bar.set_description_str(f"planning: {stage}")
                bar.update(max(0, round(100 * fraction) - bar.n))

            try:
                path, report = plan_finishing(
                    surface, args.cutter, scallop_mm=args.scallop,
                    chord_tol_mm=args.chord_tol, axis_mode=args.axis, lead_deg=args.lead,
                    tilt_deg=args.tilt, linking=args.linking, machine=args.machine,
                    progress=progress, **options)
            except PlanTravelLimitError as exc:
                advice = _tilt_advice(loaded, surface, args)
                if advice is None:
                    raise
                raise PlanTravelLimitError(exc.violations, f"{exc.where}; {advice}") from None
    if output:
        path.save(output)
    if plot:
        from toolpath.plotting_paths import plot_toolpath

        plot_toolpath(surface, path, plot, report=report,
                      title=f"{Path(args.surface).name}: {args.cutter}, {args.axis}, "
                            f"{report.linking}")
    if args.json:
        print(json.dumps(report.as_dict(), indent=2))
    else:
        print("\n".join(report.lines()))
        if args.output:
            print(f"wrote {args.output} ({len(path)} points)")
        if args.plot:
            print(f"wrote {args.plot}")
    if args.axis == "lead-tilt":
        from ..setup_advice import placement_warning

        warning = placement_warning(loaded, surface, report.max_tilt_deg,
                                    report.tilt_leaned_points, report.max_tilt_lean_deg,
                                    report.n_points)
        if warning:
            print(f"toolpath: warning: {warning}", file=sys.stderr)
    if not report.within_request:
        print("toolpath: warning: the measured result does not meet the request "
              "(see the report)", file=sys.stderr)
        return 1
    return 0


def _tilt_advice(loaded: Any, placed: Any, args: argparse.Namespace) -> str | None:
    """The upright setup's advice where a 5-axis plan left the tilt joint's travel."""
    if args.axis != "lead-tilt":
        return None
    from machines.kinematics import tilt_reach_deg
    from machines.machine import load_machine
    from toolpath.planning.options import TILT_MARGIN_DEG

    from ..setup_advice import upright_advice

    machine = load_machine(args.machine)
    if not machine.kinematics.is_five_axis:
        return None
    reach = tilt_reach_deg(machine)
    advice = None if reach >= 180.0 else upright_advice(loaded, placed, reach - TILT_MARGIN_DEG)
    return None if advice is None else advice[1]
