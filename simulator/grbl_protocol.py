r"""The GRBL 1.1 serial protocol as a sans-IO front end: bytes in, bytes out.

:class:`GrblProtocol` does what grbl's ``serial.c`` and ``protocol.c`` do with the bytes
of a serial link, around a :class:`~simulator.controller.Controller`:

* Real-time bytes (``?`` ``!`` ``~`` 0x18, and the extended 0x80-0xFF commands) are
  acted on as they arrive and never enter the receive buffer; other bytes above 0x7F
  are discarded.
* Everything else goes into a 128-byte receive buffer. When the controller cannot take
  the next line (planner full, a synchronizing line waiting) the buffer fills up, and
  bytes that arrive while it is full are dropped and counted
  (:attr:`GrblProtocol.rx_dropped_bytes`), as the serial interrupt drops them.
* Lines end at ``\n`` or ``\r`` (so ``\r\n`` is two lines). Spaces, control characters
  and comments are removed and letters upper-cased; more than 79 characters left is
  ``error:11``. Every line gets exactly one ``ok`` or ``error:N``, in order, except the
  line that raises a soft-limit alarm (grbl sends nothing for it).
* ``$`` commands: ``$`` ``$$`` ``$#`` ``$G`` ``$I`` ``$N`` ``$C`` ``$X`` ``$H`` ``$n=v``;
  pushes: ``<...>`` status reports, ``ALARM:N``, ``[MSG:...]``, the welcome banner
  after every reset.
* ``?`` is answered at once, unless the fault plan gives the firmware's status habits
  (:mod:`simulator.faults`: no reply while the planner is full, a share of queries
  ignored, a delayed report that answers every ``?`` before it once, like grbl's status
  flag); :attr:`GrblProtocol.counters` counts ``status`` (reports), ``status_ignored``
  and ``status_merged``. A delay needs the wall time passed to :meth:`feed`/:meth:`poll`.

With ``instant=True`` the controller's virtual time jumps whenever the protocol would
wait for the machine; otherwise the owner moves time (``controller.advance_to``) and
calls :meth:`GrblProtocol.poll`.

Examples
--------
>>> from machines import load_machine
>>> from simulator.controller import Controller
>>> p = GrblProtocol(Controller(load_machine("grbl-router")))
>>> p.feed(b"G1 x-1 f600\n?")
b'ok\r\n<Run|MPos:0.000,0.000,0.000|Bf:14,128|FS:0,0|WCO:0.000,0.000,0.000>\r\n'
"""

from __future__ import annotations

from simulator.controller import Controller, State
from simulator.faults import FaultPlan
from simulator.reports import (
    BANNER,
    HELP,
    StatusCounters,
    accessories,
    format_build_info,
    format_gcode_state,
    format_offsets,
    format_status,
)

__all__ = ["LINE_BUFFER_SIZE", "RX_BUFFER_SIZE", "GrblProtocol", "clean_line"]

#: Usable receive buffer, bytes (grbl 1.1 ``RX_BUFFER_SIZE``).
RX_BUFFER_SIZE = 128
#: Line buffer including its terminating NUL: 79 characters fit (grbl ``LINE_BUFFER_SIZE``).
LINE_BUFFER_SIZE = 80

_RT_STATUS, _RT_HOLD, _RT_RESUME, _RT_RESET = 0x3F, 0x21, 0x7E, 0x18
_REALTIME = frozenset({_RT_STATUS, _RT_HOLD, _RT_RESUME, _RT_RESET})
_NEEDS_SLOW = bytes([_RT_STATUS, _RT_HOLD, _RT_RESUME, _RT_RESET]) + bytes(range(0x80, 0x100))
_DELETE = bytes(range(0, 33)) + b"/"
_EOL = b"\r\n"


