"""Streaming a finished job's program to a configured target (a machine or the simulator).

The streamer comes from :func:`streamline_cam.streaming.make_streamer`, imported when
needed: without it the endpoint answers 503 rather than pretend. Each target has its own
single-thread executor, so two programs never interleave on one controller, and a slow
machine does not hold up the simulator. Stream requests are recorded in the store; one cut
short by a service stop is failed at the next start, never re-sent (see :mod:`.store`).

While a stream runs, its :class:`~streamline_cam.streaming.StreamControl` holds the live
status (position, lines, percent, ETA, alarm: :meth:`StreamRunner.live`) and takes feed
hold, resume and cancel (:meth:`StreamRunner.hold`, ``resume``, ``cancel``); every change is
passed to ``on_change(stream_id)`` (the service's event feed).
"""

from __future__ import annotations

import importlib
import logging
import threading
from collections import OrderedDict
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import Any, Final

from gcode.senders.errors import AlarmError, JobCancelledError

from ..streaming import GRBL_AXES, StreamControl
from .config import ServiceConfig
from .runner import USER_ERRORS
from .store import JobRecord, JobStore, StreamRecord

__all__ = [
    "STREAMING_MODULE",
    "MakeStreamer",
    "StreamRunner",
    "StreamingUnavailable",
    "load_make_streamer",
]

log = logging.getLogger(__name__)

STREAMING_MODULE = "streamline_cam.streaming"

MakeStreamer = Callable[[str], Callable[..., dict[str, Any]]]

#: Streams whose live status is kept in memory after they end (the newest ones).
KEPT_LIVE: Final[int] = 200


class StreamingUnavailable(RuntimeError):
    """Streaming cannot be offered by this installation (answered as 503)."""


def load_make_streamer() -> MakeStreamer:
    """``make_streamer`` from :mod:`streamline_cam.streaming`.

    Raises
    ------
    StreamingUnavailable
        The module is missing, fails to import, or lacks ``make_streamer``.
    """
    try:
        module = importlib.import_module(STREAMING_MODULE)
    except ImportError as exc:
        raise StreamingUnavailable(
            f"streaming is not available in this installation: {STREAMING_MODULE} cannot "
            f"be imported ({exc})") from None
    make = getattr(module, "make_streamer", None)
    if make is None:
        raise StreamingUnavailable(f"streaming is not available: {STREAMING_MODULE} has no "
                                   "make_streamer")
    return make


