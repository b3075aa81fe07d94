"""``toolpath send PART.nc --port URL | --modbus URL``: stream a program to a controller.

Pre-flight first (nothing is sent if the program leaves the machine's travel or uses
words its controller lacks), then the handshake, an optional ``$C`` dry run, an optional
resume (``--resume-from N`` or ``--resume-from journal``: the user asks, never the
sender), and the job with a progress bar. Ctrl-C is a feed hold and a prompt (resume or
cancel), not a dead process. Exit status: 0 done, 1 refused or stopped (error, alarm,
lost link...), 2 bad arguments or files, 130 cancelled.
"""

from __future__ import annotations

import argparse
import signal
import sys
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from gcode.senders.stream_options import DEFAULT_BAUD, StreamMode
from machines.catalog import list_machines

from ..cli_files import output_file

if TYPE_CHECKING:  # the senders (and pyserial) load when the command runs, not to parse
    from gcode.senders.grbl_sender import HoldChoice
    from gcode.senders.job import Job
    from gcode.senders.journal import JobJournal
    from gcode.senders.progress import Progress, ProgressBar
    from gcode.senders.resume import ResumePlan

__all__ = ["register", "run"]

EXIT_DONE, EXIT_STOPPED, EXIT_USAGE, EXIT_CANCELLED = 0, 1, 2, 130


