"""The pipeline's last stage: stream a checked program to a controller or the simulator.

``make_streamer(target)`` returns ``stream(gcode_path, machine) -> dict`` for
:func:`streamline_cam.pipeline.run_job`:

- ``"simulate"``: start the built-in controller (:func:`simulator.run_simulator`) on a real
  pseudo-terminal, with G54 holding the machine's work origin (the post writes
  ``joint - work_origin``), stream through pyserial with character counting, and compare
  the simulator's journal with the program: every block executed exactly once, the final
  position the program's end;
- a port (``/dev/ttyUSB0``, ``socket://127.0.0.1:PORT``): stream to that controller.

Both refuse a program whose pre-flight check finds errors.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from gcode.dialects import dialect_by_name
from gcode.senders.grbl_sender import GrblSender
from gcode.senders.job import Job
from gcode.senders.journal import JobJournal
from gcode.senders.preflight import preflight
from gcode.senders.serial_link import open_serial_link
from machines import Machine

__all__ = ["make_streamer"]

Streamer = Callable[[Path, Machine], dict[str, Any]]


def _send(job: Job, machine: Machine, url: str, journal_path: Path, dialect_name: str | None
          ) -> dict[str, Any]:
    dialect = dialect_by_name(dialect_name or machine.dialect)
    sender = GrblSender(open_serial_link(url), dialect=dialect)
    try:
        sender.connect()
        with JobJournal(journal_path, job, mode="char-count", port=url) as journal:
            result = sender.run(job, journal=journal)
    finally:
        sender.close()
    return {"ok": True, "port": url, "blocks_done": result.blocks_done,
            "bytes_sent": result.bytes_sent, "streaming_s": round(result.streaming_s, 3),
            "journal": str(journal_path)}


def _in_order(ran: list[str], sent: list[str]) -> bool:
    """Whether ``ran`` is ``sent`` with some lines left out (order kept, nothing repeated)."""
    remaining = iter(sent)
    return all(any(text == candidate for candidate in remaining) for text in ran)


def make_streamer(target: str, *, speed: str = "instant", baud: int = 115200,
                  dialect: str | None = None) -> Streamer:
    """A ``stream(gcode_path, machine)`` for ``target`` (``"simulate"`` or a port).

    ``dialect`` overrides the machine's (as the program was posted); ``speed`` and ``baud``
    set the simulator's time scale and link pacing.
    """

    def stream(gcode_path: Path, machine: Machine) -> dict[str, Any]:
        job = Job.from_text(gcode_path.read_text(encoding="ascii"), gcode_path.name)
        issues = preflight(job, machine, dialect_by_name(dialect) if dialect else None)
        if issues:
            return {"ok": False, "refused": f"pre-flight: {issues[0]}"}
        journal_path = gcode_path.with_suffix(".journal")
        if target != "simulate":
            return _send(job, machine, target, journal_path, dialect)
        from simulator import run_simulator

        g54 = (*machine.work_origin, 0.0, 0.0, 0.0)
        with run_simulator(machine, serial="pty", speed=speed, baud=baud,
                           work_offsets={1: g54}) as sim:
            outcome = _send(job, machine, sim.serial_url, journal_path, dialect)
            executed = sim.journal()
            snapshot = sim.snapshot()
        sent = [line.text for line in job.lines]
        ran = [record.text for record in executed]
        seqs = [record.seq for record in executed]
        outcome.update({
            "simulator_pty": sim.endpoints.pty_path,
            "executed_blocks": len(ran),
            # every journaled block is a program line, in order, none twice (lines that make
            # no block, such as comments, are not journaled)
            "exactly_once": len(set(seqs)) == len(seqs) and _in_order(ran, sent),
            "final_position": [round(float(v), 4) for v in snapshot["position"]],
            "alarm": snapshot.get("alarm"),
            "rx_dropped_bytes": snapshot.get("rx_dropped_bytes", 0),
        })
        return outcome

    return stream