class StreamRunner:
    """Runs stream requests, one at a time per target.

    Parameters
    ----------
    store : JobStore
    config : ServiceConfig
    loader : callable, optional
        Returns ``make_streamer``; default :func:`load_make_streamer`. Its streamers are
        called ``stream(gcode_path, machine, control=StreamControl)``.
    on_change : callable, optional
        ``on_change(stream_id)`` after every change of a stream's state or live status.
    """

    def __init__(self, store: JobStore, config: ServiceConfig, *,
                 loader: Callable[[], MakeStreamer] = load_make_streamer,
                 on_change: Callable[[str], None] | None = None) -> None:
        self._store = store
        self._config = config
        self._loader = loader
        self._lock = threading.Lock()
        self._executors: dict[str, ThreadPoolExecutor] = {}
        self._controls: OrderedDict[str, StreamControl] = OrderedDict()
        self._alarms: dict[str, str] = {}
        self.on_change = on_change

    def _changed(self, stream_id: str) -> None:
        if self.on_change is not None:
            try:
                self.on_change(stream_id)
            except Exception:  # a listener's bug must not stop a machine mid-program
                log.exception("stream %s: change listener failed", stream_id)

    def availability(self) -> str:
        """``"available"``, or why streaming is not."""
        try:
            self._loader()
        except StreamingUnavailable as exc:
            return str(exc)
        return "available"

    def submit(self, job: JobRecord, target: str) -> StreamRecord | None:
        """Record a stream of ``job``'s program to ``target`` and start it.

        Returns
        -------
        StreamRecord or None
            ``None`` when a stream of this job is still queued or running.

        Raises
        ------
        KeyError
            ``target`` is not configured.
        StreamingUnavailable
            No streamer in this installation.
        """
        address = self._config.stream_targets[target]
        make_streamer = self._loader()
        record = self._store.add_stream(job.id, target)
        if record is None:
            return None
        stream_id = record.id
        control = StreamControl(on_change=lambda _: self._changed(stream_id))
        with self._lock:
            self._controls[stream_id] = control
            while len(self._controls) > KEPT_LIVE:
                old, _ = self._controls.popitem(last=False)
                self._alarms.pop(old, None)
            executor = self._executors.get(target)
            if executor is None:
                executor = ThreadPoolExecutor(max_workers=1,
                                              thread_name_prefix=f"toolpath-stream-{target}")
                self._executors[target] = executor
            executor.submit(self._run, record.id, job, address, make_streamer, control)
        self._changed(stream_id)
        return record

    def _run(self, stream_id: str, job: JobRecord, address: str,
             make_streamer: MakeStreamer, control: StreamControl) -> None:
        try:
            if control.cancelled or not self._store.start_stream(stream_id):
                return
            control.start()
            self._stream(stream_id, job, address, make_streamer, control)
        finally:
            control.ended()
            self._changed(stream_id)

    def _stream(self, stream_id: str, job: JobRecord, address: str,
                make_streamer: MakeStreamer, control: StreamControl) -> None:
        from machines.machine import load_machine

        try:
            machine = load_machine(job.parameters["machine"])
            result = make_streamer(address)(self._config.jobs_dir / job.id / "part.nc", machine,
                                            control=control)
        except JobCancelledError as exc:
            self._store.end_stream(stream_id, error=str(exc), cancelled=True)
        except AlarmError as exc:
            self._alarms[stream_id] = str(exc)
            self._store.end_stream(stream_id, error=f"{type(exc).__name__}: {exc}")
        except USER_ERRORS as exc:
            self._store.end_stream(stream_id, error=f"{type(exc).__name__}: {exc}")
        except Exception as exc:  # a sender error or a bug: recorded, the service stays up
            log.exception("stream %s failed", stream_id)
            self._store.end_stream(stream_id, error=f"{type(exc).__name__}: {exc}")
        else:
            result = dict(result)
            if "journal" in result:  # a server path: give the resource instead
                result["journal"] = f"/jobs/{job.id}/journal"
            refused = None
            if result.get("ok") is False:
                refused = str(result.get("refused") or result.get("error")
                              or "the streamer reported ok: false")
            if result.get("alarm"):
                self._alarms[stream_id] = str(result["alarm"])
            self._store.end_stream(stream_id, result=result, error=refused)

    # control ------------------------------------------------------------------------------

    def _control(self, stream_id: str) -> StreamControl | None:
        with self._lock:
            return self._controls.get(stream_id)

    def hold(self, stream_id: str) -> bool:
        """Feed hold (``!``) on a running stream; whether it was asked."""
        control = self._control(stream_id)
        return control is not None and control.hold()

    def resume(self, stream_id: str) -> bool:
        """Cycle start (``~``) of a held stream; whether it was asked."""
        control = self._control(stream_id)
        return control is not None and control.resume()

    def cancel(self, stream_id: str) -> bool:
        """Cancel a stream; whether it was asked.

        A queued stream never starts; a running or held one gets a feed hold, then a soft
        reset (the position is kept).
        """
        control = self._control(stream_id)
        if self._store.cancel_queued_stream(stream_id):
            if control is not None:
                control.cancel()
            self._changed(stream_id)
            return True
        return control is not None and control.cancel()

    def live(self, stream_id: str) -> dict[str, Any]:
        """The stream's live status (fields of ``StreamView``; empty when not known here).

        ``position_mm`` is the work position (the program's coordinates) of the latest
        status report, or the planned end of the last acknowledged line when the report is
        stale (``position_source``); ``machine_position_mm`` the machine's (MPos).
        """
        control = self._control(stream_id)
        if control is None:
            return {}
        now = control.snapshot()
        report = now.progress_report
        live: dict[str, Any] = {"revision": now.revision, "held": now.state == "held",
                                "alarm": self._alarms.get(stream_id)}
        if report is not None:
            live |= {
                "position_mm": _axes(report.position, control.axes),
                "position_source": report.position_source or None,
                "machine_position_mm": _axes(now.machine_position, control.axes),
                "controller_state": report.state or None,
                "line": report.done, "source_line": report.line,
                "total_lines": report.total, "percent": round(report.percent, 2),
                "eta_s": None if report.eta_s is None else round(report.eta_s, 1),
                "elapsed_s": round(report.elapsed_s, 2),
            }
        return live

    def shutdown(self) -> None:
        """Stop taking streams.

        A running one ends with the process; a held one is cancelled (nobody is left to
        resume it).
        """
        with self._lock:
            executors, self._executors = list(self._executors.values()), {}
            held = [c for c in self._controls.values() if c.state == "held"]
        for control in held:
            control.cancel()
        for executor in executors:
            executor.shutdown(wait=False, cancel_futures=True)


def _axes(position: tuple[float, ...] | None, names: str) -> dict[str, float] | None:
    """``{"x": .., "y": .., "z": .., ...}`` (mm; rotary axes deg) of a reported position.

    ``names`` are the reported axes in order; a report of another length is named in
    GRBL's order (X Y Z A B C).
    """
    if position is None:
        return None
    if len(names) != len(position):
        names = GRBL_AXES
    return {name: round(float(v), 4) for name, v in zip(names, position, strict=False)}
