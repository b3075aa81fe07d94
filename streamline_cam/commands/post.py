"""``toolpath post PATH.npz --machine NAME [--dialect D] -o PART.nc``: toolpath -> G-code."""

from __future__ import annotations

import argparse
import sys

from gcode.dialects import dialect_by_name, dialect_names
from gcode.post_defaults import DEFAULT_ARC_TOLERANCE_MM, DEFAULT_CLEARANCE_MM
from gcode.program import CoolantMode, Units
from machines.catalog import list_machines

from ..cli_files import output_file

__all__ = ["register"]

_COOLANT = {"flood": CoolantMode.FLOOD, "mist": CoolantMode.MIST, "off": None}


def register(commands: argparse._SubParsersAction) -> None:
    """Add the ``post`` sub-command."""
    p = commands.add_parser(
        "post", help="turn a toolpath (.npz) into G-code for a machine",
        description="Post a toolpath: joints through the machine's kinematics, G93 for "
        "5-axis moves, arcs for planar passes, safe start and end.")
    p.add_argument("toolpath", help="toolpath file written by Toolpath.save (.npz)")
    p.add_argument("--machine", required=True,
                   help=f"machine name ({', '.join(list_machines())}) or TOML path")
    p.add_argument("--dialect", choices=dialect_names(),
                   help="controller dialect (default: the machine's)")
    p.add_argument("-o", "--output", help="G-code file to write (default: stdout)")
    p.add_argument("--inch", action="store_true", help="write G20 inch text (default G21 mm)")
    p.add_argument("--tool", type=int, help="tool number to load (T<n> M6)")
    p.add_argument("--rpm", type=float, default=12000.0, help="spindle speed, rev/min (12000)")
    p.add_argument("--coolant", choices=sorted(_COOLANT), default="flood",
                   help="coolant at the start (flood)")
    p.add_argument("--clearance", type=float, default=DEFAULT_CLEARANCE_MM,
                   help=f"clearance above the path, mm ({DEFAULT_CLEARANCE_MM:g})")
    p.add_argument("--arc-tol", type=float, default=DEFAULT_ARC_TOLERANCE_MM,
                   help=f"arc fitting tolerance, mm ({DEFAULT_ARC_TOLERANCE_MM:g})")
    p.add_argument("--no-arcs", action="store_true", help="write lines only (no G2/G3)")
    p.add_argument("--no-inverse-time", action="store_true",
                   help="write 5-axis moves in G94 with equivalent feeds instead of G93")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Post the toolpath; print a one-line summary to stderr when writing a file."""
    from gcode.emitter import emit
    from gcode.post import PostOptions, post
    from gcode.writer import TextWriter
    from machines import load_machine
    from toolpath import Toolpath

    output = output_file(args.output, "-o")
    machine = load_machine(args.machine)
    dialect = dialect_by_name(args.dialect) if args.dialect else None
    try:
        options = PostOptions(
            units=Units.INCH if args.inch else Units.MM, tool=args.tool,
            spindle_rpm=args.rpm, coolant=_COOLANT[args.coolant],
            clearance_mm=args.clearance, arcs=not args.no_arcs,
            arc_tolerance_mm=args.arc_tol, inverse_time=not args.no_inverse_time)
    except ValueError as exc:
        print(f"toolpath: error: {exc}", file=sys.stderr)
        return 2
    program = post(Toolpath.load(args.toolpath), machine, dialect, options=options)
    with TextWriter(output or sys.stdout) as writer:
        n = emit(program, dialect or dialect_by_name(machine.dialect), writer)
    if output:
        print(f"{args.output}: {n} lines for {machine.name}", file=sys.stderr)
    return 0
