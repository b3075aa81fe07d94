"""The GRBL sender against the simulator over real links (pseudo-terminal and TCP)."""

from __future__ import annotations

import numpy as np
import pytest
from _senders_support import (
    FAST_TIMEOUTS,
    assert_exactly_once,
    assert_stopped_then_resumed_once,
    end_position,
    expected_after_resume,
    machine,
    texts,
    zigzag_program,
)

from gcode.senders.errors import (
    AlarmError,
    ControllerResetError,
    HandshakeError,
    JobCancelledError,
    LineRejectedError,
    LinkLostError,
    PreflightError,
)
from gcode.senders.grbl_sender import GrblSender, HoldChoice
from gcode.senders.grbl_stream import StreamMode
from gcode.senders.job import Job
from gcode.senders.journal import JobJournal, read_journal
from gcode.senders.preflight import preflight
from gcode.senders.serial_link import open_serial_link

#: Lines the handshake sends ($I and $#): the simulator's fault line numbers count them.
HANDSHAKE_LINES = 2


def connect(sim, **kw) -> GrblSender:
    sender = GrblSender(open_serial_link(sim.serial_url), timeouts=FAST_TIMEOUTS, **kw)
    sender.connect()
    return sender


@pytest.mark.parametrize("serial", ["pty", "tcp"])
def test_whole_job_runs_every_block_exactly_once_and_ends_at_the_program_end(
    simulator_factory, serial, tmp_path
):
    text = zigzag_program(150)
    job = Job.from_text(text, "zigzag.nc")
    preflight(job, machine())
    with simulator_factory(serial=serial) as sim:
        sender = connect(sim)
        progress = []
        sender.on_progress = progress.append
        with JobJournal(tmp_path / "job.log", job, mode="char-count", port=sim.serial_url) as j:
            result = sender.run(job, journal=j)
        sender.close()
        assert_exactly_once(sim.journal(), [ln.text for ln in job.lines])
        snap = sim.snapshot()
        assert np.allclose(snap["position"], end_position(text), atol=1e-6)
        assert snap["rx_dropped_bytes"] == 0 and snap["error"] == 0
    assert result.blocks_done == len(job.lines) and result.final_status.state == "Idle"
    assert progress[-1].done == progress[-1].total == len(job.lines)
    info = read_journal(tmp_path / "job.log")
    assert info.outcome == "done" and info.last_acked == job.last_line_number


def test_send_response_mode_and_check_mode(simulator_factory):
    job = Job.from_text(zigzag_program(30))
    with simulator_factory(serial="tcp") as sim:
        sender = connect(sim, mode=StreamMode.SEND_RESPONSE)
        report = sender.check(job)
        assert report.ok and report.lines == len(job.lines)
        assert sim.journal() == []  # check mode moves nothing
        sender.run(job)
        sender.close()
        assert_exactly_once(sim.journal(), [ln.text for ln in job.lines])


def test_check_mode_reports_every_rejected_line(simulator_factory):
    job = Job.from_text("G21 G90\nG0 X1 Y1\nG1 X2 A5 F100\nG1 X3 F100\nG5 X1\n")
    with simulator_factory(serial="pty") as sim:
        sender = connect(sim)
        report = sender.check(job)
        sender.close()
    assert [(e.line, e.code) for e in report.errors] == [(3, 20), (5, 20)]
    assert "G1X2A5F100" in str(report.errors[0])


def test_link_dropped_mid_job_then_resume_runs_every_block_exactly_once(
    simulator_factory, tmp_path
):
    job = Job.from_text(zigzag_program(120), "zigzag.nc")
    log = tmp_path / "job.log"
    with simulator_factory(
        serial="pty", faults=[f"drop-after-lines={HANDSHAKE_LINES + 60}"]
    ) as sim:
        sender = connect(sim)
        with JobJournal(log, job, mode="char-count", port=sim.serial_url) as j:
            with pytest.raises(LinkLostError, match="not resumed automatically") as info:
                sender.run(job, journal=j)
        sender.close()
        assert "last line answered" in str(info.value)
        assert read_journal(log).outcome == "link-lost"
        executed = texts(sim.journal())
        assert 0 < len(executed) < len(job.lines)
        # the user asks for the resume later: reconnect (the pty path changed), continue
        assert sim.wait_idle(5.0)
        sender = connect(sim)
        line = sender.resume_line_from_journal(job, read_journal(log))
        plan = sender.plan_resume(job, line)
        executed = texts(sim.journal())  # nothing ran while reconnecting
        with JobJournal(log, job, mode="char-count", port=sim.serial_url, start_line=line) as j:
            sender.run(job, resume=plan, journal=j)
        sender.close()
        assert_exactly_once(
            sim.journal(), expected_after_resume(job, executed, line, plan.preamble)
        )
        assert np.allclose(sim.snapshot()["position"], end_position(job.source), atol=1e-6)


