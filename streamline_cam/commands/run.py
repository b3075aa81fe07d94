"""``toolpath run``: blade sections -> fit -> plan -> post -> check (-> stream)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from ..cli import add_closure_arguments
from ..cli_files import CommandLineError, output_folder
from ..verdict import plan_excess, verify_excess
from .plan import add_gouge_arguments, gouge_options

if TYPE_CHECKING:
    from ..pipeline import JobRequest

__all__ = ["register", "report_lines", "scallop_text"]


def add_job_arguments(parser: argparse.ArgumentParser) -> None:
    """The job parameters shared by ``run`` and ``demo``."""
    parser.add_argument("--machine", default="grbl-router",
                        help="machine name or TOML file (grbl-router, trunnion-ac, head-table-bc)")
    parser.add_argument("--cutter", default="ball:6",
                        help="ball:D, flat:D or bull:D:r (mm; D is the diameter)")
    parser.add_argument("--scallop", type=float, default=0.005, help="scallop height, mm")
    parser.add_argument("--chord-tol", type=float, default=0.01, help="chord tolerance, mm")
    parser.add_argument("--fit-tol", type=float, default=0.01, help="surface fit tolerance, mm")
    parser.add_argument("--method", choices=("streamline", "bspline"), default="streamline")
    parser.add_argument("--axis", choices=("3", "lead-tilt"), default="3")
    parser.add_argument("--lead", type=float, default=10.0, help="lead angle, deg (5-axis)")
    parser.add_argument("--tilt", type=float, default=0.0, help="tilt angle, deg (5-axis)")
    parser.add_argument("--linking", choices=("auto", "zigzag", "oneway", "spiral"),
                        default="auto",
                        help="auto (default): spiral round a closed blade under --axis "
                             "lead-tilt, zigzag otherwise")
    parser.add_argument("--extend", type=float, default=None,
                        help="extend passes past open edges, mm (default: 0 for a ball, the "
                             "core radius R - r for flat and bull-nose cutters)")
    parser.add_argument("--placement", choices=("auto", "flat", "upright", "none"),
                        default="auto", help="how the part sits on the table")
    parser.add_argument("--dialect", help="override the machine's G-code dialect")
    add_closure_arguments(parser)
    parser.add_argument("--clearance", type=float, default=5.0,
                        help="clearance above the part for rapids, mm (5)")
    add_gouge_arguments(parser)


def request_from_args(points: Path, args: argparse.Namespace) -> JobRequest:
    """A :class:`JobRequest` from the shared arguments."""
    from ..pipeline import JobRequest

    return JobRequest(
        sections_path=points, machine=args.machine, cutter=args.cutter,
        scallop_mm=args.scallop, chord_tol_mm=args.chord_tol, fit_tol_mm=args.fit_tol,
        method=args.method, axis_mode=args.axis, lead_deg=args.lead, tilt_deg=args.tilt,
        linking=args.linking, placement=args.placement, dialect=args.dialect,
        closed=args.closed,
        planning_options={"clearance_mm": args.clearance} | gouge_options(args)
        | ({} if args.extend is None else {"extend_mm": args.extend}))


def _scatter_advice(fit: dict) -> str:
    """The fit report's advice on scattered points, told with ``--fit-tol``."""
    from ..fit_report import smoothing_advice

    return smoothing_advice(fit["scatter_mm"], fit["tol_mm"], "--fit-tol")


def report_lines(report: dict) -> list[str]:
    """The final report, one figure per line."""
    fit, plan, program, check = report["fit"], report["plan"], report["program"], report["check"]
    n_t, n_s = fit["n_control_points"]
    lines = [
        f"fit        {fit['method']} surface {n_t}x{n_s} CPs, max error "
        f"{fit['max_error_mm']:.4f} mm (between sections {fit['between_sections_mm']:.4f}"
        + (f", between data {fit['between_data_mm']:.4f}"
           if fit.get("between_data_mm") is not None else "") + ")",
        *([f"fairness   {fit['fairness']['summary']}"] if fit.get("fairness") else []),
        *([f"scatter    {_scatter_advice(fit)}"] if fit.get("follows_scatter") else []),
        f"plan       {plan['n_passes']} passes, {plan['n_points']} points, scallop "
        f"{_plan_scallop(plan)} (asked {plan['scallop_request_mm']}), chord "
        f"{plan['max_chord_error_mm']:.4f} mm (asked {plan['chord_tol_mm']}), unreachable "
        f"{100 * plan['unreachable_fraction']:.1f}%",
        *_written_line(plan),
        *_attempts_line(plan),
        *_stalled_line(plan),
        f"linking    {plan['linking']}"
        + (f" ({plan['linking_reason']})" if plan.get("linking_reason") else ""),
        *_rotary_lines(plan),
        *_setup_lines(report),
        *([f"gouge      {plan['n_lifted']} point(s) lifted clear (max {plan['max_lift_mm']:.4f} "
            f"mm, material left there), {plan['n_retilted']} re-tilted"]
          if plan.get("n_lifted") or plan.get("n_retilted") else []),
        f"program    {program['lines']} lines, estimated {program['time_s'] / 60:.1f} min",
        f"check      {check['errors']} error(s), {check['warnings']} warning(s)",
    ]
    lines += [f"           {issue}" for issue in check["issues"][:5]]
    if "verify" in report:
        v = report["verify"]
        gouge = v.get("max_gouge_mm") or 0.0
        away = v.get("faces_away_area_mm2") or 0.0
        lines.append(f"verify     scallop {v.get('max_scallop_mm') or 0.0:.4f} mm as written, "
                     f"deepest gouge {gouge:.4f} mm (chord tolerance {plan['chord_tol_mm']})"
                     + (f"; {away:.0f} mm^2 faces away from the tool axis: not reached, "
                        "no scallop taken there" if away else ""))
    if "stream" in report:
        lines.append("stream     " + ", ".join(f"{k} {v}" for k, v in report["stream"].items()))
    return lines


