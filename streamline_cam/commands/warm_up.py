"""``toolpath warm-up``: compile the kernels a job uses, once per install (``make install``).

Optional: a job compiles what it needs on first use; this runs two small jobs
ahead of time (:mod:`streamline_cam.warmup`) so the first real one starts warm.
"""

from __future__ import annotations

import argparse
import sys

__all__ = ["register"]


def register(commands: argparse._SubParsersAction) -> None:
    """Add the ``warm-up`` sub-command."""
    p = commands.add_parser(
        "warm-up", help="compile the planner's kernels once (make install runs it)",
        description="Run two small jobs (3-axis, verified, and 5-axis) on the bundled "
        "blades, at once in two processes, so that the kernels every job uses are compiled "
        "and cached before the first real job. Optional: without it the first job compiles "
        "them.")
    p.add_argument("--quiet", action="store_true", help="print nothing")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Warm up, printing each job as it starts and ends (stderr); returns 0."""
    from ..warmup import warm_up

    def say(text: str) -> None:
        print(text, file=sys.stderr, flush=True)

    seconds = warm_up(None if args.quiet else say)
    if not args.quiet:
        say(f"warm-up: done in {seconds:.1f} s")
    return 0
