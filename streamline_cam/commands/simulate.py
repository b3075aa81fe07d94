"""``toolpath simulate``: serve a simulated GRBL / Modbus controller (see :mod:`simulator.cli`)."""

from __future__ import annotations

import argparse

from simulator.cli import add_arguments
from simulator.cli import run as _run

__all__ = ["register", "run"]


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``simulate`` to the ``toolpath`` sub-commands."""
    parser = commands.add_parser(
        "simulate",
        help="run a simulated controller on a pty / TCP port (GRBL) and Modbus",
        description="Serve a simulated CNC controller; prints its endpoints, Ctrl-C stops it.",
    )
    add_arguments(parser)
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Run the simulator; returns the exit code."""
    return _run(args)
