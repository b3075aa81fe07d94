"""``toolpath serve``: the HTTP service (:mod:`streamline_cam.service`) under uvicorn."""

from __future__ import annotations

import argparse
import ipaddress
import sys
from typing import TYPE_CHECKING, Any

from ..cli_files import CommandLineError, output_folder
from ..cli_types import positive_int

if TYPE_CHECKING:
    import socket

__all__ = ["register", "serve"]


def _target(text: str) -> tuple[str, str]:
    name, sep, address = text.partition("=")
    if not sep or not name.strip() or not address.strip():
        raise argparse.ArgumentTypeError(
            f"expected NAME=ADDRESS (e.g. mill=socket://127.0.0.1:5000), got {text!r}")
    kind, _, speed = address.strip().partition(":")
    if kind == "simulate" and speed:  # the built-in simulator at another time scale
        from simulator.clock import Speed

        try:
            Speed.parse(speed)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(f"{text!r}: {exc}") from None
    return name.strip(), address.strip()


def _port_number(text: str) -> int:
    """A TCP port for ``--port``: 0 (any free port) to 65535 (getaddrinfo would wrap more)."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"expected a port number 0-65535, got {text!r}")
    return value


def _bind(host: str, port: int) -> socket.socket:
    """A listening socket on ``host:port`` (port 0: any free port).

    Listening before the banner is printed: a client that reads the banner can connect at
    once (the connection waits in the backlog until uvicorn accepts it).
    """
    import socket  # loaded to serve, not to parse

    family, kind, proto, _, address = socket.getaddrinfo(
        host, port, type=socket.SOCK_STREAM, flags=socket.AI_PASSIVE)[0]
    sock = socket.socket(family, kind, proto)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    try:
        sock.bind(address)
        sock.listen(2048)  # uvicorn's default backlog
    except OSError:
        sock.close()
        raise
    sock.set_inheritable(True)
    return sock


def _is_loopback(host: str) -> bool:
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return host == "localhost"


def serve(args: argparse.Namespace) -> int:
    """Run the service until interrupted; returns the exit code."""
    import uvicorn

    from ..service import ServiceConfig, create_app
    from ..service.app import stop_events
    from ..service.config import DEFAULT_STREAM_TARGETS

    targets = dict(DEFAULT_STREAM_TARGETS) | dict(args.target or [])
    try:
        config = ServiceConfig(
            data_dir=output_folder(args.data_dir, "--data-dir"), workers=args.workers,
            executor=args.executor,
            max_upload_bytes=int(args.max_upload_mb * 2**20), max_queued=args.max_queued,
            stream_targets=targets, scheduler=args.scheduler)
    except (ValueError, CommandLineError) as exc:
        print(f"toolpath serve: error: {exc}", file=sys.stderr)
        return 2
    if config.executor == "thread" and config.workers > 1 and config.scheduler is None:
        from ..pipeline import kernels_threadsafe

        if not kernels_threadsafe():  # two jobs' kernels at once would abort the service
            print(f"toolpath serve: error: --executor thread with --workers "
                  f"{config.workers} runs jobs' compiled kernels in threads at once, which "
                  "numba's workqueue threading layer (neither TBB nor libgomp loads here) "
                  "cannot do without aborting the process: use --executor process (the "
                  "default) or --workers 1, or install libgomp1 or tbb", file=sys.stderr)
            return 2
    try:
        sock = _bind(args.host, args.port)
    except OSError as exc:
        print(f"toolpath serve: error: cannot listen on {args.host}:{args.port}: {exc}",
              file=sys.stderr)
        return 2
    host, port = sock.getsockname()[:2]
    shown = f"[{host}]" if ":" in host else host
    if not _is_loopback(host):
        print(f"toolpath serve: warning: listening on {host}, not loopback; the service has "
              "no authentication: anyone who reaches it can submit jobs and start streams",
              file=sys.stderr)
    print(f"toolpath serve: http://{shown}:{port} (API docs: http://{shown}:{port}/docs); "
          f"data in {config.data_dir.resolve()}; "
          + (f"jobs on the Dask scheduler at {config.scheduler}, {config.workers} at once"
             if config.scheduler else f"{config.workers} {config.executor} worker(s)")
          + f"; stream targets: {', '.join(sorted(targets))}", flush=True)
    app = create_app(config)

    class Server(uvicorn.Server):
        def handle_exit(self, sig: int, frame: Any) -> None:
            stop_events(app)  # open /events streams end, so the graceful stop is quick
            super().handle_exit(sig, frame)

    server = Server(uvicorn.Config(app, log_level=args.log_level, timeout_graceful_shutdown=5))
    try:
        server.run(sockets=[sock])
    except KeyboardInterrupt:  # uvicorn re-raises Ctrl-C after its graceful shutdown
        pass
    finally:
        sock.close()
    print("toolpath serve: stopped; queued and running jobs resume at the next start",
          flush=True)
    return 0


def register(commands: argparse._SubParsersAction) -> None:
    """Add ``toolpath serve``."""
    from ..service.config import DEFAULT_MAX_QUEUED, DEFAULT_MAX_UPLOAD_BYTES, default_workers

    parser = commands.add_parser(
        "serve", help="run the HTTP service (submit jobs, fetch results, stream)",
        description="Serve the pipeline over HTTP: submit blade sections, poll, fetch the "
        "report, plots, toolpath and G-code, stream to a machine or the simulator. Jobs are "
        "kept in SQLite in the data folder, so a restart loses none.")
    parser.add_argument("--host", default="127.0.0.1",
                        help="address to listen on (127.0.0.1: this computer only)")
    parser.add_argument("--port", type=_port_number, default=8000,
                        help="port (0: any free port)")
    parser.add_argument("--data-dir", default="toolpath-service",
                        help="folder for jobs.sqlite3 and the jobs' files (./toolpath-service)")
    parser.add_argument("--workers", type=positive_int, default=default_workers(),
                        help="jobs run at once (default: cores - 1, 1 to 4)")
    parser.add_argument("--executor", choices=("process", "thread"), default="process",
                        help="run jobs in worker processes (default) or threads")
    parser.add_argument("--scheduler", metavar="tcp://HOST:8786",
                        help="run the jobs on this Dask scheduler's workers (`dask scheduler`, "
                        "`dask worker`), --workers of them at once (default: the local "
                        "process pool)")
    parser.add_argument("--max-upload-mb", type=float,
                        default=DEFAULT_MAX_UPLOAD_BYTES / 2**20,
                        help="largest request body, MiB (413 above)")
    parser.add_argument("--max-queued", type=positive_int, default=DEFAULT_MAX_QUEUED,
                        help="queued jobs before submissions get 503")
    parser.add_argument("--target", action="append", type=_target, metavar="NAME=ADDRESS",
                        help="a stream target: NAME=socket://HOST:PORT, a serial port, or "
                        "the built-in simulator at a time scale, NAME=simulate:x20 (or "
                        "simulate:realtime) (repeatable; 'simulator' is always offered)")
    parser.add_argument("--log-level", default="info",
                        choices=("critical", "error", "warning", "info", "debug"))
    parser.set_defaults(handler=serve)
