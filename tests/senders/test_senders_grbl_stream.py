"""Byte-level tests of the sans-IO GRBL stream: recorded controller answers, no link."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gcode.senders.grbl_messages import (
    AlarmPush,
    ErrorResponse,
    Feedback,
    Ok,
    StatusReport,
    Unknown,
    Welcome,
    error_text,
    parse_message,
)
from gcode.senders.grbl_stream import (
    AlarmRaised,
    ControllerReset,
    GrblStream,
    LineAcked,
    LineRejected,
    LineSent,
    StatusUpdate,
    StreamMode,
    TimedOut,
    Timeouts,
    Unexpected,
)
from gcode.senders.job import Job, JobLine


def _lines(*texts: str) -> list[JobLine]:
    return [JobLine.of(i + 1, t) for i, t in enumerate(texts)]


def _kinds(events) -> list[str]:
    return [type(e).__name__ for e in events]


# ------------------------------------------------------------------ messages
@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("ok", Ok()),
        ("error:22", ErrorResponse(22)),
        ("ALARM:2", AlarmPush(2)),
        ("Grbl 1.1h ['$' for help]", Welcome("1.1h")),
        ("[MSG:Reset to continue]", Feedback("MSG", "Reset to continue")),
        ("[OPT:V,15,128]", Feedback("OPT", "V,15,128")),
        ("error:x", Unknown("error:x")),
    ],
)
def test_messages_parse_to_records(text, expected):
    assert parse_message(text) == expected


def test_status_report_fields_any_order_and_optional():
    r = parse_message("<Run|WPos:1.000,-2.500,3.000|FS:500,12000|Ln:77|WCO:0.000,0.000,1.000>")
    assert isinstance(r, StatusReport)
    assert r.state == "Run" and r.work_position == (1.0, -2.5, 3.0)
    assert r.machine_position is None and r.line_number == 77
    assert r.feed_mm_per_min == 500.0 and r.spindle_rpm == 12000.0
    assert r.moving and not r.hold_complete
    h = parse_message("<Hold:1|MPos:0,0,0|Bf:3,100|FS:10,0>")
    assert h.moving and h.planner_free == 3 and h.rx_free == 100
    assert parse_message("<Hold:0|MPos:0,0,0|FS:0,0>").hold_complete


def test_error_meanings_name_the_problem():
    assert "unsupported" in error_text(20)
    assert error_text(999) == "unknown error"


# ------------------------------------------------------------------ character counting
def test_char_counting_fills_the_128_byte_buffer_and_no_more():
    # 9-byte lines (8 chars + \n): 14 fit in 128 bytes, the 15th does not
    lines = [JobLine.of(i, f"G1X{i:05d}") for i in range(1, 31)]
    s = GrblStream(lines, status_interval_s=0.0)
    out = s.outgoing(0.0)
    assert len(out) == 14 * 9 and s.inflight_bytes == 126
    s.receive(b"ok\r\n", 0.01)
    assert s.outgoing(0.01) == lines[14].data  # one answer frees room for exactly one line
    assert s.inflight_bytes == 126
    assert [e.line.number for e in s.pop_events() if isinstance(e, LineAcked)] == [1]


def test_send_response_sends_one_line_at_a_time():
    s = GrblStream(_lines("G0X1", "G0X2"), mode=StreamMode.SEND_RESPONSE, status_interval_s=0.0)
    assert s.outgoing(0.0) == b"G0X1\n"
    assert s.outgoing(0.0) == b""
    s.receive(b"ok\r\n", 0.0)
    assert s.outgoing(0.0) == b"G0X2\n"


def test_eeprom_and_dollar_lines_go_alone():
    s = GrblStream(_lines("G0X1", "$110=500", "G0X2"), status_interval_s=0.0)
    assert s.outgoing(0.0) == b"G0X1\n"  # the $ line waits for G0X1's answer
    s.receive(b"ok\r\n", 0.0)
    assert s.outgoing(0.0) == b"$110=500\n"
    assert s.outgoing(0.0) == b""  # nothing after it until it is answered
    s.receive(b"ok\r\n", 0.0)
    assert s.outgoing(0.0) == b"G0X2\n"


def test_answers_split_across_reads_are_assembled():
    s = GrblStream(_lines("G0X1", "G0X2"), status_interval_s=0.0)
    s.outgoing(0.0)
    for chunk in (b"o", b"k\r", b"\nerr", b"or:2", b"0\r\n"):
        s.receive(chunk, 0.0)
    ev = s.pop_events()
    assert _kinds(ev) == ["LineSent", "LineSent", "LineAcked", "LineRejected"]
    assert ev[-1].line.text == "G0X2" and ev[-1].code == 20


def test_real_time_bytes_go_first_and_are_not_counted():
    s = GrblStream(_lines("G0X1"), status_interval_s=0.2)
    s.feed_hold(0.0)
    out = s.outgoing(0.0)
    assert out == b"!?"  # hold and a status query; no line while holding
    assert s.inflight_bytes == 0
    s.cycle_start()
    assert s.outgoing(0.05) == b"~G0X1\n"


def test_status_polling_at_most_5_hz_with_one_query_outstanding():
    s = GrblStream(_lines(), status_interval_s=0.2)
    assert s.outgoing(0.0) == b"?"
    assert s.outgoing(0.5) == b""  # the first is unanswered: never a second '?'
    s.receive(b"<Idle|MPos:0.000,0.000,0.000|FS:0,0>\r\n", 0.5)
    assert s.outgoing(0.5) == b"?"  # the period had passed
    s.receive(b"<Idle|MPos:0.000,0.000,0.000|FS:0,0>\r\n", 0.51)
    assert s.outgoing(0.6) == b""  # 0.2 s period
    assert s.outgoing(0.7) == b"?"


# ------------------------------------------------------------------ pushes and failures
def test_error_answers_the_oldest_line():
    s = GrblStream(_lines("G0X1", "G1A5", "G0X3"), status_interval_s=0.0)
    s.outgoing(0.0)
    s.receive(b"ok\r\nerror:20\r\n", 0.0)
    rejected = [e for e in s.pop_events() if isinstance(e, LineRejected)]
    assert [(e.line.number, e.line.text, e.code) for e in rejected] == [(2, "G1A5", 20)]
    assert [ln.number for ln in s.inflight] == [3]


def test_alarm_drops_every_unanswered_line_and_stops():
    s = GrblStream(_lines("G0X1", "G0X900", "G0X3"), status_interval_s=0.2)
    s.outgoing(0.0)
    s.receive(b"ok\r\nALARM:2\r\n[MSG:Reset to continue]\r\n", 0.0)
    alarm = next(e for e in s.pop_events() if isinstance(e, AlarmRaised))
    assert alarm.code == 2 and alarm.suspect.text == "G0X900"
    assert [ln.number for ln in alarm.lost] == [2, 3]
    assert s.inflight == () and not s.sending and not s.polling
    assert s.outgoing(5.0) == b""  # no '?' after a critical alarm: it would never be answered


def test_unasked_banner_is_a_controller_reset_with_lost_lines():
    s = GrblStream(_lines("G0X1", "G0X2"), status_interval_s=0.0)
    s.outgoing(0.0)
    s.receive(b"ok\r\n\r\nGrbl 1.1h ['$' for help]\r\n", 0.0)
    reset = next(e for e in s.pop_events() if isinstance(e, ControllerReset))
    assert not reset.expected and [ln.text for ln in reset.lost] == ["G0X2"]
    assert not s.sending


def test_asked_reset_is_expected():
    s = GrblStream(_lines("G0X1"), status_interval_s=0.0)
    s.outgoing(0.0)
    s.soft_reset(0.0)
    assert s.outgoing(0.0) == b"\x18"
    s.receive(b"\r\nGrbl 1.1h ['$' for help]\r\n", 0.1)
    reset = next(e for e in s.pop_events() if isinstance(e, ControllerReset))
    assert reset.expected and s.inflight == ()


def test_ok_with_nothing_outstanding_is_reported():
    s = GrblStream(_lines(), status_interval_s=0.0)
    s.receive(b"ok\r\n", 0.0)
    assert _kinds(s.pop_events()) == ["Unexpected"]


# ------------------------------------------------------------------ bounded waits (virtual time)
T = Timeouts(status_reply_s=2.0, lost_line_s=1.0, stall_s=10.0, hold_s=5.0, reset_s=3.0)


def test_unanswered_status_query_is_counted_and_asked_again_not_an_error():
    # grbl does not promise a report (issue 25): a missing one is counted, polling goes on
    s = GrblStream(_lines(), status_interval_s=0.2, timeouts=T)
    assert s.outgoing(0.0) == b"?"
    s.check(1.9)
    assert s.outgoing(1.9) == b""  # still outstanding: never a second '?'
    assert s.deadline(1.9) == pytest.approx(2.0)
    s.check(2.1)
    assert s.pop_events() == [] and s.status_missed == 1 and s.polling
    assert s.outgoing(2.1) == b"?"
    s.receive(b"<Idle|MPos:0.000,0.000,0.000|FS:0,0>\r\n", 2.15)
    assert s.status_queries == 2 and s.status_missed == 1


def test_asking_at_once_still_polls_at_most_5_hz():
    s = GrblStream(_lines(), status_interval_s=0.0)
    s.polling = True  # as the sender does when it needs a report
    s.query_status(0.0)
    assert s.outgoing(0.0) == b"?"
    s.receive(b"<Idle|MPos:0.000,0.000,0.000|FS:0,0>\r\n", 0.01)
    s.query_status(0.02)
    assert s.outgoing(0.1) == b""
    assert s.outgoing(0.2) == b"?"


def test_silence_with_lines_outstanding_is_reported_but_answers_keep_it_alive():
    s = GrblStream(_lines(*[f"G1X{i}F100" for i in range(1, 40)]), status_interval_s=0.2,
                   timeouts=T)  # fmt: skip
    s.outgoing(0.0)
    for k in range(1, 25):  # answers trickle in, no report ever comes
        s.receive(b"ok\r\n", k * 1.0)
        s.outgoing(k * 1.0)
        s.check(k * 1.0)
    assert not any(isinstance(e, TimedOut) for e in s.pop_events())
    assert s.status_missed >= 5
    s.check(24.0 + 10.5)
    (ev,) = [e for e in s.pop_events() if isinstance(e, TimedOut)]
    assert ev.what == "silent" and "no answer, report or message for 10 s" in ev.detail
    assert "status queries went unanswered" in ev.detail


def test_end_of_job_is_idle_with_an_empty_planner_after_the_last_answer_no_m2_needed():
    s = GrblStream(_lines("G1X1F100", "G1X2"), status_interval_s=0.2, timeouts=T)
    s.planner_blocks = 15
    s.outgoing(0.0)
    s.receive(b"<Idle|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0>\r\nok\r\nok\r\n", 0.01)
    assert s.finished and not s.ended  # the report came before the answers
    s.expect_end(0.02)
    assert s.outgoing(0.1) == b""  # at most 5 Hz
    assert s.outgoing(0.21) == b"?"
    s.receive(b"<Run|MPos:1.500,0.000,0.000|Bf:14,128|FS:100,0>\r\n", 0.22)
    assert not s.ended
    assert s.outgoing(0.42) == b"?"
    s.receive(b"<Idle|MPos:2.000,0.000,0.000|Bf:14,128|FS:0,0>\r\n", 0.43)
    assert not s.ended  # a block still queued
    s.outgoing(0.63)
    s.receive(b"<Check|MPos:2.000,0.000,0.000|Bf:15,128|FS:0,0>\r\n", 0.64)
    assert s.ended and s.end_status.machine_position == (2.0, 0.0, 0.0)


def test_end_of_job_wait_is_bounded_when_reports_show_no_motion():
    s = GrblStream(_lines("G1X1F100"), status_interval_s=0.2, timeouts=T)
    s.outgoing(0.0)
    s.receive(b"ok\r\n", 0.1)
    s.expect_end(0.1)
    for k in range(1, 25):  # a controller stuck in Door: it answers, it never ends
        s.receive(b"<Door:0|MPos:1.000,0.000,0.000|FS:0,0>\r\n", k * 0.5)
        s.check(k * 0.5)
    (ev,) = [e for e in s.pop_events() if isinstance(e, TimedOut)]
    assert ev.what == "stall" and "reports Door" in ev.detail and not s.ended


def test_end_of_job_wait_is_bounded_by_the_controllers_silence():
    s = GrblStream(_lines("G1X1F100"), status_interval_s=0.2, timeouts=T)
    s.outgoing(0.0)
    s.receive(b"ok\r\n", 0.1)
    s.expect_end(0.1)
    t = 0.1
    while t < 10.0:
        s.outgoing(t)
        s.check(t)
        t += 0.1
    assert not any(isinstance(e, TimedOut) for e in s.pop_events())
    s.check(10.3)
    (ev,) = [e for e in s.pop_events() if isinstance(e, TimedOut)]
    assert ev.what == "silent" and "end of the job" in ev.detail


def test_line_lost_when_idle_with_empty_buffer():
    s = GrblStream(_lines("G0X1"), status_interval_s=0.2, timeouts=T)
    s.outgoing(0.0)
    s.receive(b"<Idle|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0>\r\n", 0.1)
    s.check(1.0)
    assert not any(isinstance(e, TimedOut) for e in s.pop_events())
    s.check(1.2)
    lost = [e for e in s.pop_events() if isinstance(e, TimedOut)]
    assert lost and lost[0].what == "lost-line" and "line 1" in lost[0].detail


def test_dwell_extends_the_lost_line_bound():
    s = GrblStream([JobLine.of(1, "G4 P3")], status_interval_s=0.2, timeouts=T)
    s.outgoing(0.0)
    s.receive(b"<Idle|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0>\r\n", 0.1)
    s.check(3.5)
    assert not any(isinstance(e, TimedOut) for e in s.pop_events())
    s.check(4.2)
    assert any(isinstance(e, TimedOut) for e in s.pop_events())


def test_no_answer_and_no_motion_is_a_stall_but_motion_is_progress():
    s = GrblStream(_lines("G1X100F10"), status_interval_s=0.2, timeouts=T)
    s.outgoing(0.0)
    for k in range(1, 30):  # a long slow move: the position keeps changing
        s.receive(f"<Run|MPos:{k * 0.1:.3f},0.000,0.000|Bf:14,128|FS:10,0>\r\n".encode(), k * 1.0)
        s.check(k * 1.0)
    assert not any(isinstance(e, TimedOut) for e in s.pop_events())
    for k in range(30, 41):  # reports keep coming, the position no longer changes
        s.receive(b"<Run|MPos:2.900,0.000,0.000|Bf:14,128|FS:10,0>\r\n", float(k))
    s.check(40.5)
    stalls = [e for e in s.pop_events() if isinstance(e, TimedOut)]
    assert stalls and stalls[0].what == "stall"


def test_hold_and_reset_are_bounded():
    s = GrblStream(_lines(), status_interval_s=0.0, timeouts=T)
    s.feed_hold(0.0)
    s.check(5.5)
    s.soft_reset(6.0)
    s.check(9.5)
    assert [e.what for e in s.pop_events() if isinstance(e, TimedOut)] == ["hold", "reset"]


# ------------------------------------------------------------------ property: nothing lost
@settings(max_examples=60, deadline=None)
@given(
    lengths=st.lists(st.integers(1, 79), min_size=1, max_size=60),
    answers=st.lists(st.integers(0, 4), min_size=1, max_size=200),
    mode=st.sampled_from(list(StreamMode)),
)
def test_every_line_sent_once_in_order_within_the_buffer(lengths, answers, mode):
    lines = [JobLine(i + 1, "G" * n) for i, n in enumerate(lengths)]
    s = GrblStream(lines, mode=mode, status_interval_s=0.0)
    wire = bytearray()
    acked: list[int] = []
    t = 0.0
    k = 0
    while not s.finished:
        t += 0.001
        wire += s.outgoing(t)
        assert s.inflight_bytes <= 128
        if mode is StreamMode.SEND_RESPONSE:
            assert len(s.inflight) <= 1
        n = min(answers[k % len(answers)], len(s.inflight)) or (1 if s.inflight else 0)
        k += 1
        s.receive(b"ok\r\n" * n, t)
        acked += [e.line.number for e in s.pop_events() if isinstance(e, LineAcked)]
    assert bytes(wire) == b"".join(ln.data for ln in lines)
    assert acked == [ln.number for ln in lines]


def test_job_from_text_keeps_source_line_numbers():
    job = Job.from_text("(header)\n\nG0 X1 ; go\n%\ng1 x2 f100\n")
    assert [(ln.number, ln.text) for ln in job.lines] == [(3, "G0X1"), (5, "G1X2F100")]
    assert job.index_of(4) == 1 and job.index_of(99) == 2
    assert [ln.text for ln in job.from_line(4)] == ["G1X2F100"]


def test_events_carry_lines_sent():
    s = GrblStream(_lines("G0X1"), status_interval_s=0.0)
    s.outgoing(0.0)
    (ev,) = s.pop_events()
    assert isinstance(ev, LineSent) and ev.line.number == 1
    s.receive(b"<Idle|MPos:0,0,0|FS:0,0>\r\n", 0.0)
    assert isinstance(s.pop_events()[0], StatusUpdate)
    assert isinstance(Unexpected("ok"), Unexpected)
