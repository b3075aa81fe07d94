"""The ``toolpath`` command: fit curve/surface, demo, and :mod:`streamline_cam.commands`."""

from __future__ import annotations

import argparse
import importlib
import json
import pkgutil
import sys
import warnings

from gcode.errors import GCodeError
from machines.errors import MachineError
from toolpath.errors import ToolpathError
from toolpath.fit_methods import CURVE_METHODS, SURFACE_METHODS

from .cli_files import CommandLineError, describe_os_error, output_file, output_folder
from .job_process import freeze_at_exit, prepare_job_process

__all__ = ["ONE_SHOT_COMMANDS", "main"]

#: Commands whose process does one job and exits: their objects are frozen at exit, so the
#: interpreter's exit skips its collections (:func:`~.job_process.freeze_at_exit`); the
#: service, batch, sender and simulator exit as Python does.
ONE_SHOT_COMMANDS = frozenset({"fit", "plan", "post", "run", "check", "verify", "gcode-info"})


def add_closure_arguments(parser: argparse.ArgumentParser, what: str = "sections") -> None:
    """``--closed`` / ``--open`` (default: read from how the points end, toolpath.closure)."""
    closure = parser.add_mutually_exclusive_group()
    closure.add_argument("--closed", dest="closed", action="store_true", default=None,
                         help=f"the {what} are closed loops, fitted smooth across the seam "
                              "(default: read from how the points end)")
    closure.add_argument("--open", dest="closed", action="store_false",
                         help=f"the {what} are open even if the ends nearly meet")


def _parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``toolpath`` parser; given the ``command`` about to run, only what it needs."""
    parser = argparse.ArgumentParser(
        prog="toolpath", description="Streamline fitting and CNC toolpaths for blades.")
    commands = parser.add_subparsers(dest="command", required=True)
    fit = commands.add_parser("fit", help="fit measured points")
    what = fit.add_subparsers(dest="what", required=True)
    curve = what.add_parser("curve", help="fit ordered points of a curve (CSV or XYZ)")
    curve.add_argument("points", help="CSV with header x,y[,z], or whitespace columns (mm)")
    curve.add_argument("--tol", type=float, default=0.01, help="max error in mm (0.01)")
    curve.add_argument("--method", choices=CURVE_METHODS, default="streamline")
    add_closure_arguments(curve, "points")
    curve.add_argument("-o", "--output", help="write the fitted curve as JSON")
    curve.add_argument("--plot", help="write a PNG of points, curve and error")
    curve.add_argument("--json", action="store_true", help="print the report as JSON")
    surface = what.add_parser("surface", help="fit blade sections (CSV section,x,y,z)")
    surface.add_argument("points", help="CSV with header section,x,y,z (mm), sections hub to tip")
    surface.add_argument("--tol", type=float, default=0.01, help="max error in mm (0.01)")
    surface.add_argument("--method", choices=SURFACE_METHODS, default="streamline")
    add_closure_arguments(surface)
    surface.add_argument("-o", "--output", help="write the fitted surface as JSON")
    surface.add_argument("--plot", help="write a PNG of sections, streamlines and error")
    surface.add_argument("--json", action="store_true", help="print the report as JSON")
    demo = commands.add_parser(
        "demo", help="the whole job on the bundled blade, streamed into the simulator")
    demo.add_argument("--out", default="demo", help="folder for the outputs (demo/)")
    demo.add_argument("--quick", action="store_true",
                      help="coarse finishing (scallop 0.05 mm) so it runs in seconds")
    _register_command_modules(commands, command)
    return parser


def _register_command_modules(commands: argparse._SubParsersAction,
                              command: str | None = None) -> None:
    """Let every module in :mod:`streamline_cam.commands` add its sub-command.

    Given the ``command`` about to run, only the module of that name (``gcode-info``:
    ``gcode_info``), or none for a command of this module: a command imports what it uses,
    not every other command's dependencies. Otherwise (``--help``, a mistyped command)
    all of them.
    """
    from . import commands as package

    names = sorted(info.name for info in pkgutil.iter_modules(package.__path__))
    if command is not None and command in commands.choices:
        names = []
    elif command is not None and command.replace("-", "_") in names:
        names = [command.replace("-", "_")]
    for name in names:
        importlib.import_module(f"{package.__name__}.{name}").register(commands)


def _fit_curve(args: argparse.Namespace) -> int:
    from toolpath import read_points
    from toolpath.arrays import as_curve_points, as_positive_length

    from .cli_types import fit_tolerance_flag
    from .fit_report import fit_curve_by_method

    tol = as_positive_length(args.tol, name="--tol")
    output, plot = output_file(args.output, "-o"), output_file(args.plot, "--plot")
    points = as_curve_points(read_points(args.points))
    with fit_tolerance_flag("--tol"):
        curve, report = fit_curve_by_method(points, method=args.method, tol=tol,
                                            closed=args.closed)
    if output:
        output.write_text(json.dumps(curve.to_dict()), encoding="utf-8")
    if plot:
        from toolpath.plotting import plot_curve_fit

        plot_curve_fit(points, curve, plot, title=f"{args.method}: {args.points}")
    if args.json:
        print(json.dumps(report.as_dict(), indent=2))
    else:
        print("\n".join(report.lines()))
    return 0


def _fit_surface(args: argparse.Namespace) -> int:
    from toolpath import as_sections, read_sections
    from toolpath.arrays import as_positive_length

    from .cli_types import fit_tolerance_flag
    from .fit_report import fit_surface_by_method

    tol = as_positive_length(args.tol, name="--tol")
    output, plot = output_file(args.output, "-o"), output_file(args.plot, "--plot")
    sections = as_sections(read_sections(args.points), closed=args.closed)
    with fit_tolerance_flag("--tol"):
        surface, report = fit_surface_by_method(sections, method=args.method, tol=tol)
    if output:
        output.write_text(json.dumps(surface.to_dict()), encoding="utf-8")
    if plot:
        from toolpath.plotting import plot_surface_fit

        plot_surface_fit(sections.points, surface, plot,
                         title=f"{args.method}: {args.points}")
    print(json.dumps(report.as_dict(), indent=2) if args.json else "\n".join(report.lines()))
    return 0


def _show_warning(message: Warning | str, category: type[Warning], filename: str,
                  lineno: int, file=None, line: str | None = None) -> None:
    """A warning as a user reads it: ``toolpath: warning: ...`` (no source file or line)."""
    print(f"toolpath: warning: {message}", file=sys.stderr if file is None else file)


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit code (non-zero on error)."""
    with warnings.catch_warnings():  # (the caller's way of showing them, back after)
        warnings.showwarning = _show_warning
        return _main(argv)


def _main(argv: list[str] | None) -> int:
    """:func:`main` with warnings shown as the user reads them."""
    argv = sys.argv[1:] if argv is None else argv
    args = _parser(argv[0] if argv else None).parse_args(argv)
    prepare_job_process()  # memory reuse, idle threads asleep (streamline_cam.job_process)
    if args.command in ONE_SHOT_COMMANDS:
        freeze_at_exit()  # skip the exit's collections (streamline_cam.job_process)
    try:
        handler = getattr(args, "handler", None)
        if handler is not None:
            return handler(args)
        if args.command == "fit":
            return _fit_curve(args) if args.what == "curve" else _fit_surface(args)
        from .demo import run_demo

        return run_demo(output_folder(args.out, "--out"), quick=args.quick)
    except (ToolpathError, GCodeError, MachineError, CommandLineError) as exc:
        print(f"toolpath: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # a file that failed after the checks (disk full, permissions)
        print(f"toolpath: error: {describe_os_error(exc)}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
