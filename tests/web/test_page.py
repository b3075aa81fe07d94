"""The page at ``/`` in a real browser: upload, job, 3-D preview, report, streaming.

Screenshots of each step are saved in the test's ``tmp_path`` (``step-*.png``).
"""

from __future__ import annotations

import io
import re
import time
from pathlib import Path

import httpx
import numpy as np
import pytest
from PIL import Image

import toolpath

DEV_BLADE = Path(toolpath.__file__).parent / "data" / "dev_blade_15x142.csv"
#: Coarse settings: the dev blade's job takes seconds, its program a few hundred lines.
COARSE = {"scallop_mm": "0.3", "chord_tol_mm": "0.2", "fit_tol_mm": "0.05"}
JOB_TIMEOUT_MS = 90_000
BACKGROUND_RGB = (0xF3, 0xF5, 0xF7)  # preview.js BACKGROUND


def _shot(page, tmp_path: Path, name: str) -> None:
    page.screenshot(path=str(tmp_path / f"step-{name}.png"), full_page=True)


def _no_console_errors(browser) -> None:
    errors = browser.take_errors()
    assert not errors, "the page logged errors:\n" + "\n".join(errors)


def _fill_coarse(page, csv: Path, **fields: str) -> None:
    page.set_input_files("#f-file", str(csv))
    details = page.locator("details")
    if details.get_attribute("open") is None:
        page.click("summary")
    for name, value in {**COARSE, **fields}.items():
        page.fill(f"[name={name}]", value)


def _submit(page) -> str:
    """Click submit; the new job's id (its row is added at the top of the list)."""
    rows = page.locator("#jobs tbody tr").count()
    page.click("#submit")
    page.wait_for_function(f"document.querySelectorAll('#jobs tbody tr').length > {rows}")
    return page.locator("#jobs tbody tr").first.get_attribute("data-job")


def _error_next_to(page, field: str) -> str:
    return page.locator(f'.field:has([name="{field}"]) [data-error-for="{field}"]').inner_text()


def _canvas_pixels(page) -> np.ndarray:
    """The 3-D view as the user sees it (legend hidden), RGB."""
    page.evaluate("document.querySelector('.legend').hidden = true")
    png = page.locator("#viewport canvas").screenshot()
    page.evaluate("document.querySelector('.legend').hidden = false")
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=int)


def _last_program_point(program: str) -> dict[str, float]:
    """The modal X, Y, Z (and rotary) values after the program's last motion block."""
    position: dict[str, float] = {}
    for line in program.splitlines():
        code = re.sub(r"\(.*?\)|;.*", "", line).upper()
        for axis, value in re.findall(r"([XYZABC])\s*([-+]?\d*\.?\d+)", code):
            position[axis.lower()] = float(value)
    return position


def _readout(page) -> dict[str, float]:
    text = page.inner_text("#m-position")
    return {axis.lower(): float(v) for axis, v in re.findall(r"([XYZABC]) (-?\d+\.\d+)", text)}


@pytest.fixture(scope="module")
def finished(server, browser, tmp_path_factory) -> dict:
    """The dev blade uploaded through the form and run to the end: its job view."""
    page = browser.page
    shots = tmp_path_factory.mktemp("job")
    _fill_coarse(page, DEV_BLADE)
    job_id = _submit(page)
    _shot(page, shots, "1-submitted")
    page.wait_for_selector(f'#jobs tr[data-job="{job_id}"][data-state=done]',
                           timeout=JOB_TIMEOUT_MS)
    page.wait_for_selector("#viewport[data-state=ready]")
    return httpx.get(f"{server.url}/jobs/{job_id}").json()


def test_page_loads_from_the_package_alone(server, browser, tmp_path):
    page = browser.page
    _shot(page, tmp_path, "0-loaded")
    assert page.title() == "streamline-cam"
    machines = page.locator("#f-machine option").all_inner_texts()
    assert "grbl-router" in machines
    for url in page.evaluate("performance.getEntriesByType('resource').map(e => e.name)"):
        assert url.startswith(server.url), f"the page loaded {url} from elsewhere"
    _no_console_errors(browser)


