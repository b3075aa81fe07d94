"""Throughput of the simulated controller in instant mode.

Run:  python benchmarks/bench_simulator.py [--blocks 1000000] [--stream-lines 100000]

Builds a program of ``--blocks`` 3-axis moves inside the grbl-router's travel (1% rapids,
occasional feed changes), then measures in the same run:

* the baseline: ``gcode.parse`` of the text (the bare parser, blocks/s);
* execution: ``simulator.run_program`` on a parsed program (interpreter, soft limits,
  junction speeds, 15-block look-ahead planner, trapezoid timing, journal), blocks/s,
  and its ratio to the parser baseline. Target (issue 6): >= 200,000 blocks/s;
* streaming: ``--stream-lines`` lines fed as bytes through the sans-IO GRBL protocol
  (RX buffer, line assembly, one ``ok`` per line, per-line parse and planning), lines/s.

Best of ``--repeat`` runs for each figure; wall-clock times on this machine.
"""

from __future__ import annotations

import argparse
import gc
import os
import sys
import time

import numpy as np

from gcode import GRBL, parse
from machines import load_machine
from simulator import Controller, GrblProtocol, run_program


def build_text(n: int, seed: int) -> str:
    rng = np.random.default_rng(seed)
    xyz = rng.uniform((-700.0, -500.0, -100.0), (-100.0, -100.0, -1.0), (n, 3)).round(3)
    rapid = rng.random(n) < 0.01
    feed = np.where(rng.random(n) < 0.01, 1500, 3000)
    lines = ["G21", "G90", "G94", "G1F3000"]
    prev_feed = 3000
    for (x, y, z), r, f in zip(xyz.tolist(), rapid.tolist(), feed.tolist(), strict=True):
        if r:
            lines.append(f"G0X{x:.3f}Y{y:.3f}Z{z:.3f}")
        elif f != prev_feed:
            lines.append(f"G1X{x:.3f}Y{y:.3f}Z{z:.3f}F{f}")
            prev_feed = f
        else:
            lines.append(f"G1X{x:.3f}Y{y:.3f}Z{z:.3f}")
    return "\n".join(lines) + "\n"


def best(fn, repeat: int):
    out, t_best = None, float("inf")
    for _ in range(repeat):
        gc.collect()
        t0 = time.perf_counter()
        out = fn()
        t_best = min(t_best, time.perf_counter() - t0)
    return out, t_best


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--blocks", type=int, default=1_000_000)
    ap.add_argument("--stream-lines", type=int, default=100_000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args(argv)
    machine = load_machine("grbl-router")
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}, cpus {os.cpu_count()}")
    text, t_build = best(lambda: build_text(args.blocks, args.seed), 1)
    print(f"built {args.blocks:,} blocks ({len(text) / 1e6:.1f} MB) in {t_build:.2f} s")

    program, t_parse = best(lambda: parse(text, GRBL), args.repeat)
    n = len(program)
    parse_rate = n / t_parse
    print(f"baseline gcode.parse:      {t_parse:7.2f} s  {parse_rate:12,.0f} blocks/s")

    def execute():
        c = Controller(machine)
        return c, run_program(c, program)

    (ctl, run), t_exec = best(execute, args.repeat)
    exec_rate = run.blocks / t_exec
    verdict = "meets" if exec_rate >= 200_000 else "MISSES"
    print(
        f"simulator run_program:     {t_exec:7.2f} s  {exec_rate:12,.0f} blocks/s "
        f"({exec_rate / parse_rate:.2f}x the parser; {verdict} the 200,000 blocks/s target)"
    )
    print(
        f"  {run.blocks:,} planner blocks, {run.lines:,} journaled lines, "
        f"virtual machining time {run.duration_s / 3600:.1f} h, alarm {run.alarm}"
    )
    dups = ctl.journal.duplicates()
    print(f"  journal duplicates: {len(dups)}")

    if args.stream_lines:
        head = "\n".join(text.split("\n", args.stream_lines + 4)[: args.stream_lines + 4]) + "\n"
        data = head.encode()
        chunk = 4096

        def stream():
            p = GrblProtocol(Controller(machine), instant=True)
            oks = 0
            for i in range(0, len(data), chunk):
                oks += p.feed(data[i : i + chunk]).count(b"ok")
            p.controller.run_until_idle()
            return p, oks

        (proto, oks), t_stream = best(stream, args.repeat)
        lines = proto.lines_received
        print(
            f"GRBL protocol streaming:   {t_stream:7.2f} s  {lines / t_stream:12,.0f} lines/s "
            f"({lines:,} lines, {oks:,} ok, {proto.rx_dropped_bytes} bytes dropped)"
        )
        print(
            f"  link limit at 115200 baud for these lines: "
            f"{11520 / (len(data) / lines):,.0f} lines/s"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
