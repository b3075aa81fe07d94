"""``toolpath verify PART.nc --surface S.json --machine NAME --cutter ball:6``: what it cuts.

Every cutter kind is verified: ``ball:D``, ``flat:D`` and ``bull:D:r``.

Parses the program strictly (the machine's dialect), replays it through the machine's
kinematics with the joints interpolated within blocks, sweeps the cutter and compares the
cut with the design surface. Prints the report (text or ``--json``) on stdout, one summary
line on stderr; exit status 1 when the deepest gouge exceeds ``--gouge-limit``, 2 on bad
input.
"""

from __future__ import annotations

import argparse
import json
import sys

from gcode.dialects import dialect_by_name, dialect_names
from gcode.errors import GCodeError
from machines.catalog import list_machines
from toolpath.planning.defaults import CUTTER_SPEC_HELP
from verification.options import (
    DEFAULT_HORIZON_MM,
    DEFAULT_STOCK_MM,
    DexelMethod,
    VerifyOptions,
)

from ..cli_files import load_surface, output_file
from ..surface_args import add_placement_arguments, placed_surface

__all__ = ["DEFAULT_GOUGE_LIMIT_MM", "register"]

DEFAULT_GOUGE_LIMIT_MM = 0.02
"""Deepest gouge accepted by the exit status, mm: twice the 0.01 mm finishing chord
tolerance ``toolpath plan`` defaults to. Chords between cutter locations cut into convex
surfaces by up to the chord tolerance by design, and the text's 1 um rounding adds about
half a micrometre; a real gouge (a shifted pass, joint interpolation, a collision) is
deeper."""


def register(commands: argparse._SubParsersAction) -> None:
    """Add the ``verify`` sub-command."""
    p = commands.add_parser(
        "verify", help="simulate the material a G-code program removes and compare it with "
        "the design surface (gouges, scallops, areas not cut)",
        description="Replay PART.nc through the machine's forward kinematics (joints "
        "interpolated within each block, as the controller does), sweep the cutter and "
        "measure the material left on the design surface: the deepest gouge and its line, "
        "the largest scallop, the deviation distribution and the areas not cut. Exit "
        "status 1 when a gouge is deeper than --gouge-limit.")
    p.add_argument("program", help="G-code file")
    p.add_argument("--surface", required=True,
                   help="design surface JSON (toolpath fit surface -o, or an analytic surface)")
    p.add_argument("--machine", required=True,
                   help=f"machine name ({', '.join(list_machines())}) or TOML path")
    p.add_argument("--cutter", required=True, help=f"cutter spec: {CUTTER_SPEC_HELP}")
    p.add_argument("--dialect", choices=dialect_names(),
                   help="controller dialect to parse with (default: the machine's)")
    p.add_argument("--stock", type=float, default=DEFAULT_STOCK_MM,
                   help=f"material on the design before the program, mm ({DEFAULT_STOCK_MM:g})")
    p.add_argument("--gouge-limit", type=float, default=DEFAULT_GOUGE_LIMIT_MM,
                   help=f"deepest gouge accepted, mm ({DEFAULT_GOUGE_LIMIT_MM:g}); deeper "
                   "exits with status 1")
    p.add_argument("--scallop", type=float,
                   help="scallop height the program was planned for, mm (sets the resolution)")
    p.add_argument("--spacing", type=float,
                   help="design sample spacing, mm (default: from --scallop, else R/20)")
    p.add_argument("--horizon", type=float, default=DEFAULT_HORIZON_MM,
                   help=f"material left beyond this counts as not cut, mm "
                   f"({DEFAULT_HORIZON_MM:g})")
    p.add_argument("--method", choices=[m.value for m in DexelMethod], default="auto",
                   help="dexels along the surface normal (auto), or along +Z (a height "
                   "map, first order on steep walls)")
    p.add_argument("--max-samples", type=int, default=VerifyOptions().max_samples,
                   help="largest design sample grid")
    p.add_argument("--no-collision", action="store_true",
                   help="skip the collision search (shank, rapids through the part)")
    add_placement_arguments(p)
    p.add_argument("--plot", help="write the deviation map as a PNG")
    p.add_argument("--json", action="store_true", help="print the report as JSON")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Verify; 0 when no gouge exceeds the limit, 1 otherwise, 2 on unreadable files."""
    from machines import load_machine
    from toolpath.planning.cutters import parse_cutter
    from verification import verify_file

    plot = output_file(args.plot, "--plot")
    machine = load_machine(args.machine)
    cutter = parse_cutter(args.cutter)
    options = VerifyOptions(
        scallop_mm=args.scallop, spacing_mm=args.spacing, stock_mm=args.stock,
        horizon_mm=min(args.horizon, args.stock), method=args.method,
        max_samples=args.max_samples, collision=not args.no_collision)
    dialect = dialect_by_name(args.dialect) if args.dialect else None
    try:
        surface = placed_surface(load_surface(args.surface), args)
        report = verify_file(args.program, surface, machine, cutter, dialect=dialect,
                             options=options)
    except OSError as exc:
        print(f"toolpath: error: {exc}", file=sys.stderr)
        return 2
    except GCodeError as exc:  # the program's own fault: say which file
        print(f"toolpath: error: {args.program}: {exc}", file=sys.stderr)
        return 2
    if plot:
        from verification.plotting import plot_deviation_map

        plot_deviation_map(report, plot, title=f"{args.program} on {machine.name}")
    if args.json:
        print(json.dumps(report.to_dict(), indent=2, allow_nan=False))
    else:
        print("\n".join(report.lines()))
    failed = report.max_gouge_mm > args.gouge_limit
    where = ("" if report.max_gouge is None
             else f" at line {report.max_gouge.line} (block {report.max_gouge.block_index})")
    verdict = "FAIL" if failed else "ok"
    print(f"{args.program}: {verdict}: deepest gouge {report.max_gouge_mm:.4f} mm{where}, "
          f"limit {args.gouge_limit:g} mm; scallop {report.max_scallop_mm:.4f} mm",
          file=sys.stderr)
    return 1 if failed else 0
