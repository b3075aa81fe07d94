"""The FastAPI application: parts wired together, errors mapped to status codes.

Error mapping (every answer is JSON ``{"detail": ...}``, never a traceback):

- 413: a request body over ``max_upload_bytes`` (checked while it arrives);
- 422: a field's type or choice (pydantic), or the library's own refusal
  (``ToolpathError``, ``MachineError``, ``GCodeError``), ``loc`` naming the field;
- 404 unknown job, stream or plot; 409 results of a job that is not done;
- 503 queue full, or streaming not available in this installation;
- 500 only for a bug, with the exception's class and no traceback (that goes to the log).

``/docs`` is Swagger UI from files shipped in the package (``static/swagger``: no CDN, so it
works on a machine without internet); ReDoc is not offered.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any, Final

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import HTMLResponse, JSONResponse
from fastapi.staticfiles import StaticFiles

from gcode.errors import GCodeError
from machines.errors import MachineError
from toolpath.errors import ToolpathError

from .config import ServiceConfig
from .events import EventHub, JobWatcher
from .limits import BodySizeLimit
from .page import mount_page
from .pool import WorkerPool
from .routes import Service, router
from .store import JobStore
from .streams import MakeStreamer, StreamRunner, load_make_streamer
from .validation import SubmissionError

__all__ = ["SWAGGER_DIR", "create_app", "stop_events"]

log = logging.getLogger(__name__)

#: Swagger UI's files (swagger-ui-dist, Apache-2.0), served at ``/static/swagger``.
SWAGGER_DIR: Final[Path] = Path(__file__).parent / "static" / "swagger"

_DESCRIPTION = """Blade sections in, a checked G-code program out.

Submit a job (`POST /jobs` with JSON sections, or `POST /jobs/upload` with a
`section,x,y,z` CSV), poll `GET /jobs/{id}` until `state` is `done` or `failed`, then fetch
the report, plots, toolpath (.npz) and G-code (.nc), and optionally stream the program to
a configured machine or the built-in simulator (`POST /jobs/{id}/stream`). Jobs are kept
in SQLite in the data folder: a restart loses none.
"""


def _validation_body(field: str, message: str) -> dict[str, Any]:
    return {"detail": [{"loc": ["body", *field.split(".")], "msg": message,
                        "type": "value_error"}]}


def create_app(config: ServiceConfig, *,
               stream_loader: Callable[[], MakeStreamer] | None = None) -> FastAPI:
    """Build the service for ``config`` (the data folder is created if missing).

    The worker pool starts (and interrupted jobs are re-queued) when the application starts
    (ASGI lifespan: ``with TestClient(app)`` or uvicorn), and stops when it stops.

    Parameters
    ----------
    config : ServiceConfig
    stream_loader : callable, optional
        Returns ``make_streamer``; default: import it from ``streamline_cam.streaming``
        (:func:`~.streams.load_make_streamer`).
    """
    config.jobs_dir.mkdir(parents=True, exist_ok=True)
    store = JobStore(config.db_path)
    pool = WorkerPool(store, config)
    hub = EventHub()
    service = Service(config=config, store=store, pool=pool,
                      streams=StreamRunner(store, config,
                                           loader=stream_loader or load_make_streamer),
                      plot_lock=threading.Lock(), events=hub)
    watcher = JobWatcher(store, hub, lambda record, streams: service.job_view(
        record, streams).model_dump(mode="json"))

    def stream_changed(stream_id: str) -> None:
        if hub.listeners:
            record = store.get_stream(stream_id)
            if record is not None:
                hub.publish("stream", service.stream_view(record).model_dump(mode="json"))

    service.streams.on_change = stream_changed

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        requeued, failed = store.recover(max_attempts=config.max_attempts)
        if requeued or failed:
            log.warning("restart: %d interrupted job(s) re-queued, %d failed after %d tries",
                        len(requeued), len(failed), config.max_attempts)
        if config.start_workers:
            pool.start()
        watcher.start()
        try:
            yield
        finally:
            hub.close()
            watcher.stop()
            pool.shutdown()
            service.streams.shutdown()

    app = FastAPI(title="streamline-cam", version="0.1.0", description=_DESCRIPTION,
                  lifespan=lifespan, form_limits={"max_files": 1, "max_fields": 40},
                  docs_url=None, redoc_url=None)
    app.state.service = service
    app.add_middleware(BodySizeLimit, max_bytes=config.max_upload_bytes)
    app.include_router(router)
    app.mount("/static/swagger", StaticFiles(directory=SWAGGER_DIR), name="swagger")

    @app.get("/docs", include_in_schema=False)
    def docs() -> HTMLResponse:
        return get_swagger_ui_html(
            openapi_url=app.openapi_url or "/openapi.json", title=f"{app.title}: API",
            swagger_js_url="/static/swagger/swagger-ui-bundle.js",
            swagger_css_url="/static/swagger/swagger-ui.css",
            swagger_favicon_url="/static/swagger/favicon-32x32.png")

    # the web page at / (static files; see .page)
    mount_page(app)

    @app.exception_handler(RequestValidationError)
    async def _invalid(request: Request, exc: RequestValidationError) -> JSONResponse:
        # without "input": it may be large (a whole section), not JSON (NaN) or a file
        errors = [{"loc": list(e.get("loc", ())), "msg": str(e.get("msg", "")),
                   "type": str(e.get("type", ""))} for e in exc.errors()]
        return JSONResponse(status_code=422, content={"detail": errors})

    @app.exception_handler(SubmissionError)
    async def _refused(request: Request, exc: SubmissionError) -> JSONResponse:
        return JSONResponse(status_code=422, content=_validation_body(exc.field, exc.message))

    async def _library_error(request: Request, exc: Exception) -> JSONResponse:
        return JSONResponse(status_code=422, content={"detail": str(exc)})

    for family in (ToolpathError, MachineError, GCodeError):
        app.add_exception_handler(family, _library_error)

    @app.exception_handler(Exception)
    async def _bug(request: Request, exc: Exception) -> JSONResponse:
        log.exception("%s %s failed", request.method, request.url.path)
        return JSONResponse(status_code=500, content={
            "detail": f"internal error ({type(exc).__name__}); see the service log"})

    return app


def stop_events(app: FastAPI) -> None:
    """End every ``GET /events`` connection now (the server is stopping).

    A server waits for open responses before it shuts the application down, and an event
    stream never ends by itself: ``toolpath serve`` calls this when it is asked to stop.
    """
    app.state.service.events.close()