def test_bad_uploads_show_the_service_message_next_to_the_field(server, browser, tmp_path):
    page = browser.page
    bad_csv = tmp_path / "letters.csv"
    bad_csv.write_text("section,x,y,z\n0,1,2,3\n0,a,2,3\n", encoding="utf-8")
    _fill_coarse(page, bad_csv)
    page.click("#submit")
    page.wait_for_function("document.querySelector('[data-error-for=file]').textContent")
    _shot(page, tmp_path, "1-bad-csv")
    assert _error_next_to(page, "file") == "letters.csv:3: 'a' is not a number"
    assert page.get_attribute("#f-file", "aria-invalid") == "true"

    _fill_coarse(page, DEV_BLADE, scallop_mm="0")
    page.click("#submit")
    page.wait_for_function("document.querySelector('[data-error-for=scallop_mm]').textContent")
    _shot(page, tmp_path, "2-scallop-zero")
    assert _error_next_to(page, "scallop_mm") == (
        "scallop_mm must be a finite length > 0 mm, got 0.0")
    assert _error_next_to(page, "file") == ""  # the earlier message is gone
    assert page.locator("#jobs tbody tr").count() == 0  # nothing was queued
    # the browser itself logs each refused request (422) as a console error; nothing else
    errors = browser.take_errors()
    assert errors and all("status of 422" in e and "/jobs/upload" in e for e in errors), errors
    page.fill("[name=scallop_mm]", COARSE["scallop_mm"])


def test_dev_blade_job_preview_report_and_plots(server, browser, finished, tmp_path):
    page = browser.page
    job_id = finished["id"]
    assert finished["state"] == "done" and page.get_attribute("#job", "data-job") == job_id
    stages = page.locator(f'#jobs tr[data-job="{job_id}"] .stage progress')
    assert stages.count() >= 5
    assert all(float(v) == 100 for v in stages.evaluate_all("bars => bars.map(b => b.value)"))
    page.locator("#viewport").scroll_into_view_if_needed()
    _shot(page, tmp_path, "1-done")

    # the 3-D view drew the surface and the passes in colour
    pixels = _canvas_pixels(page)
    drawn = np.any(np.abs(pixels - BACKGROUND_RGB) > 8, axis=2)
    assert drawn.mean() > 0.02, f"only {drawn.mean():.1%} of the canvas differs from background"
    r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    assert ((r > g + 60) & (r > b + 60)).sum() > 50, "no red (last) passes drawn"
    assert ((b > r + 60) & (b > g + 20)).sum() > 50, "no blue (first) passes drawn"

    # the tool follows the slider
    before = page.inner_text("#tool-readout")
    slider = page.locator("#tool-slider")
    middle = int(slider.get_attribute("max")) // 2
    assert middle > 10
    slider.evaluate(f"s => {{ s.value = {middle}; s.dispatchEvent(new Event('input')); }}")
    after = page.inner_text("#tool-readout")
    assert after != before and after.startswith(f"point {middle + 1} of ")
    page.wait_for_timeout(200)
    assert np.abs(_canvas_pixels(page) - pixels).sum() > 0, "the tool did not move"
    page.locator("#viewport").screenshot(path=str(tmp_path / "step-2-tool-moved.png"))

    # the report's figures, the verified ones among them
    report = httpx.get(f"{server.url}/jobs/{job_id}/report").json()
    verified = page.locator("#report tr[data-stage=verified]")
    assert verified.count() >= 5
    gouge = page.locator('#report tr[data-key="verify.max_gouge_mm"] td.num').inner_text()
    assert gouge == f"{report['verify']['max_gouge_mm']:.4f} mm"
    lines = page.locator('#report tr[data-key="program.lines"] td.num').inner_text()
    assert lines == str(report["program"]["lines"])

    # plots as images, downloads as links
    page.locator("#plots").scroll_into_view_if_needed()
    page.wait_for_function("[...document.querySelectorAll('#plots img')].length > 0 && "
                           "[...document.querySelectorAll('#plots img')]"
                           ".every(i => i.complete && i.naturalWidth > 0)", timeout=60_000)
    _shot(page, tmp_path, "3-report-and-plots")
    plots = page.locator("#plots figure").evaluate_all("fs => fs.map(f => f.dataset.plot)")
    assert {"deviation", "surface"} <= set(plots)
    links = dict(page.locator("#downloads a").evaluate_all(
        "links => links.map(a => [a.dataset.download, a.getAttribute('href')])"))
    assert {"gcode", "toolpath", "report"} <= set(links)
    assert httpx.get(server.url + links["gcode"]).text.rstrip().endswith("M30")
    _no_console_errors(browser)


