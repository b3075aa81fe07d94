"""``toolpath gcode-info PART.nc [--machine NAME]``: blocks, bounds, length, estimated time."""

from __future__ import annotations

import argparse

from gcode.dialects import dialect_by_name, dialect_names
from machines.catalog import list_machines

from ..cli_files import read_text

__all__ = ["register"]


def register(commands: argparse._SubParsersAction) -> None:
    """Add the ``gcode-info`` sub-command."""
    p = commands.add_parser(
        "gcode-info", help="blocks, bounds, path length and estimated time of a G-code file")
    p.add_argument("program", help="G-code file")
    p.add_argument("--machine",
                   help=f"machine ({', '.join(list_machines())}): machine coordinates, "
                   "rapid and axis rates in the time estimate")
    p.add_argument("--dialect", choices=dialect_names(),
                   help="dialect to read (default: the machine's, else generic)")
    p.add_argument("--rapid-rate", type=float,
                   help="without --machine: rapid rate for the time estimate, mm/min")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Parse the file strictly and print its summary, one ``name: value`` per line."""
    from gcode.check import machine_dialect
    from gcode.parser import parse
    from gcode.summary import summarize
    from machines import load_machine

    machine = load_machine(args.machine) if args.machine else None
    name = args.dialect or (machine.dialect if machine is not None else "generic")
    dialect = dialect_by_name(name)
    if machine is not None:
        dialect = machine_dialect(machine, dialect)
    text = read_text(args.program, "a G-code program")
    summary = summarize(parse(text, dialect), machine=machine,
                        rapid_rate_mm_per_min=args.rapid_rate)
    print(f"file: {args.program}")
    if machine is not None:
        print(f"machine: {machine.name} (machine coordinates)")
    print("\n".join(summary.lines()))
    return 0
