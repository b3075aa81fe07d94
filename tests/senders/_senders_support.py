"""Helpers for the sender tests: programs, simulator start-up, exactly-once checks, a proxy."""

from __future__ import annotations

import re
import select
import socket
import threading
from collections.abc import Sequence

import numpy as np

from gcode.blockparser import BlockParser
from gcode.dialects import GENERIC
from gcode.interpreter import interpret
from gcode.parser import parse
from gcode.senders.grbl_stream import Timeouts
from gcode.senders.job import Job
from machines import load_machine
from machines.machine import Machine

MACHINE = "grbl-router"
_MODAL_ONLY = re.compile(r"(G[0-3]|G9[0134]|G1[789]|G2[01]|F[\d.]+)+")
#: G54 of the simulated router: the machine's work origin (the simulator defaults to 0).
WORK_OFFSET = (-400.0, -300.0, -110.0, 0.0, 0.0, 0.0)
#: Short bounds so a failing test fails fast (the sender's own time-outs, not pytest's).
FAST_TIMEOUTS = Timeouts(status_reply_s=2.0, lost_line_s=1.0, stall_s=10.0, hold_s=5.0, reset_s=3.0)


def machine() -> Machine:
    return load_machine(MACHINE)


def zigzag_program(n_moves: int, *, step_mm: float = 0.5, feed: float = 1200.0) -> str:
    """A program whose path never passes through the same point twice (X only grows).

    Every line is unique, so the simulator's journal texts identify lines.
    """
    lines = ["G21 G90 (mm, absolute)", "G0 Z5", "G0 X0 Y0", "M3 S1000", "G1 Z-1 F300"]
    for i in range(1, n_moves + 1):
        y = 2.0 * ((i * 7) % 5) / 4.0
        lines.append(f"G1 X{i * step_mm:.3f} Y{y:.3f} F{feed:g}")
    lines += ["G0 Z5", "M5"]
    return "\n".join(lines) + "\n"


def end_position(text: str) -> np.ndarray:
    """Machine XYZ at the end of the program (work offset added)."""
    seg = interpret(parse(text))
    return seg.end[-1, :3] + np.asarray(WORK_OFFSET[:3])


def texts(entries) -> list[str]:
    return [e.text for e in entries]


def assert_exactly_once(entries, expected: Sequence[str]) -> None:
    """The simulator journal holds exactly ``expected``, in order: nothing lost, reordered
    or duplicated."""
    got = texts(entries)
    seqs = [e.seq for e in entries]
    assert len(set(seqs)) == len(seqs), "a controller sequence number was journaled twice"
    if got != list(expected):
        for k, (a, b) in enumerate(zip(got, expected, strict=False)):
            if a != b:
                raise AssertionError(f"journal differs at entry {k}: got {a!r}, expected {b!r}")
        raise AssertionError(f"journal has {len(got)} entries, expected {len(expected)}")


def journaled(lines) -> list[str]:
    """Texts of ``lines`` the simulator journals (it skips lines that make no block, e.g.
    a lone ``G1F1200``)."""
    out = []
    for ln in lines:
        if BlockParser(GENERIC).parse_line(ln.text, 1) or not _MODAL_ONLY.fullmatch(ln.text):
            out.append(ln.text)
    return out


def expected_after_resume(
    job: Job, executed: Sequence[str], resume_line: int, preamble
) -> list[str]:
    """What the journal must show after a first run that executed ``executed`` and a resume."""
    return list(executed) + journaled(preamble) + journaled(job.from_line(resume_line))


def assert_stopped_then_resumed_once(sender, sim, job: Job, err, *, good_lines: int) -> None:
    """After a line rejected past the first ``good_lines``: no later line ran, and resuming
    from the suggested line completes the job with every block executed exactly once."""
    executed = texts(sim.journal())
    later = ({ln.text for ln in job.lines[good_lines:]}
             - {ln.text for ln in job.lines[:good_lines]})
    assert not later & set(executed), "a line after the rejected one ran"
    assert err.resume_line is not None and err.resume_line <= err.line
    plan = sender.plan_resume(job, err.resume_line)
    sender.run(job, resume=plan)
    sender.close()
    assert_exactly_once(
        sim.journal(), expected_after_resume(job, executed, err.resume_line, plan.preamble))


class ModbusProxy:
    """A TCP proxy on 127.0.0.1 between a Modbus client and the simulator, for faults.

    ``swallow_responses(n)`` drops the next n server answers (the client times out);
    ``cut()`` closes the current connection (the client sees it lost).
    """

    def __init__(self, target_port: int) -> None:
        self.target = ("127.0.0.1", target_port)
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self._lock = threading.Lock()
        self._swallow = 0
        self._cut = False
        self.swallowed = 0
        self.connections = 0
        self._stop = False
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def swallow_responses(self, n: int = 1) -> None:
        with self._lock:
            self._swallow += n

    def cut(self) -> None:
        with self._lock:
            self._cut = True

    def _run(self) -> None:
        self.server.settimeout(0.05)
        while not self._stop:
            try:
                client, _ = self.server.accept()
            except OSError:
                continue
            self.connections += 1
            try:
                upstream = socket.create_connection(self.target, timeout=2.0)
            except OSError:
                client.close()
                continue
            self._pipe(client, upstream)

    def _pipe(self, client: socket.socket, upstream: socket.socket) -> None:
        try:
            while not self._stop:
                with self._lock:
                    if self._cut:
                        self._cut = False
                        return
                ready, _, _ = select.select([client, upstream], [], [], 0.02)
                for s in ready:
                    data = s.recv(65536)
                    if not data:
                        return
                    if s is client:
                        upstream.sendall(data)
                    else:
                        with self._lock:
                            drop = self._swallow > 0
                            if drop:
                                self._swallow -= 1
                                self.swallowed += 1
                        if not drop:
                            client.sendall(data)
        except OSError:
            return
        finally:
            client.close()
            upstream.close()

    def close(self) -> None:
        self._stop = True
        self._thread.join(2.0)
        self.server.close()
