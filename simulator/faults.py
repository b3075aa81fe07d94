"""Fault injection: what can go wrong on a real link or controller, on purpose.

A fault is written ``name=value`` (command line ``--fault``, API ``faults=[...]``):

``drop-after-bytes=N``
    Cut the serial link after N bytes received from the host (TCP: the connection is
    closed; pty: the device disappears and a new one is published).
``drop-after-lines=N``
    Cut the serial link once N lines have been received.
``error-at-line=K[:CODE]``
    Answer ``error:CODE`` (default 20) to line K instead of executing it (GRBL: the K-th
    line received; Modbus: block SEQ K, reported in ERROR_CODE/ERROR_SEQ).
``alarm-at-line=K[:CODE]``
    Raise ``ALARM:CODE`` (default 1, hard limit) when line K arrives; the line gets no
    answer, as on a real controller.
``restart-at-line=K``
    Restart the controller (power cycle: banner, queue and modal state lost, position
    kept) when line K arrives; line K is lost with it.
``latency=MS``
    Delay every answer by MS milliseconds (added to the link latency).

Status habits of real firmware (grbl's interface document: "Every '?' command sent by a
GUI is not guaranteed with a response"); each holds for the simulator's life:

``status-when-full=ignore|defer``
    No status reply while the planner is full: ``ignore`` forgets the query (as a grbl
    build seen on Linux does), ``defer`` answers it once the planner has room.
``ignore-status=F``
    Ignore a fraction F (0 < F <= 1) of the ``?`` queries, spread evenly (F = 0.25:
    every fourth).
``status-delay=MS``
    Send the report MS milliseconds after its ``?``; more ``?`` before it is sent are
    answered by that one report (grbl's status flag is set once).

Line and link faults fire once. Lines are counted from 1 over the simulator's life.

Examples
--------
>>> plan = FaultPlan.parse(["error-at-line=3:22", "latency=5"])
>>> plan.line_fault(3), plan.latency_s
(('error', 22), 0.005)
>>> plan.line_fault(3) is None
True
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

__all__ = ["FAULT_NAMES", "FaultPlan"]

#: Added to ``query * fraction`` before it is truncated: 100 * 0.29 is 28.999999999999996
#: in doubles, and the 100th query would not count as the 29th ignored one.
_COUNT_SLACK = 1e-9

FAULT_NAMES = (
    "drop-after-bytes",
    "drop-after-lines",
    "error-at-line",
    "alarm-at-line",
    "restart-at-line",
    "latency",
    "status-when-full",
    "ignore-status",
    "status-delay",
)


def _seconds_from_ms(name: str, text: str, most_ms: int) -> float:
    """A delay given in ms (0..``most_ms``), in seconds."""
    try:
        ms = float(text)
    except ValueError:
        ms = -1.0
    if not 0.0 <= ms <= most_ms:
        raise ValueError(f"fault {name!r}: MS must be 0..{most_ms} ms, got {text!r}")
    return ms / 1000.0


def _int(name: str, text: str, lo: int, what: str) -> int:
    try:
        v = int(text)
    except ValueError:
        v = lo - 1
    if v < lo:
        raise ValueError(f"fault {name!r}: {what} must be an integer >= {lo}, got {text!r}")
    return v


@dataclass
class FaultPlan:
    """Parsed faults and which of them have fired.

    Attributes
    ----------
    drop_after_bytes, drop_after_lines : int or None
        Link cut thresholds.
    line_faults : dict of int to (str, int)
        Line number -> (``"error"`` | ``"alarm"`` | ``"restart"``, code).
    latency_s : float
        Extra answer delay, s.
    status_when_full : str or None
        ``"ignore"`` or ``"defer"``: no status reply while the planner is full.
    ignore_status_fraction : float
        Share of ``?`` queries ignored, spread evenly (0 = none).
    status_delay_s : float
        Delay from ``?`` to its report, s (queries before it are merged).
    fired : list of str
        Faults that have fired, in order (for tests and the status line).
    """

    drop_after_bytes: int | None = None
    drop_after_lines: int | None = None
    line_faults: dict[int, tuple[str, int]] = field(default_factory=dict)
    latency_s: float = 0.0
    status_when_full: str | None = None
    ignore_status_fraction: float = 0.0
    status_delay_s: float = 0.0
    fired: list[str] = field(default_factory=list)

    @classmethod
    def parse(cls, specs: Iterable[str] | None) -> FaultPlan:
        """Read ``name=value`` specs (see the module docstring).

        Raises
        ------
        ValueError
            Naming the bad spec and listing the known fault names.
        """
        plan = cls()
        for spec in specs or ():
            name, sep, value = str(spec).strip().partition("=")
            name = name.strip().lower()
            if not sep or name not in FAULT_NAMES:
                raise ValueError(
                    f"unknown fault {spec!r}: use name=value with name one of "
                    f"{', '.join(FAULT_NAMES)}"
                )
            if name == "drop-after-bytes":
                plan.drop_after_bytes = _int(name, value, 1, "N")
            elif name == "drop-after-lines":
                plan.drop_after_lines = _int(name, value, 1, "N")
            elif name == "status-when-full":
                mode = value.strip().lower()
                if mode not in ("ignore", "defer"):
                    raise ValueError(
                        f"fault 'status-when-full': use 'ignore' or 'defer', got {value!r}"
                    )
                plan.status_when_full = mode
            elif name == "ignore-status":
                try:
                    share = float(value)
                except ValueError:
                    share = -1.0
                if not 0.0 < share <= 1.0:
                    raise ValueError(
                        f"fault 'ignore-status': F must be a fraction 0 < F <= 1, got {value!r}"
                    )
                plan.ignore_status_fraction = share
            elif name == "status-delay":
                plan.status_delay_s = _seconds_from_ms(name, value, 10_000)
            elif name == "latency":
                plan.latency_s += _seconds_from_ms(name, value, 60_000)
            else:
                kind = name.split("-", 1)[0]
                line_text, _, code_text = value.partition(":")
                line = _int(name, line_text, 1, "the line K")
                if kind == "restart":
                    if code_text:
                        raise ValueError(f"fault {name!r} takes no code, got {value!r}")
                    code = 0
                elif kind == "error":
                    code = _int(name, code_text, 1, "CODE") if code_text else 20
                else:
                    code = _int(name, code_text, 1, "CODE") if code_text else 1
                    if code > 9:
                        raise ValueError(f"fault {name!r}: alarm CODE must be 1..9, got {code}")
                if line in plan.line_faults:
                    raise ValueError(f"two faults at line {line}: {spec!r}")
                plan.line_faults[line] = (kind, code)
        return plan

    @property
    def status_habits(self) -> bool:
        """Any status fault is set."""
        return bool(self.status_when_full or self.ignore_status_fraction or self.status_delay_s)

    def ignores_status(self, query: int) -> bool:
        """Whether the ``query``-th ``?`` (1-based) is one of the ignored fraction."""
        f = self.ignore_status_fraction
        return f > 0.0 and int(query * f + _COUNT_SLACK) > int((query - 1) * f + _COUNT_SLACK)

    def line_fault(self, line: int) -> tuple[str, int] | None:
        """The fault due at ``line`` (fired and forgotten), or None."""
        fault = self.line_faults.pop(line, None)
        if fault is not None:
            self.fired.append(f"{fault[0]}-at-line={line}")
        return fault

    def drop_cut(self, data: bytes, bytes_in: int, lines_in: int) -> int | None:
        r"""Where to cut the link inside the next received chunk (fired once).

        Parameters
        ----------
        data : bytes
            The chunk about to be delivered.
        bytes_in, lines_in : int
            Bytes and line ends (``\n`` or ``\r``) received before it.

        Returns
        -------
        int or None
            How many bytes of ``data`` to deliver before the link drops, or None.
        """
        cut = None
        if self.drop_after_bytes is not None and bytes_in + len(data) >= self.drop_after_bytes:
            cut = max(self.drop_after_bytes - bytes_in, 0)
            self.fired.append(f"drop-after-bytes={self.drop_after_bytes}")
            self.drop_after_bytes = None
        if self.drop_after_lines is not None:
            need = self.drop_after_lines - lines_in
            at = None
            if need <= 0:
                at = 0
            else:
                for i, b in enumerate(data):
                    if b in (10, 13):
                        need -= 1
                        if need == 0:
                            at = i + 1
                            break
            if at is not None:
                self.fired.append(f"drop-after-lines={self.drop_after_lines}")
                self.drop_after_lines = None
                cut = at if cut is None else min(cut, at)
        return cut
