"""Command line: ``python -m gcode parse FILE`` and ``python -m gcode info FILE``.

``parse`` checks a file strictly and prints one line per block (source line and block);
``info`` prints blocks, bounds, path length and the time at programmed feeds. Data goes
to stdout; an error goes to stderr as one line ``FILE:LINE: error N (NAME): message`` and
the exit status is 1 (2 for usage errors).

Examples
--------
>>> from gcode.__main__ import main
>>> main(["info", "--help"])  # doctest: +SKIP
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from gcode.dialects import dialect_by_name, dialect_names
from gcode.errors import GCodeError
from gcode.interpreter import interpret
from gcode.numbers import format_number
from gcode.parser import parse

__all__ = ["main"]


def _build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="python -m gcode", description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="command", required=True)
    for name, text in (
        ("parse", "parse FILE strictly and list its blocks"),
        ("info", "blocks, bounds, path length and time at programmed feeds"),
    ):
        p = sub.add_parser(name, help=text)
        p.add_argument("file", type=Path, help="G-code file")
        p.add_argument(
            "--dialect",
            default="generic",
            choices=dialect_names(),
            help="controller dialect to accept (default: generic)",
        )
    sub.choices["info"].add_argument(
        "--rapid-rate", type=float, default=None, help="rapid rate for the time estimate, mm/min"
    )
    return ap


def _info(path: Path, args: argparse.Namespace) -> list[str]:
    program = parse(path.read_text(encoding="utf-8"), dialect_by_name(args.dialect))
    seg = interpret(program)
    lo, hi = seg.bounds()
    length = seg.lengths()
    seconds = float(seg.durations(args.rapid_rate).sum()) + seg.dwell_s
    feed_len = float(length[seg.kind != 0].sum())
    rapid_len = float(length[seg.kind == 0].sum())

    def f(v: float, d: int = 3) -> str:
        return format_number(v, d)

    out = [
        f"file: {path}",
        f"units: {program.units.name.lower()}",
        f"blocks: {len(program)}",
        f"moves: {len(seg)} (rapid {int(np.sum(seg.kind == 0))}, feed "
        f"{int(np.sum(seg.kind == 1))}, arc {int(np.sum(seg.kind >= 2))})",
    ]
    for n, axis in enumerate("XYZABC"):
        if lo[n] != 0.0 or hi[n] != 0.0:
            unit = "deg" if axis in "ABC" else "mm"
            out.append(f"bounds {axis}: {f(lo[n])} .. {f(hi[n])} {unit}")
    out += [
        f"length feed: {f(feed_len)} mm",
        f"length rapid: {f(rapid_len)} mm",
        f"time: {f(seconds, 1)} s"
        + ("" if args.rapid_rate else " (feed moves and dwells; rapids not timed)"),
    ]
    return out


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return the exit status.

    Parameters
    ----------
    argv : list of str or None
        Arguments without the program name (``sys.argv[1:]`` when None).

    Returns
    -------
    int
        0 on success, 1 on a G-code or file error, 2 on a usage error.
    """
    ap = _build_parser()
    try:
        args = ap.parse_args(argv)
    except SystemExit as exc:  # argparse exits on --help and usage errors
        return int(exc.code or 0)
    path: Path = args.file
    try:
        if args.command == "parse":
            program = parse(path.read_text(encoding="utf-8"), dialect_by_name(args.dialect))
            lines = program.source_lines or ()
            out = [f"{line}: {block!r}" for line, block in zip(lines, program.blocks, strict=True)]
        else:
            out = _info(path, args)
    except GCodeError as err:
        print(f"{path}:{err}", file=sys.stderr)
        return 1
    except (OSError, UnicodeDecodeError) as err:
        print(f"{path}: {err}", file=sys.stderr)
        return 1
    sys.stdout.write("".join(line + "\n" for line in out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
