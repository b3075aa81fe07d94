"""Streaming throughput against the simulator at 115200 baud pacing.

Prints, for one program (mean line length shown):

* character counting: link use = line bytes written / (streaming time x 11,520 B/s), the
  share of the serial link's capacity the sender keeps busy (target >= 97 %);
* send-response on the same link, beside it;
* Modbus TCP blocks per second (credit flow control, 8 slots) and RTU over a pty;
* issue 25: the program without any synchronizing end (no M2/M30, no M5: it ends on a
  move) and with the firmware's status habits as simulator faults (no reply while the
  planner is full, half the ``?`` ignored, a 500 ms report that answers two ``?``), each
  by character counting and send-response: link use, blocks executed exactly once (the
  simulator's journal against the program), status queries left unanswered, and the wait
  from the last answer to the end report. These run the simulator in this process (its
  journal is read), so their link use is a little below the rows above.

The simulator runs in ``instant`` mode (the machine never makes the link wait), so the
link is the only limit; sender and simulator share the CPU, so a loaded machine shows as
gaps (the median of ``--repeat`` runs is printed, with the spread).
Run: ``python benchmarks/bench_stream.py [--lines N] [--serial tcp|pty] [--repeat 3]``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gcode.senders.grbl_sender import GrblSender
from gcode.senders.grbl_stream import StreamMode, Timeouts
from gcode.senders.job import Job
from gcode.senders.modbus_sender import ModbusLink, ModbusSender
from gcode.senders.serial_link import open_serial_link
from simulator import run_simulator

BAUD = 115200
LINK_BYTES_PER_S = BAUD / 10.0  # 8N1: 10 bits a byte


def program(n: int) -> str:
    """A finishing pass of short moves: about 25 characters a line, like CAM output.

    Coordinates stay inside the router's travel with any work offset (machine zero or
    the work origin), so the simulator's default offsets do.
    """
    lines = ["G21G90", "G0Z-5", "G0X-10Y-10", "M3S12000", "G1Z-6F300"]
    for i in range(1, n + 1):
        x = -10.0 - (i % 400) * 0.25
        y = -10.0 - (i // 400) * 0.5 - (i % 3) * 0.1
        lines.append(f"G1X{x:.3f}Y{y:.3f}Z{-6.0 - (i % 5) * 0.01:.3f}")
    lines += ["G0Z-5", "M5"]
    return "\n".join(lines) + "\n"


@contextmanager
def simulator_process(serial: str) -> Iterator[str]:
    """``python -m simulator`` in its own process (its own interpreter lock, like a real
    controller); yields the serial URL and stops it (by its pid) afterwards."""
    cmd = [sys.executable, "-m", "simulator", "--serial", serial, "--speed", "instant",
           "--baud", str(BAUD), "--status-interval", "0", "--duration", "600"]  # fmt: skip
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        url = None
        deadline = time.monotonic() + 20.0
        while url is None and time.monotonic() < deadline:
            line = proc.stdout.readline()
            if not line:
                break
            if line.startswith(("grbl tcp:", "grbl pty:")):
                url = line.split(":", 1)[1].strip()
        if url is None:
            raise RuntimeError("the simulator process printed no serial endpoint")
        yield url
    finally:
        proc.terminate()
        try:
            proc.wait(5.0)
        except subprocess.TimeoutExpired:
            proc.kill()


def grbl(job: Job, mode: StreamMode, serial: str, separate: bool) -> tuple[float, float, float]:
    if separate:
        ctx = simulator_process("tcp:0" if serial == "tcp" else "pty")
    else:
        ctx = run_simulator("grbl-router", serial=serial, speed="instant", baud=BAUD)
    with ctx as sim:
        url = sim if isinstance(sim, str) else sim.serial_url
        sender = GrblSender(open_serial_link(url), mode=mode)
        sender.connect()
        result = sender.run(job)
        sender.close()
    t = result.streaming_s
    return result.bytes_sent / t / LINK_BYTES_PER_S, result.blocks_done / t, t


#: Simulator fault sets of the issue-25 rows (None: no fault).
HABITS = (
    None,
    "status-when-full=ignore",
    "ignore-status=0.5",
    "status-delay=500",
)


def without_end(text: str) -> str:
    """The program without its synchronizing last line (M5): it ends on a move, no M2."""
    lines = text.splitlines()
    while lines and lines[-1].startswith(("M2", "M30", "M5")):
        lines.pop()
    return "\n".join(lines) + "\n"


def grbl_habit(job: Job, mode: StreamMode, serial: str, fault: str | None) -> dict[str, float]:
    """Stream ``job`` into an in-process simulator with ``fault``; count exactly-once blocks."""
    faults = [fault] if fault else []
    with run_simulator("grbl-router", serial=serial, speed="instant", baud=BAUD,
                       faults=faults) as sim:  # fmt: skip
        sender = GrblSender(open_serial_link(sim.serial_url), mode=mode,
                            timeouts=Timeouts(status_reply_s=0.3))  # fmt: skip
        sender.connect()
        result = sender.run(job)
        sender.close()
        journal = [e.text for e in sim.journal()]
    expected = [ln.text for ln in job.lines]
    # exactly once: the journal is the program, line for line (nothing lost, repeated
    # or reordered); otherwise the number of blocks before the first difference
    same = len(journal) == len(expected) and journal == expected
    prefix = next((k for k, (a, b) in enumerate(zip(journal, expected, strict=False)) if a != b),
                  min(len(journal), len(expected)))  # fmt: skip
    t = result.streaming_s
    return {
        "use": result.bytes_sent / t / LINK_BYTES_PER_S,
        "once": len(expected) if same else -prefix,
        "missed": result.status_missed,
        "queries": result.status_queries,
        "end_wait": result.elapsed_s - t,
        "time": result.elapsed_s,
    }


def modbus(job: Job, kind: str) -> tuple[float, float]:
    with run_simulator("grbl-router", serial=None, modbus=kind, speed="instant") as sim:
        ep = sim.endpoints
        url = f"tcp://127.0.0.1:{ep.modbus_port}" if kind == "tcp" else f"rtu:{ep.modbus_rtu_path}"
        sender = ModbusSender(ModbusLink(url))
        sender.connect()
        t0 = time.perf_counter()
        result = sender.run(job)
        t = time.perf_counter() - t0
        sender.close()
    return result.blocks_done / t, t


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=2000, help="program moves (2000)")
    ap.add_argument("--serial", choices=["tcp", "pty"], default="tcp")
    ap.add_argument("--repeat", type=int, default=3, help="runs per GRBL mode (median shown)")
    ap.add_argument(
        "--in-process",
        dest="process",
        action="store_false",
        help="run the GRBL simulator in this process (shares the interpreter lock)",
    )
    ap.add_argument(
        "--no-habits",
        dest="habits",
        action="store_false",
        help="skip the issue-25 rows (no M2, status replies dropped)",
    )
    args = ap.parse_args(argv)
    job = Job.from_text(program(args.lines), "bench.nc")
    mean = sum(ln.size for ln in job.lines) / len(job.lines)
    print(f"program: {len(job.lines)} lines, mean {mean:.1f} bytes a line with its newline")
    where = "its own process" if args.process else "this process"
    print(
        f"link: {BAUD} baud 8N1 = {LINK_BYTES_PER_S:.0f} B/s each way, simulator {args.serial}"
        f" in {where}"
    )
    ideal = LINK_BYTES_PER_S / mean
    print(f"link limit for this program: {ideal:.0f} lines/s")
    print()
    print(f"{'mode':28s} {'link use':>9s} {'lines/s':>9s} {'time s':>8s}")
    for mode in (StreamMode.CHAR_COUNT, StreamMode.SEND_RESPONSE):
        runs = sorted(grbl(job, mode, args.serial, args.process) for _ in range(args.repeat))
        use, rate, t = runs[len(runs) // 2]  # the median run
        spread = ""
        if len(runs) > 1:
            spread = f"  [{runs[0][0] * 100:.1f}..{runs[-1][0] * 100:.1f}% over {len(runs)} runs]"
        target = "  (target >= 97 %)" if mode is StreamMode.CHAR_COUNT else ""
        print(f"grbl {mode.value:23s} {use * 100:8.1f}% {rate:9.0f} {t:8.2f}{target}{spread}")
    for kind in ("tcp", "rtu"):
        rate, t = modbus(job, kind)
        print(f"modbus {kind:21s} {'':>9s} {rate:9.0f} {t:8.2f}  blocks/s")
    if args.habits:
        habits(args)
    return 0


def habits(args: argparse.Namespace) -> None:
    """The issue-25 rows: no M2, and status replies dropped (simulator fault options)."""
    job = Job.from_text(without_end(program(args.lines)), "no-m2.nc")
    print()
    print(f"no M2/M30/M5 ({len(job.lines)} blocks, last line {job.lines[-1].text!r}), "
          f"simulator {args.serial} in this process")  # fmt: skip
    print(f"{'mode':14s} {'status fault':24s} {'link use':>9s} {'exactly once':>14s} "
          f"{'? missed':>10s} {'end wait s':>10s} {'time s':>7s}")  # fmt: skip
    for mode in (StreamMode.CHAR_COUNT, StreamMode.SEND_RESPONSE):
        for fault in HABITS:
            r = grbl_habit(job, mode, args.serial, fault)
            once = f"{abs(int(r['once']))}/{len(job.lines)}" + ("" if r["once"] >= 0 else " !")
            print(f"{mode.value:14s} {fault or 'none':24s} {r['use'] * 100:8.1f}% {once:>14s} "
                  f"{int(r['missed']):>4d}/{int(r['queries']):<5d} {r['end_wait']:10.2f} "
                  f"{r['time']:7.2f}")  # fmt: skip


if __name__ == "__main__":
    sys.exit(main())