def _attempts_line(plan: dict) -> list[str]:
    """Where the job planned more than once: what each plan measured, which was kept.

    And why a re-plan stopped (it gouged), where one did.
    """
    attempts = plan.get("attempts") or []
    stopped = [f"re-plan    {plan['replan_stopped']}"] if plan.get("replan_stopped") else []
    if len(attempts) < 2:
        return stopped
    kept = plan.get("kept_attempt", len(attempts))
    readings = "; ".join(
        f"asked {a['scallop_mm']:.4f}/{a['chord_tol_mm']:.4f}, measured "
        f"{a.get('judged_scallop_mm', a['measured_scallop_mm']) or 0.0:.4f}/"
        f"{a['measured_chord_mm'] or 0.0:.4f}" for a in attempts)
    return [f"re-plan    {len(attempts)} plans (scallop/chord mm: {readings}); plan {kept} "
            "kept, the nearest to the request", *stopped]


def scallop_text(max_mm: float | None, above_mm: float | None = None) -> str:
    """A measured scallop for the summary: ``0.0041 mm``, or above the measure's horizon.

    ``above_mm``: the horizon where the scallop stands above it (the report's JSON then
    holds no number, ``scallop_above_horizon``); None with no figure: not measured.
    """
    if above_mm is not None:
        return f"above {above_mm:g} mm (the measure's horizon)"
    return "not measured" if max_mm is None else f"{max_mm:.4f} mm"


def _plan_scallop(plan: dict) -> str:
    """The plan's largest scallop, and the one away from uncut areas where it is less.

    Beside an uncut area (faces the cutter cannot reach, the edge of the surface) a
    cusp can stand higher than the request, as the report's ``scallop_interior_mm``
    tells apart: the summary gives both where they differ.
    """
    above = plan.get("scallop_horizon_mm") if plan.get("scallop_above_horizon") else None
    largest, inner = plan.get("max_scallop_mm"), plan.get("scallop_interior_mm")
    text = scallop_text(largest, above)
    if inner is not None and (largest is None or round(inner, 4) < round(largest, 4)):
        text += f", {inner:.4f} mm away from uncut areas"
    return text


def _written_line(plan: dict) -> list[str]:
    """The plan's figures are its toolpath's; what the G-code's rounding may add to them.

    The plan measures the toolpath, the verifier the program as written (every joint
    rounded to the G-code's grid): their scallops differ by up to the rounding reserve
    (0.0016 and 0.0026 mm on the dev blade with bull:8:1 in 5 axes).
    """
    bound = plan.get("written_scallop_bound_mm")
    if bound is None or not plan.get("rounding_reserve_mm"):
        return []
    return [f"           (the toolpath's, before the G-code's rounding of up to "
            f"{plan['rounding_reserve_mm']:.4f} mm: as written, scallop at most about "
            f"{bound:.4f} mm)"]


def _stalled_line(plan: dict) -> list[str]:
    """The moves the chord check left whole, where splitting did not shrink their gap.

    Their planned gap (the report's ``stalled_gap_mm``), read at their ends too (a move whose
    ends sit on the surface is split on), counts in the chord figure; it is mostly misread
    beside an edge (a flat end's disc beyond the open tip, 2.34 mm planned
    on dev_prop_7x100 flat:6 where the verifier finds 0.05 mm), but can be real.
    """
    if not plan.get("n_stalled_moves"):
        return []
    return [f"           {plan['n_stalled_moves']} move(s) left whole: splitting did not shrink "
            f"their gap (up to {plan['stalled_gap_mm']:.4f} mm; beside an edge it may be "
            f"misread: --verify or `toolpath verify` judges what the program cuts)"]


def _rotary_lines(plan: dict) -> list[str]:
    """The rotary joints' fastest turn and C's sense, and the edge face left uncut."""
    return [f"{label} {plan[name]['text']}"
            for label, name in (("rotary    ", "rotary_rates"), ("uncut     ", "blunt_face"))
            if plan.get(name)]


