"""Streaming throughput against the simulator at 115200 baud pacing.

Prints, for one program (mean line length shown):

* character counting: link use = line bytes written / (streaming time x 11,520 B/s), the
  share of the serial link's capacity the sender keeps busy (target >= 97 %);
* send-response on the same link, beside it;
* Modbus TCP blocks per second (credit flow control, 8 slots) and RTU over a pty.

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
from gcode.senders.grbl_stream import StreamMode
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
    return 0


if __name__ == "__main__":
    sys.exit(main())
