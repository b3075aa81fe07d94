"""The ``simulate`` command: serve a simulated controller until Ctrl-C.

``toolpath simulate --machine NAME [--serial pty|tcp:PORT] [--modbus tcp:PORT|rtu:pty]
[--speed instant|realtime|xN] [--baud 115200] [--latency-ms 0] [--mode grbl|linuxcnc]
[--fault NAME=VALUE ...]`` prints its endpoints (stdout, one per line, then flushed), then a
live status line on stderr until interrupted; Ctrl-C stops it cleanly (exit 0). Also
``python -m simulator ...``.
"""

from __future__ import annotations

import argparse
import sys
import time

from simulator.faults import FAULT_NAMES

__all__ = ["add_arguments", "main", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the ``simulate`` options to ``parser``."""
    parser.add_argument("--machine", default="grbl-router", help="machine name or TOML path")
    parser.add_argument("--serial", default="pty", help="pty, tcp or tcp:PORT (0 = any); 'none'")
    parser.add_argument("--modbus", default=None, help="tcp, tcp:PORT or rtu:pty (default off)")
    parser.add_argument("--speed", default="realtime", help="instant, realtime or xN (x10)")
    parser.add_argument("--baud", type=int, default=115200, help="serial pacing, 8N1 (0 = off)")
    parser.add_argument("--latency-ms", type=float, default=0.0, help="link latency each way")
    parser.add_argument("--mode", choices=("grbl", "linuxcnc"), default=None,
                        help="protocol mode (default from the machine)")  # fmt: skip
    parser.add_argument("--fault", action="append", default=[], metavar="NAME=VALUE",
                        help=f"inject a fault: {', '.join(FAULT_NAMES)}")  # fmt: skip
    parser.add_argument("--no-reset-on-connect", action="store_true",
                        help="keep the job when a client connects (no DTR restart)")  # fmt: skip
    parser.add_argument("--status-interval", type=float, default=0.5,
                        help="seconds between status lines (0 = none)")  # fmt: skip
    parser.add_argument("--g54", choices=("work-origin", "zero"), default="work-origin",
                        help="G54 as the operator set it: the machine's work origin (what "
                             "posted programs expect, the default) or zero")
    parser.add_argument("--duration", type=float, default=None,
                        help="stop after this many seconds (default: until Ctrl-C)")  # fmt: skip


def _status_line(snap: dict[str, object]) -> str:
    pos = ",".join(f"{v:.3f}" for v in snap["position"])  # type: ignore[attr-defined]
    return (
        f"{snap['state']:<7} pos {pos} feed {snap['feed_mm_per_min']:.0f} "
        f"t {snap['virtual_time_s']:.2f}s lines {snap['lines_received']} ok {snap['ok']} "
        f"err {snap['error']} alarms {snap['alarms']} planner {snap['planner_free']} "
        f"rx {snap['rx_free']} dropped {snap['rx_dropped_bytes']}"
    )


def _work_offsets(args: argparse.Namespace) -> dict[int, tuple[float, ...]] | None:
    """G54 = the machine's work origin (A/B/C 0) unless ``--g54 zero``."""
    from machines import load_machine  # the machine model (numpy): loaded to run, not to parse

    if args.g54 == "zero":
        return None
    origin = load_machine(args.machine).work_origin
    return {1: (*(float(v) for v in origin), 0.0, 0.0, 0.0)}


def run(args: argparse.Namespace) -> int:
    """Run the simulator as ``args`` say; returns the exit code."""
    from simulator.runtime import Simulator  # the controller: loaded to run, not to parse

    serial = None if str(args.serial).lower() == "none" else args.serial
    try:
        sim = Simulator(
            args.machine,
            serial=serial,
            modbus=args.modbus,
            speed=args.speed,
            baud=args.baud,
            latency_s=args.latency_ms / 1000.0,
            mode=args.mode,
            faults=args.fault,
            reset_on_connect=not args.no_reset_on_connect,
            work_offsets=_work_offsets(args),
        )
        sim.start()
    except (ValueError, OSError, RuntimeError) as exc:
        print(f"simulate: error: {exc}", file=sys.stderr)
        return 2
    try:
        print(f"machine: {sim.machine.name} ({sim.controller.mode} mode, speed {sim.speed.name})")
        for line in sim.endpoints.lines():
            print(line)
        sys.stdout.flush()
        start = time.monotonic()
        while args.duration is None or time.monotonic() - start < args.duration:
            time.sleep(args.status_interval if args.status_interval > 0 else 0.2)
            if args.status_interval > 0 and sys.stderr.isatty():
                print("\r" + _status_line(sim.snapshot()), end="", file=sys.stderr, flush=True)
            elif args.status_interval > 0:
                print(_status_line(sim.snapshot()), file=sys.stderr, flush=True)
    except KeyboardInterrupt:
        pass
    finally:
        sim.stop()
        print("", file=sys.stderr)
        print("simulator stopped", file=sys.stderr)
    return 0


def main(argv: list[str] | None = None) -> int:
    """``python -m simulator``: same options as ``toolpath simulate``."""
    parser = argparse.ArgumentParser(prog="python -m simulator", description=__doc__.split("\n")[0])
    add_arguments(parser)
    return run(parser.parse_args(argv))