def _setup_lines(report: dict) -> list[str]:
    """How the part was moved into the travel and the tool axis leaned, when they were."""
    lines = []
    shift = report.get("placement", {}).get("travel_shift_mm")
    if shift and any(shift):
        lines.append(f"setup      part moved by ({shift[0]:.3f}, {shift[1]:.3f}, "
                     f"{shift[2]:.3f}) mm to keep the path inside the travel of "
                     f"{report['machine']} (placement offset "
                     + ", ".join(f"{v:.3f}" for v in report["placement"]["offset_mm"])
                     + " mm)")
    plan = report["plan"]
    if plan.get("tilt_leaned_points"):
        lines.append(f"tool axis  {plan['tilt_leaned_points']} points leaned toward +Z by up "
                     f"to {plan['max_tilt_lean_deg']:.2f} deg to keep the tilt joint in "
                     f"travel ({plan['max_tilt_deg']:.2f} deg from +Z at most)")
    return lines


def _check_points(points: Path, closed: bool | None) -> None:
    """Read and check the blade sections as the job will (``toolpath fit surface`` too).

    Raises
    ------
    DataFileError
        The file cannot be read as ``section,x,y,z`` CSV (naming the file and line).
    InvalidPointsError
        Its sections cannot make a surface (:func:`toolpath.as_sections`: too few,
        repeated points, ...).
    """
    from toolpath import as_sections, read_sections

    as_sections(read_sections(points), closed=closed)


def _run(args: argparse.Namespace) -> int:
    from ..background_compile import background_compile, job_kernels, say_on_stderr
    from ..progress import StageBars

    out = (output_folder(Path(args.output).parent, "-o", shown=args.output) if args.output
           else output_folder("job", "the output folder"))
    if args.output and Path(args.output).is_dir():
        raise CommandLineError(f"-o {args.output}: cannot write: it is a folder")
    # a bad points file is one error line, before anything is said of compiling (the job
    # reads the file again: a few milliseconds)
    _check_points(Path(args.points), args.closed)
    bars = StageBars(disable=args.quiet)
    target = "simulate" if args.simulate else args.send
    stream = None
    if target:  # the senders (and their serial port modules) load only to stream
        from ..streaming import make_streamer

        stream = make_streamer(target, dialect=args.dialect)
    # on a cold kernel cache, helper processes compile the job's kernels too (started
    # before the pipeline's modules load: the cache check loads one kernel's module)
    stages = ("fit", "plan", "post", "check") + (("verify",) if args.verify else ())
    try:
        with background_compile(job_kernels(args.axis, stages, args.cutter),
                                say=None if args.quiet else say_on_stderr):
            from ..pipeline import run_job

            result = run_job(request_from_args(Path(args.points), args), out, progress=bars,
                             stream=stream, plots=args.plots, verify=args.verify)
    finally:
        bars.close()
    if args.output and Path(args.output) != result.files["gcode"]:
        result.files["gcode"].replace(args.output)
        result.files["gcode"] = Path(args.output)
    text = report_lines(result.report)
    print(json.dumps(result.report, indent=2) if args.json else "\n".join(text))
    print(f"files      {', '.join(str(p) for p in result.files.values())}")
    failed = result.report["check"]["errors"] or not result.report.get("stream", {"ok": 1})["ok"]
    excess = verify_excess(result.report)
    if excess:
        print(f"toolpath: verify failed: {excess}; the files are kept for inspection",
              file=sys.stderr)
    elif "verify" not in result.report and (excess := plan_excess(result.report)):
        print(f"toolpath: the plan's measurement does not meet the request: {excess}; the "
              "files are kept for inspection (--verify measures the program itself)",
              file=sys.stderr)
    return 1 if failed or excess else 0


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``toolpath run``."""
    parser = commands.add_parser(
        "run", help="sections -> fit -> plan -> post -> check in one go",
        description="Fit blade sections, plan finishing passes, post and check the G-code.")
    parser.add_argument("points", help="CSV section,x,y,z (mm), sections hub to tip")
    add_job_arguments(parser)
    parser.add_argument("-o", "--output", help="G-code file (other files go beside it)")
    target = parser.add_mutually_exclusive_group()
    target.add_argument("--send", metavar="PORT",
                        help="stream the checked program to a GRBL controller "
                             "(/dev/ttyUSB0, socket://127.0.0.1:PORT)")
    target.add_argument("--simulate", action="store_true",
                        help="stream it into the built-in simulator over a pseudo-terminal")
    parser.add_argument("--plots", action="store_true",
                        help="write fit.png, toolpath.png, tool_axis.png (5-axis), deviation.png")
    parser.add_argument("--verify", action="store_true",
                        help="replay the program and measure what it cuts; exit status 1 "
                             "when the deepest gouge exceeds --chord-tol or the scallop "
                             "--scallop")
    parser.add_argument("--json", action="store_true", help="print the report as JSON")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    parser.set_defaults(handler=_run)
