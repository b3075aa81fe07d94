"""Byte-level tests of the sans-IO GRBL 1.1 front end."""

import re

import pytest
from conftest import lines_of

from simulator import Controller, GrblProtocol
from simulator.grbl_protocol import RX_BUFFER_SIZE, clean_line

STATUS = re.compile(
    r"^<(Idle|Run|Hold:[01]|Alarm|Check)\|MPos:[-\d.,]+\|Bf:\d+,\d+\|FS:\d+,\d+(\|.*)?>$"
)


def test_banner_and_exactly_one_answer_per_line(proto):
    assert proto.banner() == b"\r\nGrbl 1.1h ['$' for help]\r\n"
    out = proto.feed(b"G21\n\n(just a comment)\nG1X-1F600\nG1 Q5\nG1X-2\n")
    assert lines_of(out) == ["ok", "ok", "ok", "ok", "error:20", "ok"]


def test_cr_and_lf_each_end_a_line(proto):
    assert proto.feed(b"G1X-1F600\r\n") == b"ok\r\nok\r\n"


def test_realtime_bytes_in_the_middle_of_a_line(proto):
    out = proto.feed(b"G1X-1?0F6?00\n")
    got = lines_of(out)
    assert STATUS.match(got[0]) and STATUS.match(got[1]) and got[2] == "ok"
    assert proto.controller.parser_state.feed == 600.0  # the line survived intact
    assert proto.rx_bytes == len(b"G1X-10F600\n")


def test_status_report_fields(proto):
    out = lines_of(proto.feed(b"?"))[0]
    assert out == "<Idle|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0|WCO:0.000,0.000,0.000>"
    proto.feed(b"G1X-10F600\n")
    rep = lines_of(proto.feed(b"?"))[0]
    assert rep.startswith("<Run|MPos:0.000,0.000,0.000|Bf:14,128|FS:0,0")
    proto.controller.step(0.5)
    rep = lines_of(proto.feed(b"?"))[0]
    assert STATUS.match(rep) and "FS:600,0" in rep


def test_line_overflow_is_error_11(proto):
    ok79 = b"G1X-1F" + b"0" * 70 + b"600\n"  # 79 characters after cleaning
    assert len(clean_line(ok79[:-1])[0]) == 79
    assert proto.feed(ok79) == b"ok\r\n"
    assert proto.feed(b"G1 X-1 F" + b"0" * 71 + b"600\n") == b"error:11\r\n"  # 80
    # spaces and comments do not count
    assert proto.feed(b"G1 X-1 (" + b"x" * 100 + b") F600\n") == b"ok\r\n"


def test_rx_buffer_overflow_drops_and_counts(proto):
    c = proto.controller
    proto.instant = False  # the machine does not move: the planner fills up
    data = b"".join(b"G1X-%dF600\n" % (i + 1) for i in range(60))
    out = proto.feed(data)
    assert out.count(b"ok") == 15
    assert proto.rx_free == 0
    held = len(b"G1X-16F600\n")
    assert (
        proto.rx_dropped_bytes
        == len(data)
        - sum(len(b"G1X-%dF600\n" % (i + 1)) for i in range(15))
        - held
        - RX_BUFFER_SIZE
    )
    assert lines_of(proto.feed(b"?"))[0].split("|")[2] == "Bf:0,0"
    c.run_until_idle()
    out = proto.poll()
    # the buffered lines are served; what is left is the cut-off start of a line
    assert out.count(b"ok") == 1 + 128 // 11  # the held line and the whole lines buffered
    assert b"\n" not in bytes(proto._rx)


def test_check_mode(proto):
    assert lines_of(proto.feed(b"$C\n")) == ["[MSG:Enabled]", "ok"]
    out = lines_of(proto.feed(b"G1X-100F600\nG1Q1\n?"))
    assert out[:2] == ["ok", "error:20"] and out[2].startswith("<Check|")
    assert proto.controller.position() == (0.0, 0.0, 0.0)
    assert len(proto.controller.journal) == 0
    out = lines_of(proto.feed(b"$C\n"))
    assert out == ["[MSG:Disabled]", "ok", "Grbl 1.1h ['$' for help]"]
    assert proto.controller.parser_state.position[0] == 0.0  # reset dropped the checked moves


def test_check_mode_only_from_idle(proto):
    proto.instant = False
    proto.feed(b"G1X-10F600\n")
    assert proto.feed(b"$C\n") == b"error:8\r\n"


def test_alarm_then_unlock(proto):
    out = lines_of(proto.feed(b"G1X-1F600\nG1X5\n"))
    assert out == ["ok", "ALARM:2", "[MSG:Reset to continue]"]  # no answer to the bad line
    assert proto.feed(b"?G1X-2\n$X\n") == b""  # critical: nothing is served
    out = lines_of(proto.feed(b"\x18"))
    assert out == ["Grbl 1.1h ['$' for help]", "[MSG:'$H'|'$X' to unlock]"]
    assert lines_of(proto.feed(b"G1X-2\n")) == ["error:9"]
    assert lines_of(proto.feed(b"?"))[0].startswith("<Alarm|")
    assert lines_of(proto.feed(b"$X\n")) == ["[MSG:Caution: Unlocked]", "ok"]
    assert lines_of(proto.feed(b"G1X-2F600\n")) == ["ok"]


