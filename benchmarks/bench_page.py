"""Benchmark: the web page at ``/`` in Debian's headless chromium, as a user opens it.

Starts ``toolpath serve`` (a free loopback port, a temporary data folder), runs one coarse
job on the bundled dev blade, then drives ``/usr/bin/chromium`` through Playwright and prints

* the page, ready to use (``body[data-ready]``: modules, three.js, the job list from the
  event stream), in a fresh browser profile (cold) and reloaded (warm), beside the time the
  same browser takes to show the service's ``/health`` JSON (the baseline: one request, no
  page), and their ratio; the issue asks for under 1 s;
* a 250,000-point toolpath in the 3-D view: the preview the endpoint sends (thinned to its
  default budget) and the whole 250,000 points (the page's own guard thins them), the time
  until drawn and the mean frame while the tool slider moves (responsiveness).

The big toolpath is the synthetic one of ``bench_preview.py``, handed to the page in place of
the job's own preview. Run: ``python benchmarks/bench_page.py`` (needs chromium and the test
extra's playwright).
"""

from __future__ import annotations

import json
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx
from bench_preview import Sheet, synthetic

from streamline_cam.service.preview import DEFAULT_MAX_POINTS, preview
from toolpath.paper_examples import bundled_data_path

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--enable-unsafe-swiftshader"]
COARSE = {"scallop_mm": "0.3", "chord_tol_mm": "0.2", "fit_tol_mm": "0.05"}
JOB_TIMEOUT_S = 300.0
REPEAT = 5
SLIDER_MOVES = 20


def _serve(data_dir: Path) -> tuple[subprocess.Popen, str]:
    """``toolpath serve`` on a free loopback port; its process and base URL."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "streamline_cam.cli", "serve", "--port", "0", "--data-dir",
         str(data_dir), "--workers", "1", "--executor", "thread", "--log-level", "warning"],
        stdout=subprocess.PIPE, text=True)
    banner = proc.stdout.readline()
    found = re.search(r"http://127\.0\.0\.1:\d+", banner)
    if not found:
        proc.kill()
        raise SystemExit(f"toolpath serve did not start: {banner!r}")
    return proc, found.group(0)


def _coarse_job(url: str) -> None:
    """Upload the dev blade and wait until its job is done."""
    with httpx.Client(base_url=url, timeout=30.0) as client:
        blade = bundled_data_path("dev_blade_15x142.csv")
        job = client.post("/jobs/upload", data=COARSE,
                          files={"file": (blade.name, blade.read_bytes(), "text/csv")}).json()
        deadline = time.monotonic() + JOB_TIMEOUT_S
        while (state := client.get(f"/jobs/{job['id']}").json()["state"]) != "done":
            if state in ("failed", "cancelled") or time.monotonic() > deadline:
                raise SystemExit(f"the coarse job ended {state}")
            time.sleep(0.5)


def _median_ms(run) -> float:
    times = []
    for _ in range(REPEAT):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return 1e3 * statistics.median(times)


def _big_preview(page, body: str) -> tuple[float, float]:
    """Show ``body`` as the job's preview: ms until drawn, mean ms per slider frame."""
    page.unroute(re.compile(r"/jobs/[^/]+/preview"))
    page.route(re.compile(r"/jobs/[^/]+/preview"),
               lambda route: route.fulfill(status=200, content_type="application/json",
                                           body=body))
    page.reload()
    page.wait_for_selector("body[data-ready=true]")
    start = time.perf_counter()
    page.locator("#jobs tbody tr").first.click()
    page.wait_for_selector("#viewport[data-state=ready]", timeout=60_000)
    shown_ms = 1e3 * (time.perf_counter() - start)
    frame_ms = page.evaluate("""async (moves) => {
        const slider = document.querySelector('#tool-slider');
        const start = performance.now();
        for (let i = 0; i < moves; i++) {
          slider.value = Math.round((i + 1) * slider.max / moves);
          slider.dispatchEvent(new Event('input'));
          await new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)));
        }
        return (performance.now() - start) / moves; }""", SLIDER_MOVES)
    return shown_ms, frame_ms


def main() -> None:
    from playwright.sync_api import sync_playwright

    path = synthetic(250_000)
    bodies = {f"endpoint's ({DEFAULT_MAX_POINTS} budget)":
              json.dumps(preview(Sheet(), path, max_points=DEFAULT_MAX_POINTS)),
              "whole (250000 points)": json.dumps(preview(Sheet(), path, max_points=250_000))}
    with tempfile.TemporaryDirectory(prefix="bench-page-") as folder:
        proc, url = _serve(Path(folder) / "data")
        try:
            _coarse_job(url)
            with sync_playwright() as playwright:
                context = playwright.chromium.launch_persistent_context(
                    str(Path(folder) / "profile"), executable_path=CHROMIUM, headless=True,
                    args=CHROMIUM_ARGS, viewport={"width": 1400, "height": 1000})
                page = context.new_page()
                start = time.perf_counter()
                page.goto(url + "/")
                page.wait_for_selector("body[data-ready=true]")
                cold_ms = 1e3 * (time.perf_counter() - start)
                health_ms = _median_ms(lambda: page.goto(url + "/health"))
                warm_ms = _median_ms(lambda: (page.goto(url + "/"),
                                              page.wait_for_selector("body[data-ready=true]")))
                print(f"toolpath serve at {url}; {CHROMIUM} headless")
                print(f"{'what':<52} {'ms':>8} {'x /health':>10}")
                print(f"{'/health JSON (baseline, median of 5)':<52} {health_ms:>8.0f} {1:>10.1f}")
                print(f"{'page ready, first open (fresh profile)':<52} {cold_ms:>8.0f} "
                      f"{cold_ms / health_ms:>10.1f}")
                print(f"{'page ready, reopened (median of 5)':<52} {warm_ms:>8.0f} "
                      f"{warm_ms / health_ms:>10.1f}")
                for label, body in bodies.items():
                    shown_ms, frame_ms = _big_preview(page, body)
                    print(f"{'250k toolpath, ' + label + ' drawn':<52} {shown_ms:>8.0f} "
                          f"{shown_ms / health_ms:>10.1f}")
                    print(f"{'  then per slider frame (mean of 20)':<52} {frame_ms:>8.1f}")
                context.close()
        finally:
            proc.terminate()
            proc.wait(timeout=30)


if __name__ == "__main__":
    main()
