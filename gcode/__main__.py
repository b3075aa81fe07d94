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

from gcode.dialects import dialect_by_name, dialect_names
from gcode.errors import GCodeError
from gcode.parser import parse
from gcode.summary import summarize

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
    summary = summarize(program, rapid_rate_mm_per_min=args.rapid_rate)
    return [f"file: {path}", *summary.lines()]


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
