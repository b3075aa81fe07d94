"""``toolpath send`` against the simulator: success, refusal, resume, Ctrl-C = hold + prompt."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

from _senders_support import assert_exactly_once, expected_after_resume, texts, zigzag_program

from gcode.senders.job import Job
from gcode.senders.journal import read_journal
from streamline_cam.cli import main


def _write(tmp_path, text: str, name: str = "part.nc"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_send_streams_the_file_and_journals_it(simulator_factory, tmp_path, capsys):
    prog = _write(tmp_path, zigzag_program(60))
    log = tmp_path / "job.log"
    with simulator_factory(serial="pty") as sim:
        code = main(["send", str(prog), "--port", sim.serial_url, "--journal", str(log), "--check"])
        assert code == 0
        job = Job.from_file(prog)
        assert_exactly_once(sim.journal(), [ln.text for ln in job.lines])
    err = capsys.readouterr().err
    n = len(Job.from_file(prog).lines)
    assert "connected: Grbl 1.1h" in err and f"check mode: {n} lines accepted" in err
    assert f"done: {n} blocks" in err
    assert read_journal(log).outcome == "done"


def test_send_refuses_a_program_beyond_soft_limits_before_connecting(tmp_path, capsys):
    prog = _write(tmp_path, "G21 G90\nG0 X10 Y10\nG1 X450 F1000\n")
    code = main(["send", str(prog), "--port", "socket://127.0.0.1:9"])  # nothing listens there
    assert code == 1
    err = capsys.readouterr().err
    assert f"{prog}:3:" in err and "soft-limit" in err and "refused before sending" in err


def test_send_over_modbus(simulator_factory, tmp_path, capsys):
    prog = _write(tmp_path, zigzag_program(40))
    with simulator_factory(serial=None, modbus="tcp") as sim:
        url = f"tcp://127.0.0.1:{sim.endpoints.modbus_port}"
        assert main(["send", str(prog), "--modbus", url, "--no-progress"]) == 0
        assert len(sim.journal()) == len(Job.from_file(prog).lines)
    assert "connected: Modbus register map 1" in capsys.readouterr().err


def test_send_after_a_lost_link_resumes_only_when_asked(simulator_factory, tmp_path, capsys):
    prog = _write(tmp_path, zigzag_program(100))
    log = tmp_path / "job.log"
    job = Job.from_file(prog)
    with simulator_factory(serial="tcp", faults=["drop-after-lines=50"]) as sim:
        args = ["send", str(prog), "--port", sim.serial_url, "--journal", str(log), "--no-progress"]
        assert main(args) == 1
        err = capsys.readouterr().err
        assert "not resumed automatically" in err and "--resume-from" in err
        assert sim.wait_idle(5.0)
        executed = texts(sim.journal())
        assert main([*args, "--resume-from", "journal"]) == 0
        err = capsys.readouterr().err
        line = int(err.split("resuming at line ")[1].split(":")[0])
        # the preamble the CLI printed is what the controller ran before line N
        preamble_texts = err.split("plunge, then: ")[1].splitlines()[0].split()
        from gcode.senders.job import JobLine

        preamble = [JobLine(0, t) for t in preamble_texts]
        assert_exactly_once(sim.journal(), expected_after_resume(job, executed, line, preamble))


def test_ctrl_c_is_a_feed_hold_and_a_prompt_then_resume(simulator_factory, tmp_path):
    prog = _write(tmp_path, zigzag_program(150, feed=3000.0))
    with simulator_factory(serial="tcp", speed="x4") as sim:
        cmd = [
            sys.executable,
            "-c",
            "import sys; from streamline_cam.cli import main; sys.exit(main(sys.argv[1:]))",
            "send",
            str(prog),
            "--port",
            sim.serial_url,
        ]
        proc = subprocess.Popen(
            cmd,
            stdin=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={**os.environ, "PYTHONUNBUFFERED": "1"},
        )
        try:
            assert sim.wait_for(lambda s: len(s.controller.journal) > 20, timeout_s=30.0)
            proc.send_signal(signal.SIGINT)
            assert sim.wait_for(lambda s: s.controller.hold_complete, timeout_s=10.0)
            time.sleep(0.2)
            assert proc.poll() is None, "Ctrl-C killed the sender"
            held_at = len(sim.journal())
            proc.stdin.write("resume\n")
            proc.stdin.flush()
            _, err = proc.communicate(timeout=60)
        finally:
            if proc.poll() is None:
                proc.kill()
        assert proc.returncode == 0, err
        n = len(Job.from_file(prog).lines)
        assert "machine held. [r]esume or [c]ancel?" in err and f"done: {n} blocks" in err
        assert held_at < n
        assert_exactly_once(sim.journal(), [ln.text for ln in Job.from_file(prog).lines])
