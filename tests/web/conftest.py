"""Fixtures of the browser tests: a real uvicorn server and Debian's chromium (Playwright).

The server runs in a thread on 127.0.0.1 (a free port), one thread worker, a temporary data
folder, and the built-in simulator as stream target, slowed so that a feed hold lands
while the program runs (:func:`_live_server.live_server`). Chromium is the system's
(``apt-get install chromium``; ``make test`` installs it); Playwright only drives it
(``playwright install`` is never needed).
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from _live_server import live_server

CHROMIUM = os.environ.get("CHROMIUM", "/usr/bin/chromium")
CHROMIUM_ARGS = ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync",
                 # WebGL on the CPU (SwiftShader): headless has no GPU
                 "--enable-unsafe-swiftshader"]
#: The simulator at 20x machine speed: the coarse job's program runs for a few seconds.
SIMULATOR_TARGET = "simulate:x20"


@dataclass
class Server:
    url: str
    data_dir: Path


@dataclass
class Browser:
    """One page and what its console said (errors, and exceptions the page did not catch)."""

    page: object
    errors: list[str] = field(default_factory=list)

    def take_errors(self) -> list[str]:
        errors, self.errors[:] = list(self.errors), []
        return errors


@pytest.fixture(scope="module")
def server(tmp_path_factory) -> Iterator[Server]:
    data_dir = tmp_path_factory.mktemp("web") / "data"
    with live_server(data_dir, stream_targets={"simulator": SIMULATOR_TARGET}) as (url, _app):
        yield Server(url, data_dir)


@pytest.fixture(scope="module")
def browser(server, tmp_path_factory) -> Iterator[Browser]:
    if not Path(CHROMIUM).is_file():
        pytest.skip(f"no chromium at {CHROMIUM} (apt-get install chromium; make test does)")
    sync_api = pytest.importorskip("playwright.sync_api",
                                   reason="playwright is a test extra: pip install -e '.[test]'")
    profile = tmp_path_factory.mktemp("chromium-profile")
    with sync_api.sync_playwright() as playwright:
        context = playwright.chromium.launch_persistent_context(
            str(profile), executable_path=CHROMIUM, headless=True, args=CHROMIUM_ARGS,
            viewport={"width": 1400, "height": 1000}, accept_downloads=False)
        try:
            page = context.new_page()
            page.set_default_timeout(15_000)
            seen = Browser(page)
            page.on("console", lambda m: seen.errors.append(
                f"{m.text} ({m.location.get('url', '')})") if m.type == "error" else None)
            page.on("pageerror", lambda e: seen.errors.append(f"uncaught: {e}"))
            page.goto(server.url + "/")
            page.wait_for_selector("body[data-ready=true]")
            yield seen
        finally:
            context.close()
    shutil.rmtree(profile, ignore_errors=True)
