"""``toolpath warm-up``: compile the kernels a job uses, once per install (``make install``).

Optional: a job compiles what it needs on first use; this compiles the kernels jobs call
ahead of time, without a job (:mod:`streamline_cam.warmup`), so the first real one starts
warm.
"""

from __future__ import annotations

import argparse
import sys

__all__ = ["register"]


def register(commands: argparse._SubParsersAction) -> None:
    """Add the ``warm-up`` sub-command."""
    p = commands.add_parser(
        "warm-up", help="compile the planner's kernels once (make install runs it)",
        description="Byte-compile the modules and compile the kernels that jobs call "
        "(3- and 5-axis, fit to verify, for the argument types recorded from real jobs) and "
        "cache them before the first "
        "real job, in one process per core, a line per stage on stderr. Optional: without "
        "it the first job compiles them; a kernel that fails to compile is reported and "
        "left to the job.")
    p.add_argument("--quiet", action="store_true", help="print nothing")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Warm up, printing the progress (stderr); returns 0."""
    from ..warmup import compile_modules, warm_up

    def say(text: str) -> None:
        print(text, file=sys.stderr, flush=True)

    missed = compile_modules()
    if missed and not args.quiet:
        say(f"warm-up: the bytecode of {', '.join(missed)} could not all be written "
            "(a read-only folder?): their modules compile at each start")
    seconds = warm_up(None if args.quiet else say)
    if not args.quiet:
        say(f"warm-up: done in {seconds:.1f} s")
    return 0
