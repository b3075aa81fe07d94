"""The pipeline's last stage: stream a checked program to a controller or the simulator.

``make_streamer(target)`` returns ``stream(gcode_path, machine) -> dict`` for
:func:`streamline_cam.pipeline.run_job`:

- ``"simulate"``: start the built-in controller (:func:`simulator.run_simulator`) on a real
  pseudo-terminal, with G54 holding the machine's work origin (the post writes
  ``joint - work_origin``), stream through pyserial with character counting, and compare
  the simulator's journal with the program: every block executed exactly once, the final
  position the program's end;
- ``"simulate:SPEED"`` (``simulate:x10``, ``simulate:realtime``): the same at that time
  scale (the default ``instant`` jumps each move to its end);
- a port (``/dev/ttyUSB0``, ``socket://127.0.0.1:PORT``): stream to that controller.

Both refuse a program whose pre-flight check finds errors. A :class:`StreamControl` passed as
``stream(..., control=...)`` watches the run (progress, status) and holds, resumes or
cancels it from another thread through the sender's own feed hold (``!``), cycle start
(``~``) and cancel (hold, then soft reset: position kept).
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any, Final, NamedTuple

from gcode.dialects import dialect_by_name
from gcode.senders.grbl_sender import GrblSender
from gcode.senders.job import Job
from gcode.senders.journal import JobJournal
from gcode.senders.preflight import preflight
from gcode.senders.progress import Progress
from gcode.senders.serial_link import open_serial_link
from machines import Machine

__all__ = ["GRBL_AXES", "SIMULATE", "StreamControl", "StreamSnapshot", "make_streamer"]

#: The built-in simulator's target name (``simulate`` or ``simulate:SPEED``).
SIMULATE: Final[str] = "simulate"
#: Axis letters of the positions in GRBL's status reports, in report order.
GRBL_AXES: Final[str] = "xyzabc"

Streamer = Callable[..., dict[str, Any]]


class StreamSnapshot(NamedTuple):
    """One consistent view of a :class:`StreamControl` (:meth:`StreamControl.snapshot`)."""

    revision: int
    state: str
    progress_report: Progress | None
    machine_position: tuple[float, ...] | None


class StreamControl:
    """Watch one stream and hold, resume or cancel it from other threads.

    The sender runs in its own thread and calls :meth:`progress` (``on_progress``) and,
    once a requested feed hold has stopped the machine, :meth:`decide` (``on_hold``), which
    waits for :meth:`resume` or :meth:`cancel`. ``state`` is ``queued`` (not sending yet),
    ``running``, ``held`` (stopped by a feed hold, waiting for a decision) or ``stopping``
    (a cancel is under way); the caller records how the run ended. ``revision`` counts the
    changes: it goes up after each state change and progress report, so of two snapshots
    of the stream, the one taken at the higher revision is the newer.

    Parameters
    ----------
    on_change : callable or None
        ``on_change(control)`` after each progress report and state change (from the
        sender's thread or the caller's).
    """

    def __init__(self, on_change: Callable[[StreamControl], None] | None = None) -> None:
        self._lock = threading.Lock()
        self._decided = threading.Condition(self._lock)
        self._sender: GrblSender | None = None
        self._hold_asked = False
        self._decision: str | None = None
        self.on_change = on_change
        self.state = "queued"
        self.cancelled = False
        self.progress_report: Progress | None = None
        self.machine_position: tuple[float, ...] | None = None
        self.axes = "xyz"
        """Axis letters of the reported positions, in report order (lower case)."""
        self.revision = 0
        """Changes so far, counted in the same locked step as each change (:meth:`snapshot`)."""

    def _changed(self) -> None:
        if self.on_change is not None:
            self.on_change(self)

    def snapshot(self) -> StreamSnapshot:
        """The revision, state and latest report, taken together."""
        with self._lock:
            return StreamSnapshot(self.revision, self.state, self.progress_report,
                                  self.machine_position)

    def start(self) -> None:
        """The run has begun (connecting): holds and cancels are taken from now on."""
        with self._lock:
            if self.state == "queued":
                self.state = "running"
            self.revision += 1
        self._changed()

    def attach(self, sender: GrblSender) -> None:
        """The run starts with ``sender``: a hold or cancel asked before applies now."""
        with self._lock:
            self._sender = sender
            if self.state == "queued":
                self.state = "running"
            if self._hold_asked:
                sender.request_hold()
            self.revision += 1
        self._changed()

    def progress(self, report: Progress) -> None:
        """``on_progress`` of the sender: keep the latest report."""
        sender = self._sender
        status = sender.status if sender is not None else None
        with self._lock:
            self.progress_report = report
            if status is not None and status.machine_position is not None:
                self.machine_position = tuple(status.machine_position)
            self.revision += 1
        self._changed()

    def hold(self) -> bool:
        """Ask for a feed hold; ``False`` unless the stream is running and not holding."""
        with self._lock:
            if self.state != "running" or self._hold_asked or self.cancelled:
                return False
            self._hold_asked, self._decision = True, None
            if self._sender is not None:
                self._sender.request_hold()
        return True

    def resume(self) -> bool:
        """Cycle start after a hold; ``False`` unless the stream is held."""
        with self._lock:
            if self.state != "held":
                return False
            self._decision = "resume"
            self._decided.notify_all()
        return True

    def cancel(self) -> bool:
        """Stop the run (hold, then soft reset); ``False`` once it has ended or is stopping."""
        with self._lock:
            if self.cancelled or self.state not in ("queued", "running", "held"):
                return False
            self.cancelled, self._decision = True, "cancel"
            if self.state in ("queued", "running") and not self._hold_asked:
                self._hold_asked = True
                if self._sender is not None:
                    self._sender.request_hold()
            self._decided.notify_all()
        return True

    def decide(self, report: Progress) -> str:
        """``on_hold`` of the sender: the machine stands in a feed hold; wait for a decision.

        Returns ``"resume"`` or ``"cancel"``.
        """
        with self._lock:
            self.progress_report = report
            if self._decision is None:
                self.state = "held"
            self.revision += 1
        self._changed()
        with self._lock:
            self._decided.wait_for(lambda: self._decision is not None)
            decision, self._decision, self._hold_asked = self._decision, None, False
            self.state = "running" if decision == "resume" else "stopping"
            self.revision += 1
        self._changed()
        return str(decision)

    def ended(self) -> None:
        """The run is over: later requests are refused."""
        with self._lock:
            self.state = "ended"
            self._sender = None
            self.revision += 1


def _send(job: Job, machine: Machine, url: str, journal_path: Path, dialect_name: str | None,
          control: StreamControl | None = None) -> dict[str, Any]:
    dialect = dialect_by_name(dialect_name or machine.dialect)
    sender = GrblSender(open_serial_link(url), dialect=dialect,
                        on_progress=control.progress if control is not None else None)
    try:
        sender.connect()
        with JobJournal(journal_path, job, mode="char-count", port=url) as journal:
            if control is None:
                result = sender.run(job, journal=journal)
            else:
                control.attach(sender)
                result = sender.run(job, journal=journal, on_hold=control.decide)
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
    """A ``stream(gcode_path, machine, *, control=None)`` for ``target``.

    ``target`` is ``"simulate"``, ``"simulate:SPEED"`` (overrides ``speed``) or a port.
    ``dialect`` overrides the machine's (as the program was posted); ``speed`` and ``baud``
    set the simulator's time scale and link pacing. ``control`` (a :class:`StreamControl`)
    watches, holds, resumes and cancels the run.
    """
    name, _, given_speed = target.partition(":")
    if name == SIMULATE and given_speed:
        target, speed = SIMULATE, given_speed

    def stream(gcode_path: Path, machine: Machine, *,
               control: StreamControl | None = None) -> dict[str, Any]:
        if control is not None:  # GRBL reports X Y Z A B C, the machine's axes among them
            control.axes = "".join(c for c in GRBL_AXES
                                   if c.upper() in {a.letter.upper() for a in machine.axes})
        job = Job.from_text(gcode_path.read_text(encoding="ascii"), gcode_path.name)
        issues = preflight(job, machine, dialect_by_name(dialect) if dialect else None)
        if issues:
            return {"ok": False, "refused": f"pre-flight: {issues[0]}"}
        journal_path = gcode_path.with_suffix(".journal")
        if target != "simulate":
            return _send(job, machine, target, journal_path, dialect, control)
        from simulator import run_simulator

        g54 = (*machine.work_origin, 0.0, 0.0, 0.0)
        with run_simulator(machine, serial="pty", speed=speed, baud=baud,
                           work_offsets={1: g54}) as sim:
            outcome = _send(job, machine, sim.serial_url, journal_path, dialect, control)
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
