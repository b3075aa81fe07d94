r"""A software CNC controller for tests and the demo: GRBL 1.1 serial and Modbus.

Nothing else in the project imports this package; tests, the demo and the CLI
(``toolpath simulate``, ``python -m simulator``) drive it.

The in-process API (the contract senders and the demo build on)
----------------------------------------------------------------
``run_simulator(machine="grbl-router", *, serial="tcp", modbus=None, speed="instant",
faults=None, **options)`` is a context manager that starts a controller in a background
thread and yields a :class:`Simulator`; leaving the block stops it (thread joined, ports
and devices closed). Everything binds 127.0.0.1; port 0 picks a free port.

* ``serial``: ``"pty"`` | ``"tcp"`` | ``"tcp:PORT"`` | None. ``modbus``: ``"tcp"`` |
  ``"tcp:PORT"`` | ``"rtu"`` (pseudo-terminal) | None.
* ``speed``: ``"instant"`` (virtual time jumps whenever the machine would make the
  host wait; the queue runs out after ``drain_after_s`` = 0.05 s of link silence),
  ``"realtime"`` or ``"xN"``.
* ``faults``: ``["drop-after-bytes=N", "drop-after-lines=N", "error-at-line=K[:CODE]",
  "alarm-at-line=K[:CODE]", "restart-at-line=K", "latency=MS"]`` (see :mod:`.faults`).
* options: ``baud=115200`` (0 = unpaced), ``latency_s=0.0`` (each way),
  ``mode=None`` (``"grbl"`` | ``"linuxcnc"``, default from the machine),
  ``reset_on_connect=True`` (a connection restarts the controller like an Arduino's
  DTR; the banner follows after ``boot_delay_s=0.05``), ``planner_blocks=15``,
  ``work_offsets=None`` (G54..G59 as {1..6: 6 values}), ``serial_port``, ``modbus_port``.

The :class:`Simulator` it yields:

* ``sim.serial_url`` -- what ``serial.serial_for_url(url, timeout=...)`` opens (the pty
  path or ``socket://127.0.0.1:PORT``); ``sim.endpoints`` -- :class:`Endpoints`
  (``serial_url``, ``pty_path``, ``tcp_port``, ``modbus_port``, ``modbus_rtu_path``).
* ``sim.controller`` -- the :class:`Controller` (``journal``, ``state``,
  ``position()``, ``now_s``, ...); hold ``sim.lock`` when touching it, or use
  ``sim.journal()`` (list of :class:`JournalEntry`: ``seq``, ``line``, ``n_word``,
  ``text``, ``position``, ``time_s``), ``sim.snapshot()`` / ``sim.counters()`` (state,
  position, buffers, ``ok``/``error``/``alarms``, ``rx_dropped_bytes``, ``resets``,
  ``restarts``, ``drops``, ``bytes_in``/``bytes_out``, ``faults_fired``, ...),
  ``sim.call(fn)``.
* ``sim.wait_for(predicate, timeout_s)`` and ``sim.wait_idle(timeout_s)`` -- bounded
  waits that return False on time-out; ``sim.drop_link()``.

Journal semantics: one entry per executed line that produced blocks (``seq`` counts
accepted lines over the simulator's life; ``line`` is the GRBL received-line count, or
the Modbus block SEQ), so ``journal.duplicates() == {}`` and the list of lines proves
exactly-once execution.

Sans-IO pieces for byte-level tests: ``GrblProtocol(Controller(machine)).feed(bytes)
-> bytes``; ``ModbusDevice(controller).write/read/service``; ``run_program(controller,
program)`` executes a whole parsed program at once (instant mode, same physics).

Modules
-------
clock
    ``VirtualClock`` (injected time) and ``Speed`` (instant, realtime, xN).
motion
    Block kinematics, grbl junction speeds, trapezoid timing and stepping.
planner
    ``PlannerQueue`` (15 blocks, look-ahead) and ``plan_entry_speeds_sq`` (vectorized).
controller
    ``Controller``: states, soft limits, hold/resume/reset, alarms, journal.
journal
    ``Journal`` and ``JournalEntry``.
settings
    The ``$n`` table from a machine definition.
reports
    Status report, ``$G``, ``$#``, ``$I`` texts.
grbl_protocol
    ``GrblProtocol``: the sans-IO GRBL 1.1 front end.
program_run
    ``run_program``: whole-program execution (vectorized, instant).
faults
    ``FaultPlan``: fault specs.
link
    ``PacedPipe``: baud pacing and latency.
transports
    ``PtyEndpoint``, ``TcpEndpoint``.
serial_session
    ``SerialSession``: endpoint + pacing + faults + protocol.
modbus_device
    ``ModbusDevice``: the register map's handshake (sans-IO).
modbus_server
    The pymodbus adapter (TCP, RTU over pty); the only pymodbus importer.
runtime
    ``Simulator``, ``run_simulator``, ``Endpoints``.
cli
    ``toolpath simulate`` / ``python -m simulator``.

Examples
--------
>>> from simulator import run_simulator
>>> import serial
>>> with run_simulator("grbl-router", serial="tcp") as sim:
...     port = serial.serial_for_url(sim.serial_url, timeout=2.0)
...     banner = [port.readline(), port.readline()]
...     _ = port.write(b"G1X-10F600\n")
...     answer = port.readline()
...     port.close()
...     ok = sim.wait_idle(2.0)
>>> banner[1], answer, ok
(b"Grbl 1.1h ['$' for help]\r\n", b'ok\r\n', True)
"""

import importlib
from typing import Any

#: Exported names -> defining module, imported on first use: ``toolpath --help`` (which
#: lists ``simulate``) and ``import simulator.cli`` do not load the whole controller.
_EXPORTS = {
    "Speed": "simulator.clock",
    "VirtualClock": "simulator.clock",
    "Alarm": "simulator.controller",
    "Controller": "simulator.controller",
    "State": "simulator.controller",
    "SubmitResult": "simulator.controller",
    "FaultPlan": "simulator.faults",
    "GrblProtocol": "simulator.grbl_protocol",
    "Journal": "simulator.journal",
    "JournalEntry": "simulator.journal",
    "ModbusDevice": "simulator.modbus_device",
    "ProgramRun": "simulator.program_run",
    "run_program": "simulator.program_run",
    "Endpoints": "simulator.runtime",
    "Simulator": "simulator.runtime",
    "run_simulator": "simulator.runtime",
}

__all__ = [
    "Alarm",
    "Controller",
    "Endpoints",
    "FaultPlan",
    "GrblProtocol",
    "Journal",
    "JournalEntry",
    "ModbusDevice",
    "ProgramRun",
    "Simulator",
    "Speed",
    "State",
    "SubmitResult",
    "VirtualClock",
    "run_program",
    "run_simulator",
]


def __getattr__(name: str) -> Any:
    # (toolpath.lazy.lazy_exports, inline: this package may import only machines and gcode)
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(_EXPORTS[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
