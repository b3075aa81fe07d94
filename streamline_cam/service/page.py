"""The web page at ``/``: static files from ``web/`` (HTML, ES modules, CSS, vendored three.js).

Nothing is built: the browser loads ``web/index.html``, whose import map points ``three`` at
the vendored copy, so the page works on a machine without internet. Everything it shows
comes from the JSON API and ``GET /events``; this module only serves the files.
"""

from __future__ import annotations

from pathlib import Path
from typing import Final

from fastapi import FastAPI
from fastapi.responses import FileResponse
from fastapi.staticfiles import StaticFiles

__all__ = ["WEB_DIR", "mount_page"]

WEB_DIR: Final[Path] = Path(__file__).with_name("web")
"""The page's files (installed as package data)."""


def mount_page(app: FastAPI) -> None:
    """Serve the page at ``/`` and its files under ``/web/``."""
    app.mount("/web", StaticFiles(directory=WEB_DIR), name="web")

    @app.get("/", include_in_schema=False)
    def page() -> FileResponse:
        return FileResponse(WEB_DIR / "index.html", media_type="text/html; charset=utf-8")