def register(commands: argparse._SubParsersAction) -> None:
    """Add the ``send`` sub-command."""
    p = commands.add_parser(
        "send",
        help="stream a G-code file to a GRBL (serial) or Modbus controller",
        description="Pre-flight the program against the machine, then stream it with "
        "character counting (or send-response), journal every line, show progress. Ctrl-C "
        "holds the feed and asks whether to resume or cancel.",
    )
    p.add_argument("program", help="G-code file")
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--port", help="serial device, socket://HOST:PORT or a pty path (GRBL)")
    where.add_argument("--modbus", help="tcp://HOST:PORT or rtu:/dev/PATH[?baud=N]")
    p.add_argument("--baud", type=int, default=DEFAULT_BAUD, help="baud rate (115200)")
    p.add_argument(
        "--mode",
        choices=[m.value for m in StreamMode],
        default="char-count",
        help="pacing: char-count (default) or send-response",
    )
    p.add_argument(
        "--check",
        action="store_true",
        help="dry run in the controller's check mode first; refuse on any error",
    )
    p.add_argument(
        "--resume-from",
        metavar="N|journal",
        help="resume at source line N, or where --journal's last run stopped",
    )
    p.add_argument("--journal", help="journal file: every line sent and answered (appended)")
    p.add_argument(
        "--machine",
        default="grbl-router",
        help=f"machine for the pre-flight ({', '.join(list_machines())} or TOML)",
    )
    p.add_argument(
        "--clearance-z",
        type=float,
        metavar="MM",
        help="retract height for a resume, work Z in mm (default: program's top)",
    )
    p.add_argument(
        "--unlock",
        action="store_true",
        help="unlock ($X / CLEAR) a controller that comes up in alarm",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(handler=run)


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def _prompt(progress: Progress) -> HoldChoice:
    """Ask resume or cancel on the terminal (EOF or a second Ctrl-C cancels)."""
    from gcode.senders.grbl_sender import HoldChoice
    from gcode.senders.progress import format_progress

    _say(f"\nfeed hold: {format_progress(progress)}")
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        while True:
            sys.stderr.write("machine held. [r]esume or [c]ancel? ")
            sys.stderr.flush()
            answer = sys.stdin.readline()
            if not answer:
                return HoldChoice.CANCEL
            a = answer.strip().lower()
            if a in ("r", "resume"):
                return HoldChoice.RESUME
            if a in ("c", "cancel"):
                return HoldChoice.CANCEL
    except KeyboardInterrupt:
        return HoldChoice.CANCEL
    finally:
        signal.signal(signal.SIGINT, previous)


def _resume_hint(args: argparse.Namespace, line: int | None) -> str:
    if not line:
        return ""
    where = f"--port {args.port}" if args.port else f"--modbus {args.modbus}"
    journal = f" --journal {args.journal}" if args.journal else ""
    return f"to resume: toolpath send {args.program} {where} --resume-from {line}{journal}"


def run(args: argparse.Namespace) -> int:
    """Run ``toolpath send``; returns the exit status."""
    from gcode.dialects import dialect_by_name
    from gcode.senders.errors import JobCancelledError, PreflightError, SenderError
    from gcode.senders.job import Job
    from gcode.senders.preflight import preflight
    from gcode.senders.progress import ProgressBar
    from gcode.senders.serial_link import port_problem
    from machines import load_machine

    output_file(args.journal, "--journal")  # before the port opens
    if args.port is not None:
        problem = port_problem(args.port)
        if problem is not None:
            _say(f"toolpath: error: --port {args.port!r}: {problem}")
            return EXIT_USAGE
    try:
        job = Job.from_file(args.program)
    except OSError as exc:
        _say(f"toolpath: error: {exc}")
        return EXIT_USAGE
    machine = load_machine(args.machine)
    dialect = dialect_by_name(machine.dialect)
    try:
        for warning in preflight(job, machine, dialect):
            _say(f"{args.program}:{warning.line or ''} {warning}")
    except PreflightError as err:
        for issue in err.issues:
            _say(f"{args.program}:{getattr(issue, 'line', '') or ''}: {issue}")
        _say(f"toolpath: error: {err}")
        return EXIT_STOPPED
    if args.resume_from == "journal" and not args.journal:
        _say("toolpath: error: --resume-from journal needs --journal FILE")
        return EXIT_USAGE
    if args.resume_from not in (None, "journal"):
        try:
            int(args.resume_from)
        except ValueError:
            _say(
                f"toolpath: error: --resume-from takes a line number or 'journal', "
                f"got {args.resume_from!r}"
            )
            return EXIT_USAGE
    bar = None if args.no_progress else ProgressBar()
    try:
        if args.modbus:
            return _run_modbus(args, job, dialect, bar)
        return _run_grbl(args, job, dialect, bar)
    except KeyboardInterrupt:
        if bar is not None:
            bar.close()
        _say("toolpath: interrupted before the job started; nothing was streamed")
        return EXIT_CANCELLED
    except JobCancelledError as err:
        if bar is not None:
            bar.close()
        _say(f"toolpath: {err}")
        hint = _resume_hint(args, err.resume_line)
        if hint:
            _say(hint)
        return EXIT_CANCELLED
    except SenderError as err:
        if bar is not None:
            bar.close()
        _say(f"toolpath: error: {err}")
        hint = _resume_hint(args, err.resume_line)
        if hint:
            _say(hint)
        return EXIT_STOPPED


def _journal(args: argparse.Namespace, job: Job, mode: str, start: int | None) -> JobJournal | None:
    from gcode.senders.journal import JobJournal

    if not args.journal:
        return None
    return JobJournal(
        Path(args.journal), job, mode=mode, port=args.port or args.modbus, start_line=start
    )


def _with_sigint(request_hold: Callable[[], None], fn: Callable[[], int]) -> int:
    previous = signal.signal(signal.SIGINT, lambda *_: request_hold())
    try:
        return fn()
    finally:
        signal.signal(signal.SIGINT, previous)


def _run_grbl(args: argparse.Namespace, job: Job, dialect, bar: ProgressBar | None) -> int:
    from gcode.senders.grbl_sender import GrblSender
    from gcode.senders.journal import read_journal
    from gcode.senders.serial_link import open_serial_link

    link = open_serial_link(args.port, baud=args.baud)
    sender = GrblSender(link, mode=args.mode, dialect=dialect, on_progress=bar, on_message=_say)
    try:
        info = sender.connect(unlock=args.unlock)
        _say(
            f"connected: Grbl {info.version} on {args.port} ({info.rx_buffer_bytes}-byte "
            f"buffer, {args.mode})"
        )
        if args.check and not _dry_run(sender, job, args):
            return EXIT_STOPPED
        plan: ResumePlan | None = None
        if args.resume_from:
            if args.resume_from == "journal":
                line = sender.resume_line_from_journal(job, read_journal(args.journal))
            else:
                line = int(args.resume_from)
            plan = sender.plan_resume(job, line, clearance_z_mm=args.clearance_z)
            _report_plan(plan)
        return _stream(sender, job, args, args.mode, plan, bar)
    finally:
        sender.close()


def _dry_run(sender, job: Job, args: argparse.Namespace) -> bool:
    """The controller's check mode over the whole job; False (reported) on any rejection."""
    report = sender.check(job)
    for err in report.errors:
        _say(f"{args.program}:{err.line}: {err}")
    if not report.ok:
        _say(f"toolpath: error: check mode rejected {len(report.errors)} line(s); "
             "nothing was run")
        return False
    _say(f"check mode: {report.lines} lines accepted")
    return True


def _stream(sender, job: Job, args: argparse.Namespace, mode: str, plan: ResumePlan | None,
            bar: ProgressBar | None) -> int:
    """Run the job under a journal, Ctrl-C meaning feed hold and a prompt."""
    journal = _journal(args, job, mode, plan.line if plan else None)
    try:
        return _with_sigint(
            sender.request_hold,
            lambda: _finish(sender.run(job, resume=plan, journal=journal, on_hold=_prompt), bar),
        )
    finally:
        if journal is not None:
            journal.close()


def _report_plan(plan: ResumePlan) -> None:
    _say(
        f"resuming at line {plan.line}: retract to Z{plan.clearance_z_mm:g}, move over, "
        f"plunge, then: {' '.join(ln.text for ln in plan.preamble)}"
    )
    for note in plan.notes:
        _say(f"note: {note}")


def _finish(result, bar: ProgressBar | None) -> int:
    if bar is not None:
        bar.close()
    rate = result.blocks_done / result.elapsed_s if result.elapsed_s > 0 else 0.0
    status = result.final_status
    where = ""
    if status is not None:
        for label, pos in (("MPos", status.machine_position), ("WPos", status.work_position)):
            if pos is not None:
                where += f" {label} " + ",".join(f"{v:.3f}" for v in pos)
        where = f", {status.state}{where}"
    last = getattr(result, "last_line", 0)
    stopped = f"; stopped after line {last}{where}" if last else where
    _say(
        f"done: {result.blocks_done} blocks in {result.elapsed_s:.1f} s ({rate:.0f} blocks/s)"
        f"{stopped}"
    )
    missed = getattr(result, "status_missed", 0)
    if missed:
        _say(
            f"note: {missed} of {result.status_queries} status queries went unanswered "
            "(grbl does not promise a report; progress came from the acknowledgements)"
        )
    return EXIT_DONE


def _run_modbus(args: argparse.Namespace, job: Job, dialect, bar: ProgressBar | None) -> int:
    from gcode.senders.journal import read_journal
    from gcode.senders.modbus_sender import ModbusLink, ModbusSender
    from gcode.senders.resume import plan_resume

    try:
        link = ModbusLink(args.modbus)
    except ValueError as exc:
        _say(f"toolpath: error: {exc}")
        return EXIT_USAGE
    sender = ModbusSender(link, send_response=args.mode == "send-response", on_progress=bar)
    try:
        info = sender.connect(unlock=args.unlock)
        _say(
            f"connected: Modbus register map {info.version} on {args.modbus} "
            f"({info.slot_count} slots)"
        )
        if args.check and not _dry_run(sender, job, args):
            return EXIT_STOPPED
        plan: ResumePlan | None = None
        if args.resume_from:
            if args.resume_from == "journal":
                info_j = read_journal(args.journal)
                line = info_j.resume_line or (
                    job.lines[job.index_of((info_j.last_acked or 0) + 1)].number
                )
            else:
                line = int(args.resume_from)
            plan = plan_resume(job, line, dialect=dialect, clearance_z_mm=args.clearance_z)
            _report_plan(plan)
        return _stream(sender, job, args, "modbus", plan, bar)
    finally:
        sender.close()