def clean_line(raw: bytes) -> tuple[bytes, bool]:
    """Grbl's line assembly: drop spaces, controls, ``/`` and comments; upper-case.

    Returns
    -------
    (bytes, bool)
        The line and whether it overflowed the line buffer.
    """
    if b"(" not in raw and b";" not in raw:
        clean = raw.translate(None, _DELETE).upper()
        if len(clean) >= LINE_BUFFER_SIZE:
            return clean[: LINE_BUFFER_SIZE - 1], True
        return clean, False
    out = bytearray()
    paren = semi = overflow = False
    for c in raw:
        if paren or semi or overflow:
            if c == 0x29 and paren:
                paren = False
            continue
        if c <= 0x20 or c == 0x2F:
            continue
        if c == 0x28:
            paren = True
        elif c == 0x3B:
            semi = True
        elif len(out) >= LINE_BUFFER_SIZE - 1:
            overflow = True
        else:
            out.append(c - 32 if 0x61 <= c <= 0x7A else c)
    return bytes(out), overflow


class GrblProtocol:
    r"""Sans-IO GRBL 1.1 front end of a controller.

    Parameters
    ----------
    controller : Controller
        The core it drives.
    instant : bool
        Jump virtual time whenever the protocol would wait for motion.
    faults : FaultPlan or None
        Line faults (error, alarm, restart at line K); link faults are the transport's.

    Attributes
    ----------
    rx_dropped_bytes : int
        Bytes dropped because the receive buffer was full.
    lines_received : int
        Lines received (every ``\n`` or ``\r``), over the protocol's life.
    counters : dict of str to int
        ``ok``, ``error``, ``alarm``, ``status``, ``reset``, ``restart`` counts.
    """

    def __init__(
        self,
        controller: Controller,
        *,
        instant: bool = True,
        faults: FaultPlan | None = None,
    ) -> None:
        self.controller = controller
        self.instant = instant
        self.faults = faults if faults is not None else FaultPlan()
        self._rx = bytearray()
        self._held: bytes | None = None  # a G-code line waiting for the planner
        self._held_line = 0
        self._await_ok = False
        self._status = StatusCounters()
        self._out: list[bytes] = []
        self.rx_dropped_bytes = 0
        self.rx_bytes = 0
        self.lines_received = 0
        self.counters = {
            "ok": 0,
            "error": 0,
            "alarm": 0,
            "status": 0,
            "status_ignored": 0,
            "status_merged": 0,
            "reset": 0,
            "restart": 0,
        }
        self.status_queries = 0
        self._status_due_s: float | None = None  # a report owed (grbl's status flag)
        self._now_s: float | None = None

    # ------------------------------------------------------------------ public
    @property
    def rx_free(self) -> int:
        """Free bytes in the receive buffer (``Bf:`` second field)."""
        return RX_BUFFER_SIZE - len(self._rx)

    def banner(self) -> bytes:
        """The power-on output: the welcome line (and the lock message in Alarm)."""
        self._out.append(b"\r\n" + BANNER.encode() + _EOL)
        if self.controller.alarm is not None:
            self._out.append(b"[MSG:'$H'|'$X' to unlock]\r\n")
        return self._take()

    def feed(self, data: bytes, now_s: float | None = None) -> bytes:
        """Receive bytes from the host; return the bytes the controller sends back.

        ``now_s`` is the wall time (s), used only by the ``status-delay`` fault.
        """
        if now_s is not None:
            self._now_s = now_s
        if data.translate(None, _NEEDS_SLOW) == data:
            self._receive(data)
        else:
            start = 0
            for i, c in enumerate(data):
                if c in _REALTIME or c >= 0x80:
                    if i > start:
                        self._receive(data[start:i])
                    start = i + 1
                    self._realtime(c)
            if start < len(data):
                self._receive(data[start:])
        return self._take()

    def poll(self, now_s: float | None = None) -> bytes:
        """Serve whatever the controller's progress allows (call after moving time)."""
        if now_s is not None:
            self._now_s = now_s
        self._process()
        return self._take()

    def soft_reset(self) -> bytes:
        """Ctrl-X from the API (same as receiving 0x18)."""
        self._realtime(_RT_RESET)
        return self._take()

    def restart(self) -> bytes:
        """Power-cycle the controller: buffers lost, banner sent."""
        self.controller.restart()
        self._flush_input()
        self.counters["restart"] += 1
        self._status.reset()
        return self.banner()

    def status_report(self) -> str:
        """The status report text for the current instant (no line end)."""
        c = self.controller
        state = c.state
        if state is State.HOLD:
            name = "Hold:0" if c.hold_complete else "Hold:1"
        else:
            name = state.value
        busy = state in (State.RUN, State.HOLD)
        show_wco, show_ovr = self._status.next(busy)
        s = c.settings
        return format_status(
            name,
            c.position(),
            c.work_offset(),
            machine_position=s.report_mpos,
            buffer=(c.planner_free, self.rx_free) if s.report_buffer else None,
            feed_mm_per_min=c.feed_mm_per_min(),
            rpm=c.spindle_rpm(),
            show_wco=show_wco,
            show_ovr=show_ovr,
            accessories=accessories(c.executed_state),
        )

    # ------------------------------------------------------------------ internals
    def _take(self) -> bytes:
        out = b"".join(self._out)
        self._out.clear()
        return out

    def _receive(self, data: bytes) -> None:
        self.rx_bytes += len(data)
        rx = self._rx
        while data:
            room = RX_BUFFER_SIZE - len(rx)
            if room > 0:
                rx += data[:room]
                data = data[room:]
            self._process()
            if data and len(rx) >= RX_BUFFER_SIZE:
                self.rx_dropped_bytes += len(data)
                return

    def _realtime(self, c: int) -> None:
        ctl = self.controller
        if c == _RT_RESET:
            ctl.soft_reset()
            self._flush_input()
            self.counters["reset"] += 1
            self._emit_alarms()
            self._status.reset()
            self._out.append(b"\r\n" + BANNER.encode() + _EOL)
            if ctl.alarm is not None:
                self._out.append(b"[MSG:'$H'|'$X' to unlock]\r\n")
            return
        if c == _RT_STATUS:
            if ctl.alarm_critical:
                return  # grbl sends nothing after a critical alarm until a reset
            self._status_query()
        elif c == _RT_HOLD:
            ctl.feed_hold()
            if self.instant:
                ctl.run_until_stopped()
        elif c == _RT_RESUME:
            ctl.cycle_start()
        # other extended real-time bytes (door, jog cancel, overrides) are accepted and ignored
        self._process()

    def _status_query(self) -> None:
        """A ``?``: report now, or as the fault plan's status habits say."""
        f = self.faults
        self.status_queries += 1
        if not f.status_habits:
            self._report()
            return
        if self._status_due_s is not None:  # the flag is already set: one report for both
            self.counters["status_merged"] += 1
            return
        full = self.controller.planner.full
        if f.ignores_status(self.status_queries) or (f.status_when_full == "ignore" and full):
            self.counters["status_ignored"] += 1
            return
        self._status_due_s = (self._now_s or 0.0) + f.status_delay_s
        self._serve_status()

    def _serve_status(self) -> None:
        due = self._status_due_s
        if due is None:
            return
        if self._now_s is not None and self._now_s < due:
            return
        if self.faults.status_when_full == "defer" and self.controller.planner.full:
            return
        self._status_due_s = None
        self._report()

    def _report(self) -> None:
        self.counters["status"] += 1
        self._out.append(self.status_report().encode() + _EOL)

    def _flush_input(self) -> None:
        self._status_due_s = None  # a reset clears grbl's pending status flag
        self._rx.clear()
        self._held = None
        self._await_ok = False

    def _emit_alarms(self) -> None:
        events = self.controller.alarm_events
        while events:
            alarm = events.popleft()
            self.counters["alarm"] += 1
            self._out.append(f"ALARM:{int(alarm)}\r\n".encode())
            if alarm.critical:
                self._out.append(b"[MSG:Reset to continue]\r\n")

    def _ok(self) -> None:
        self.counters["ok"] += 1
        self._out.append(b"ok\r\n")

    def _error(self, code: int) -> None:
        self.counters["error"] += 1
        self._out.append(f"error:{code}\r\n".encode())

    def _process(self) -> None:
        self._lines()
        if self._status_due_s is not None:
            self._serve_status()

    def _lines(self) -> None:
        ctl = self.controller
        rx = self._rx
        instant = self.instant
        while True:
            if ctl.alarm_events:
                self._emit_alarms()
            if ctl.critical:
                if instant and not ctl.alarm_critical:
                    ctl.run_until_stopped()
                    continue
                return
            if self._await_ok:
                if ctl.line_pending:
                    if not instant or ctl.hold_complete:
                        return
                    ctl.run_until_line_done()
                    if ctl.line_pending:
                        return
                    continue
                self._await_ok = False
                self._ok()
            if self._held is not None:
                if not ctl.accepting:
                    if not instant or ctl.hold_complete:
                        return
                    ctl.run_until_accepting()
                    if not ctl.accepting:
                        return
                text = self._held
                self._held = None
                res = ctl.submit(text.decode("ascii"), line=self._held_line)
                if res.status == "accepted":
                    self._await_ok = True
                elif res.status == "error":
                    self._error(res.code)
                continue
            # next complete line from the receive buffer
            i = rx.find(b"\n")
            j = rx.find(b"\r")
            if i < 0 or 0 <= j < i:
                i = j
            if i < 0:
                return
            raw = bytes(rx[:i])
            del rx[: i + 1]
            self.lines_received += 1
            self._line(raw)

    def _line(self, raw: bytes) -> None:
        n = self.lines_received
        if self.faults.line_faults:
            fault = self.faults.line_fault(n)
            if fault is not None:
                kind, code = fault
                if kind == "error":
                    self._error(code)
                elif kind == "alarm":
                    self.controller.raise_alarm(code)
                    self._flush_input()
                    self._emit_alarms()
                else:
                    self._out.append(self.restart())
                return
        line, overflow = clean_line(raw)
        if overflow:
            self._error(11)
        elif not line:
            self._ok()
        elif line[0] == 0x24:  # '$'
            self._system(line.decode("ascii"))
        elif self.controller.alarm is not None:
            self._error(9)
        else:
            self._held = line
            self._held_line = n

    # ------------------------------------------------------------------ $ commands
    def _system(self, line: str) -> None:
        ctl = self.controller
        state = ctl.state
        out = self._out
        cmd = line[1:]
        if cmd == "":
            out.append(HELP.encode() + _EOL)
        elif cmd in ("$", "G", "C", "X"):
            if cmd == "$":
                if state in (State.RUN, State.HOLD):
                    self._error(8)
                    return
                out.extend(t.encode() + _EOL for t in ctl.settings.format_lines())
            elif cmd == "G":
                out.append(format_gcode_state(ctl.parser_state).encode() + _EOL)
            elif cmd == "C":
                if state is State.CHECK:
                    ctl.set_check_mode(False)
                    out.append(b"[MSG:Disabled]\r\n")
                    self._ok()
                    self._flush_input()
                    self._status.reset()
                    out.append(b"\r\n" + BANNER.encode() + _EOL)
                    return
                if ctl.set_check_mode(True):
                    self._error(8)
                    return
                out.append(b"[MSG:Enabled]\r\n")
            elif ctl.unlock():
                out.append(b"[MSG:Caution: Unlocked]\r\n")
        else:
            if state not in (State.IDLE, State.ALARM):
                self._error(8)
                return
            if cmd == "#":
                idx = tuple("XYZABC".index(a) for a in ctl.report_axes)
                lines = format_offsets(ctl.work_offsets, idx)
                out.extend(t.encode() + _EOL for t in lines)
            elif cmd == "I":
                info = format_build_info(ctl.planner.capacity, RX_BUFFER_SIZE)
                out.extend(t.encode() + _EOL for t in info)
            elif cmd == "N":
                out.append(b"$N0=\r\n$N1=\r\n")
            elif cmd == "H":
                self._error(5)  # homing cycle not enabled ($22=0)
                return
            else:
                code = self._store_setting(cmd)
                if code:
                    self._error(code)
                    return
        self._ok()

    def _store_setting(self, cmd: str) -> int:
        number, eq, value = cmd.partition("=")
        if not eq or not number.isdigit():
            return 3  # '$' statement not recognized or not supported ($J=, $SLP, $RST=, $Nx=)
        try:
            v = float(value)
        except ValueError:
            return 2
        return self.controller.set_setting(int(number), v)