def test_error_stops_at_that_line_and_names_it(simulator_factory):
    job = Job.from_text(zigzag_program(80, feed=3000.0))
    bad = job.lines[29]
    with simulator_factory(
        serial="tcp", speed="x20", faults=[f"error-at-line={HANDSHAKE_LINES + 30}:20"]
    ) as sim:
        sender = connect(sim)
        with pytest.raises(LineRejectedError) as info:
            sender.run(job)
        err = info.value
        assert err.line == bad.number and err.text == bad.text and err.code == 20
        assert (
            f"line {bad.number}" in str(err)
            and "error:20" in str(err)
            and "unsupported" in str(err)
        )
        # the fault fired once: resuming from the suggested line completes the job exactly once
        assert_stopped_then_resumed_once(sender, sim, job, err, good_lines=30)


def test_alarm_mid_job_no_hang_clear_report(simulator_factory):
    job = Job.from_text(zigzag_program(80))
    with simulator_factory(serial="pty", faults=[f"alarm-at-line={HANDSHAKE_LINES + 40}:1"]) as sim:
        sender = connect(sim)
        with pytest.raises(AlarmError) as info:
            sender.run(job)
        sender.close()
    err = info.value
    assert err.code == 1 and "ALARM:1 (hard limit" in str(err)
    assert err.line == job.lines[39].number and "re-home" in str(err)


def test_controller_restart_mid_job_is_detected_and_the_job_stops(simulator_factory):
    job = Job.from_text(zigzag_program(80))
    with simulator_factory(serial="tcp", faults=[f"restart-at-line={HANDSHAKE_LINES + 40}"]) as sim:
        sender = connect(sim)
        with pytest.raises(ControllerResetError, match="restarted during the job"):
            sender.run(job)
        received = sim.snapshot()["lines_received"]
        sender.close()
    # after the restart nothing more was sent than what was already on its way (128 bytes)
    assert received <= HANDSHAKE_LINES + 40 + 128 // 10 + 1


def test_soft_limit_violation_is_refused_before_sending(simulator_factory):
    job = Job.from_text("G21 G90\nG0 X10 Y10\nG1 X450 F1000\n", "far.nc")
    with simulator_factory(serial="tcp") as sim:
        with pytest.raises(PreflightError, match="line 3") as info:
            preflight(job, machine())
        assert info.value.issues[0].code.value == "soft-limit"
        assert sim.snapshot()["bytes_in"] == 0


def test_feed_hold_then_resume_completes_exactly_once(simulator_factory):
    job = Job.from_text(zigzag_program(100, feed=3000.0))
    holds = []
    with simulator_factory(serial="pty", speed="x20") as sim:
        sender = connect(sim)

        def progress(p):
            if p.done >= 30 and not holds:
                holds.append(p)
                sender.request_hold()

        def on_hold(p):
            holds.append(sim.snapshot()["state"])
            return HoldChoice.RESUME

        sender.on_progress = progress
        sender.run(job, on_hold=on_hold)
        sender.close()
        assert holds[1] == "Hold:0"  # the machine had stopped when asked
        assert_exactly_once(sim.journal(), [ln.text for ln in job.lines])


def test_feed_hold_then_cancel_then_resume_exactly_once(simulator_factory):
    job = Job.from_text(zigzag_program(100, feed=3000.0))
    with simulator_factory(serial="tcp", speed="x20") as sim:
        sender = connect(sim)
        sender.on_progress = lambda p: p.done >= 30 and sender.request_hold()
        with pytest.raises(JobCancelledError) as info:
            sender.run(job, on_hold=lambda p: "cancel")
        assert sim.snapshot()["alarm"] is None  # reset while held: no ALARM:3, position kept
        executed = texts(sim.journal())
        line = info.value.resume_line
        assert line is not None
        sender.on_progress = None
        plan = sender.plan_resume(job, line)
        sender.run(job, resume=plan)
        sender.close()
        assert_exactly_once(
            sim.journal(), expected_after_resume(job, executed, line, plan.preamble)
        )


def test_handshake_refuses_a_controller_in_alarm_unless_unlocked(simulator_factory):
    # no reset on connect (a TCP bridge, not an Arduino's DTR): the alarm survives
    with simulator_factory(serial="tcp", reset_on_connect=False) as sim:
        sim.call(lambda: sim.controller.raise_alarm(9))
        link = open_serial_link(sim.serial_url)
        with pytest.raises(HandshakeError, match="Alarm"):
            GrblSender(link, timeouts=FAST_TIMEOUTS).connect()
        link.close()
        sender = GrblSender(open_serial_link(sim.serial_url), timeouts=FAST_TIMEOUTS)
        assert sender.connect(unlock=True).state == "Idle"
        sender.close()


def test_handshake_fails_fast_on_a_silent_port(tmp_path):
    import os
    import pty

    master, slave = pty.openpty()
    path = os.ttyname(slave)
    try:
        sender = GrblSender(open_serial_link(path), timeouts=FAST_TIMEOUTS)
        with pytest.raises(HandshakeError, match="no status report and no banner"):
            sender.connect(boot_wait_s=0.3)
        sender.close()
    finally:
        os.close(master)
        os.close(slave)
