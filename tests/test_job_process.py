"""A job's process keeps freed arrays for reuse, its idle threads asleep (issue 27)."""

import os
import platform
import subprocess
import sys
from pathlib import Path

import pytest

from streamline_cam import job_process
from streamline_cam.job_process import as_job, prepare_job_process, release_freed_memory
from verification.pages import madvise_switch

ROOT = Path(__file__).resolve().parents[1]


def test_numpy_asks_for_no_huge_pages_and_openmp_waits_passively():
    prepare_job_process()
    switch = madvise_switch()
    assert switch is not None and switch(False) is False  # returns the setting it replaced
    assert os.environ["OMP_WAIT_POLICY"]  # PASSIVE unless the environment chose


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="mallopt is glibc's")
def test_glibc_takes_the_malloc_settings():
    assert prepare_job_process() is True


def test_a_job_hands_its_freed_memory_back_when_it_ends_even_by_an_error(monkeypatch):
    calls = []
    monkeypatch.setattr(job_process, "release_freed_memory", lambda: calls.append("released"))
    # a long-lived process (a test before may have run a one-shot command in this one)
    monkeypatch.setattr(job_process, "_freezes_at_exit", False)

    @as_job
    def failing_job():
        calls.append("ran")
        raise ValueError("bad input")

    with pytest.raises(ValueError, match="bad input"):
        failing_job()
    assert calls == ["ran", "released"]


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="malloc_trim is glibc's")
def test_glibc_trims_freed_memory():
    assert release_freed_memory() is True


def test_no_c_library_calls_off_linux(monkeypatch):
    monkeypatch.setattr(job_process.sys, "platform", "win32")
    assert job_process.release_freed_memory() is False
    assert job_process._mallopt(-3, 1024) is False


def _exit_of(code: str) -> list[str]:
    """What a Python process running ``code`` prints, through its exit handlers."""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr
    return done.stdout.strip().split("\n")


def test_a_one_shot_command_exits_without_collecting_what_it_loaded(tmp_path):
    # an exit handler registered before the command's runs after its own: by then every
    # object is frozen, so the interpreter's exit does not walk them again (issue 27)
    program = tmp_path / "part.nc"
    program.write_text("G21 G90\nG1 X1 Y2 F100\nM2\n", encoding="ascii")
    code = ("import atexit, gc\n"
            "atexit.register(lambda: print('frozen', gc.get_freeze_count() > 0))\n"
            "from streamline_cam.cli import main\n"
            f"main(['gcode-info', {str(program)!r}])\n"
            "print('running', gc.get_freeze_count())\n")
    printed = _exit_of(code)
    assert printed[-2:] == ["running 0", "frozen True"]


def test_a_job_in_a_long_lived_process_leaves_the_exit_as_python_does(tmp_path):
    # a service or library caller: an object kept alive only by a reference cycle is still
    # finalised at exit (its file flushed), which a frozen exit would skip
    out = tmp_path / "held.bin"
    code = ("from streamline_cam.job_process import as_job, prepare_job_process\n"
            "prepare_job_process()\n"
            "as_job(lambda: None)()\n"
            "class Holder: pass\n"
            "h = Holder(); h.me = h\n"
            f"h.out = open({str(out)!r}, 'wb'); h.out.write(b'x' * 100)\n"
            "print('running')\n")
    assert _exit_of(code) == ["running"]
    assert out.read_bytes() == b"x" * 100


def test_a_one_shot_process_leaves_the_freed_memory_to_its_exit(tmp_path):
    # issue 27: the trim after the job only costs time where the exit hands the memory
    # back; a long-lived process (above) still trims after every job
    code = ("from streamline_cam import job_process\n"
            "calls = []\n"
            "job_process.release_freed_memory = lambda: calls.append('released')\n"
            "job_process.as_job(lambda: None)()\n"
            "print('long-lived', calls)\n"
            "job_process.freeze_at_exit()\n"
            "job_process.as_job(lambda: None)()\n"
            "print('one-shot', calls)\n")
    assert _exit_of(code) == ["long-lived ['released']", "one-shot ['released']"]
