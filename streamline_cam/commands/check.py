"""``toolpath check PART.nc --machine NAME``: pre-flight report, one line per issue."""

from __future__ import annotations

import argparse
import sys

from gcode.dialects import dialect_by_name, dialect_names
from machines.catalog import list_machines

__all__ = ["register"]


def register(commands: argparse._SubParsersAction) -> None:
    """Add the ``check`` sub-command."""
    p = commands.add_parser(
        "check", help="check a G-code file against a machine (limits, words, feeds)",
        description="Report every issue with its line: soft limits, unsupported words, "
        "long lines, missing feed (errors), feeds above axis rates (warnings). Exit status "
        "1 when there is an error.")
    p.add_argument("program", help="G-code file")
    p.add_argument("--machine", required=True,
                   help=f"machine name ({', '.join(list_machines())}) or TOML path")
    p.add_argument("--dialect", choices=dialect_names(),
                   help="controller dialect (default: the machine's)")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Print ``FILE:LINE: severity code: message`` per issue; 1 on errors, else 0."""
    from gcode.check import Severity, check_program
    from machines import load_machine

    machine = load_machine(args.machine)
    dialect = dialect_by_name(args.dialect) if args.dialect else None
    try:
        issues = check_program(args.program, machine, dialect)
    except OSError as exc:
        print(f"toolpath: error: {exc}", file=sys.stderr)
        return 2
    for issue in issues:
        line = "" if issue.line is None else f"{issue.line}:"
        print(f"{args.program}:{line} {issue.severity.value} {issue.code.value}: {issue.message}")
    errors = sum(issue.severity is Severity.ERROR for issue in issues)
    warnings = len(issues) - errors
    print(f"{args.program}: {errors} error(s), {warnings} warning(s) for {machine.name}",
          file=sys.stderr)
    return 1 if errors else 0