def test_stream_to_the_simulator_with_hold_and_resume(server, browser, finished, tmp_path):
    page = browser.page
    job_id = finished["id"]
    panel = page.locator("#machine-panel")
    panel.scroll_into_view_if_needed()
    page.click("#m-stream")
    page.wait_for_selector("#machine-panel[data-stream-state=running]")
    page.wait_for_function("/X -?\\d/.test(document.querySelector('#m-position').textContent)")
    seen = {page.inner_text("#m-position")}
    deadline = time.monotonic() + 10
    while len(seen) < 3 and time.monotonic() < deadline:
        page.wait_for_timeout(100)
        seen.add(page.inner_text("#m-position"))
    assert len(seen) >= 3, f"the position readout did not move: {seen}"
    _shot(page, tmp_path, "1-streaming")
    # on a 3-axis machine the program's coordinates are the preview's: the tool is drawn there
    page.wait_for_selector("#viewport[data-machine=shown]")
    page.locator("#viewport").screenshot(path=str(tmp_path / "step-1-machine-tool.png"))

    # The answer to hold is kept back until the stream's event has said "held": an answer
    # taken while the machine still decelerated, arriving late, must not undo that.
    answers = []
    page.route("**/streams/*/hold", lambda route: answers.append((route, route.fetch())))
    page.click("#m-hold")
    page.wait_for_selector("#machine-panel[data-stream-state=held]")
    (route, answer), = answers
    with page.expect_response("**/streams/*/hold"):
        route.fulfill(response=answer)
    page.unroute("**/streams/*/hold")
    held_at, held_line = page.inner_text("#m-position"), page.inner_text("#m-line")
    page.wait_for_timeout(600)
    assert page.get_attribute("#machine-panel", "data-stream-state") == "held"
    assert (page.inner_text("#m-position"), page.inner_text("#m-line")) == (held_at, held_line)
    assert page.is_enabled("#m-resume") and not page.is_enabled("#m-hold")
    _shot(page, tmp_path, "2-held")

    page.click("#m-resume")
    page.wait_for_selector("#machine-panel[data-stream-state=done]", timeout=JOB_TIMEOUT_MS)
    _shot(page, tmp_path, "3-done")
    assert page.get_attribute("#viewport", "data-machine") == ""
    program = httpx.get(f"{server.url}/jobs/{job_id}/gcode").text
    end = _last_program_point(program)
    shown = _readout(page)
    assert set(shown) == set(end) and all(abs(shown[a] - end[a]) < 1e-3 for a in end), (
        shown, end)
    assert page.inner_text("#m-percent") == "100.0 %"
    assert page.inner_text("#m-alarm") == "none"
    stream = httpx.get(f"{server.url}/jobs/{job_id}").json()["streams"][-1]
    assert stream["state"] == "done" and stream["result"]["exactly_once"], stream

    # opened again, the page shows the job's last stream where it ended
    page.reload()
    page.wait_for_selector("body[data-ready=true]")
    page.click(f'#jobs tr[data-job="{job_id}"]')
    page.wait_for_selector("#machine-panel[data-stream-state=done]")
    assert _readout(page) == shown

    # a second stream, cancelled from the panel as soon as it runs (hold, then soft reset)
    page.click("#m-stream")
    page.wait_for_selector("#machine-panel[data-stream-state=running]")
    page.click("#m-cancel")
    page.wait_for_selector("#machine-panel[data-stream-state=cancelled]")
    _shot(page, tmp_path, "4-cancelled")
    assert page.is_enabled("#m-stream") and not page.is_enabled("#m-cancel")
    stream = httpx.get(f"{server.url}/jobs/{job_id}").json()["streams"][-1]
    assert stream["state"] == "cancelled", stream
    _no_console_errors(browser)


def test_cancel_a_job_from_the_list(server, browser, tmp_path):
    page = browser.page
    _fill_coarse(page, DEV_BLADE)
    job_id = _submit(page)
    row = page.locator(f'#jobs tr[data-job="{job_id}"]')
    row.locator("button.cancel").click()
    page.wait_for_selector(f'#jobs tr[data-job="{job_id}"][data-state=cancelled]')
    _shot(page, tmp_path, "1-cancelled")
    assert not row.locator("button.cancel").is_visible()
    assert httpx.get(f"{server.url}/jobs/{job_id}").json()["state"] == "cancelled"
    _no_console_errors(browser)
