"""Resume planning, locating a stop on the path, the journal, the pre-flight (no link)."""

from __future__ import annotations

import pytest
from _senders_support import machine, zigzag_program

from gcode.senders.errors import PreflightError, ResumeError
from gcode.senders.job import Job
from gcode.senders.journal import JobJournal, read_journal
from gcode.senders.preflight import preflight
from gcode.senders.progress import Progress, ProgressBar, format_progress
from gcode.senders.resume import (
    locate_resume_line,
    modal_state_before,
    plan_resume,
    safe_resume_line,
)

PROGRAM = """\
G20 G91 G18 (inch, incremental, ZX plane)
G0 Y1
G90
G0 Z0.5
G0 X0 Y0
M4 S8000
M8
G1 Z-0.1 F10
G1 X1 F40
G2 X2 Z-0.1 I0.5 K0
G1 X3
"""


def test_plan_restores_units_plane_distance_spindle_coolant_and_feed():
    job = Job.from_text(PROGRAM)
    plan = plan_resume(job, 11)
    texts = [ln.text for ln in plan.preamble]
    assert texts[0] == "G21G90G94G17G54"  # known baseline first
    assert texts[1] == "G0Z12.7"  # retract to the program's top (0.5 in), in mm
    assert texts[2] == "G0X50.8Y0"  # move over to where line 11 starts (X 2 in)
    assert texts[3:5] == ["M4S8000", "M8"]
    assert texts[5] == "G0Z-1.54"  # rapid to 1 mm above the start
    assert texts[6] == "G1Z-2.54F254"  # plunge at the program's plunge feed (10 in/min)
    assert texts[7:] == ["G18", "G20", "G2F40"]  # modal state at line 11, feed in inch/min
    assert all(ln.number == 0 for ln in plan.preamble)


def test_resume_refuses_mid_arc_and_names_a_safe_line():
    job = Job.from_text(PROGRAM)
    with pytest.raises(ResumeError, match=r"line 10 is an arc .* resume from line 9") as info:
        plan_resume(job, 10)
    assert info.value.resume_line == 9
    assert safe_resume_line(job, 10) == 9 and safe_resume_line(job, 11) == 11


def test_resume_never_retracts_downward_and_refuses_lines_outside():
    job = Job.from_text(zigzag_program(10))
    plan = plan_resume(job, 8, current_z_mm=20.0)
    assert plan.preamble[1].text == "G0Z20"
    with pytest.raises(ResumeError, match="line 99"):
        plan_resume(job, 99)
    with pytest.raises(ResumeError, match="below the start"):
        plan_resume(job, 8, clearance_z_mm=-5.0)


def test_modal_state_before_a_line():
    st = modal_state_before(Job.from_text(PROGRAM), 9)
    assert st.feed == pytest.approx(254.0) and st.flood and int(st.spindle) == 4


def test_locate_finds_the_first_line_that_did_not_complete():
    job = Job.from_text(zigzag_program(10))
    # line 6 is G1 X0.5 ...: the start of the zigzag; ends listed by the parser
    ends = {ln.number: ln for ln in job.lines}
    assert ends[6].text.startswith("G1X0.5")
    # at the end of line 8: resume at line 9
    assert locate_resume_line(job, (1.5, 0.5, -1.0), first_line=6, last_line=12) == 9
    # half way along line 9 (X1.5 Y0.5 to X2 Y1.5): resume at line 9
    mid = (1.75, (0.5 + 1.5) / 2, -1.0)
    assert locate_resume_line(job, mid, first_line=6, last_line=12) == 9
    # nowhere near the path: unknown
    assert locate_resume_line(job, (50.0, 50.0, 0.0), first_line=6, last_line=12) is None


def test_journal_summarizes_the_last_run(tmp_path):
    job = Job.from_text("G0X1\nG0X2\nG0X3\nG0X4\n", "p.nc")
    path = tmp_path / "job.log"
    with JobJournal(path, job, mode="char-count", port="x") as j:
        for ln in job.lines:
            j.sent(ln)
        j.acked(job.lines[0])
        j.end("link-lost", resume_line=None)
    with JobJournal(path, job, mode="char-count", port="x", start_line=2) as j:
        j.sent(job.lines[1])
        j.acked(job.lines[1])
        j.sent(job.lines[2])
        j.rejected(job.lines[2], 20)
        j.end("error", resume_line=3)
    info = read_journal(path)
    assert info.start_line == 2 and info.last_acked == 2 and info.last_sent == 3
    assert info.outcome == "error" and info.resume_line == 3 and info.sent_unanswered == ()


def test_journal_torn_last_line_from_a_crash_is_ignored(tmp_path):
    job = Job.from_text("G0X1\nG0X2\n")
    path = tmp_path / "job.log"
    j = JobJournal(path, job, mode="char-count", port="x")
    j.sent(job.lines[0])
    j.acked(job.lines[0])
    j.flush()
    with path.open("a") as f:
        f.write('{"e":"sent","li')  # the process died mid-write
    info = read_journal(path)
    assert info.outcome is None and info.last_acked == 1
    with pytest.raises(ValueError, match="no job record"):
        (tmp_path / "empty.log").write_text("\n")
        read_journal(tmp_path / "empty.log")


def test_preflight_refuses_soft_limits_and_unsupported_words_naming_lines():
    job = Job.from_text("G21 G90\nG0 X10 Y10 Z5\nG1 X500 F1000\nG1 A5\n", "bad.nc")
    with pytest.raises(PreflightError) as info:
        preflight(job, machine())
    lines = sorted({i.line for i in info.value.issues})
    assert lines == [3, 4] and "bad.nc refused before sending" in str(info.value)
    long_line = "G1" + "X1.000" * 14
    with pytest.raises(PreflightError, match=r"line-too-long|line buffer"):
        preflight(Job.from_text(f"G21\n{long_line}\n"), machine())
    assert preflight(Job.from_text(zigzag_program(5)), machine()) == []


def test_progress_record_and_text():
    p = Progress(done=3, total=4, elapsed_s=1.5, line=9, state="Run")
    assert p.percent == 75.0 and p.eta_s == pytest.approx(0.5)
    assert (
        format_progress(p, width=4) == "[###.]  75%  3/4 blocks  2 blocks/s  ETA 0:00  line 9  Run"
    )
    import io

    buf = io.StringIO()
    bar = ProgressBar(buf, plain_interval_s=0.0)
    bar(p)
    bar.close()
    assert "3/4 blocks" in buf.getvalue()