def test_reset_during_motion_gives_alarm_3(proto):
    proto.instant = False
    proto.feed(b"G1X-100F600\n")
    proto.controller.step(0.5)
    out = lines_of(proto.feed(b"\x18"))
    assert out == ["ALARM:3", "Grbl 1.1h ['$' for help]", "[MSG:'$H'|'$X' to unlock]"]
    assert -100.0 < proto.controller.position()[0] < 0.0
    assert len(proto.controller.journal) == 0  # the move was not completed


def test_reset_when_idle_gives_no_alarm(proto):
    assert lines_of(proto.feed(b"\x18")) == ["Grbl 1.1h ['$' for help]"]


def test_hold_and_resume(proto):
    proto.instant = False
    c = proto.controller
    proto.feed(b"G1X-100F3000\n")
    c.step(1.0)
    assert lines_of(proto.feed(b"!?"))[0].startswith("<Hold:1|")
    c.step(0.2)
    x_stop = c.position()[0]
    assert lines_of(proto.feed(b"?"))[0].startswith("<Hold:0|")
    c.step(1.0)
    assert c.position()[0] == x_stop  # held
    proto.feed(b"~")
    c.run_until_idle()
    assert c.position()[0] == -100.0
    assert len(c.journal) == 1


def test_dollar_commands(proto):
    out = lines_of(proto.feed(b"$$\n"))
    assert "$110=8000.000" in out and "$20=1" in out and "$10=3" in out and out[-1] == "ok"
    assert lines_of(proto.feed(b"$G\n")) == ["[GC:G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0]", "ok"]
    assert lines_of(proto.feed(b"$I\n")) == ["[VER:1.1h.20190830:]", "[OPT:V,15,128]", "ok"]
    assert lines_of(proto.feed(b"$#\n"))[0] == "[G54:0.000,0.000,0.000]"
    assert lines_of(proto.feed(b"$\n"))[0].startswith("[HLP:")
    assert lines_of(proto.feed(b"$H\n")) == ["error:5"]
    assert lines_of(proto.feed(b"$J=G91X1F100\n")) == ["error:3"]
    assert lines_of(proto.feed(b"$11=0.02\n")) == ["ok"]
    assert proto.controller.settings.junction_deviation_mm == 0.02
    assert lines_of(proto.feed(b"$999=1\n")) == ["error:3"]
    assert lines_of(proto.feed(b"$X\n")) == ["ok"]  # not in alarm: no effect
    proto.instant = False
    proto.feed(b"G1X-100F600\n")
    assert lines_of(proto.feed(b"$$\n")) == ["error:8"]


def test_grbl_mode_rejects_rotary_words(trunnion):
    p = GrblProtocol(Controller(trunnion, mode="grbl"))
    assert lines_of(p.feed(b"G1A10F600\nG93\n")) == ["error:20", "error:20"]
    assert p.controller.report_axes == "XYZ"


def test_linuxcnc_mode_accepts_five_axis_and_g93(trunnion):
    p = GrblProtocol(Controller(trunnion))
    assert p.controller.mode == "linuxcnc"
    out = lines_of(p.feed(b"G0Z-10\nG93G1X10A-10C45F60\n"))
    assert out == ["ok", "ok"]
    p.controller.run_until_idle()
    assert p.controller.position() == (10.0, 0.0, -10.0, -10.0, 45.0)
    rep = lines_of(p.feed(b"?"))[0]
    assert "MPos:10.000,0.000,-10.000,-10.000,45.000" in rep
    assert lines_of(p.feed(b"G1X11\n")) == ["error:22"]  # G93 needs F on every move
    assert lines_of(p.feed(b"G1A-130F60\n")) == ["ALARM:2", "[MSG:Reset to continue]"]


def test_dwell_and_spindle_synchronize(proto):
    c = proto.controller
    proto.instant = False
    assert proto.feed(b"G1X-10F600\nG4P0.5\n") == b"ok\r\n"  # the dwell answers when done
    c.run_until_idle()
    assert proto.poll() == b"ok\r\n"
    assert c.journal[-1].time_s == pytest.approx(c.journal[0].time_s + 0.5)
    assert proto.feed(b"M3S1200\n?").startswith(b"ok\r\n<Idle|")
    assert "FS:0,1200" in proto.status_report()


def test_unsupported_bytes_above_0x7f_are_discarded(proto):
    assert proto.feed(b"G1X-1\xffF600\n") == b"ok\r\n"
