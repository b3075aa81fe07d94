"""Emitter behaviour beyond the golden files: streaming, modal words, dialect limits."""

import io
from dataclasses import replace

import numpy as np
import pytest

from gcode import (
    FANUC,
    GRBL,
    LINUXCNC,
    Arc,
    Comment,
    DialectError,
    Dwell,
    ErrorCode,
    FeedMode,
    GCodeError,
    Linear,
    LineCollector,
    Plane,
    Program,
    Rapid,
    SetFeedMode,
    TextWriter,
    ToolChange,
    emit,
    emit_lines,
    parse,
)
from gcode.emitter import CHUNK


def test_modal_words_only_when_they_change():
    p = Program((Rapid(x=0.0), Rapid(y=1.0), Linear(x=1.0, feed=100.0), Linear(x=2.0, feed=100.0),
                 Linear(x=3.0, feed=200.0), Rapid(z=5.0), Linear(z=0.0, feed=200.0)))  # fmt: skip
    assert emit_lines(p, LINUXCNC)[2:] == [
        "G0 X0", "Y1", "G1 X1 F100", "X2", "X3 F200", "G0 Z5", "G1 Z0",
    ]  # fmt: skip
    no_suppress = replace(LINUXCNC, suppress_modal=False)
    assert emit_lines(p, no_suppress)[-1] == "G1 Z0 F200"


def test_inverse_time_writes_f_on_every_feed_move():
    moves = tuple(Linear(x=float(k), a=float(k), feed=50.0) for k in range(40))
    p = Program((SetFeedMode(FeedMode.INVERSE_TIME), *moves))
    lines = emit_lines(p, LINUXCNC)
    assert all(line.endswith("F50") for line in lines[3:])
    with pytest.raises(DialectError):
        emit_lines(p, GRBL)


@pytest.mark.parametrize("vectorize", [True, False])
def test_grbl_refuses_rotary_axes_and_tool_change(vectorize):
    for block in (Rapid(x=1.0, a=10.0), ToolChange(2)):
        with pytest.raises(GCodeError) as info:
            emit_lines(Program((block,) * 40), GRBL, vectorize=vectorize)
        assert info.value.code is ErrorCode.UNSUPPORTED_COMMAND


@pytest.mark.parametrize("vectorize", [True, False])
def test_line_over_the_limit_is_an_error_with_the_output_line(vectorize):
    tight = replace(GRBL, max_line_length=20)
    ok = Linear(x=1.0, y=2.0, feed=100.0)
    long = Linear(x=123456.789, y=-123456.789, z=1.5, feed=100.0)
    with pytest.raises(GCodeError) as info:
        emit_lines(Program((ok,) * 40 + (long,)), tight, vectorize=vectorize)
    assert info.value.code is ErrorCode.LINE_OVERFLOW
    assert info.value.line == 2 + 40 + 1  # units line, preamble line, 40 moves


def test_feed_that_rounds_to_zero_is_refused():
    for vectorize in (True, False):
        with pytest.raises(GCodeError) as info:
            emit_lines(Program((Linear(x=1.0, feed=0.01),) * 40), GRBL, vectorize=vectorize)
        assert info.value.code is ErrorCode.UNDEFINED_FEED_RATE


def test_arc_outside_the_active_plane_is_refused():
    arc = Arc(clockwise=True, x=1.0, z=0.0, i=0.5, k=0.0, plane=Plane.ZX, feed=100.0)
    with pytest.raises(GCodeError) as info:
        emit_lines(Program((arc,)), LINUXCNC)
    assert info.value.code is ErrorCode.INVALID_TARGET


def test_comments_are_sanitized_for_each_style():
    p = Program((Comment("a (nested) é\nb"),))
    assert emit_lines(p, LINUXCNC)[-1] == "(a [nested] ? b)"
    semi = replace(LINUXCNC, comment_style=LINUXCNC.comment_style.SEMICOLON)
    assert emit_lines(p, semi)[-1] == "; a (nested) ? b"
    assert parse("\n".join(emit_lines(p, semi))).blocks[-1] == Comment("a (nested) ? b")


def test_line_numbers_wrap_after_the_maximum():
    small = replace(FANUC, line_number_start=1, line_number_step=1, line_number_max=5)
    lines = emit_lines(Program(tuple(Rapid(x=float(k)) for k in range(40))), small)
    numbers = [int(line.split()[0][1:]) for line in lines if line.startswith("N")]
    assert numbers[:12] == [1, 2, 3, 4, 5, 1, 2, 3, 4, 5, 1, 2]


def test_fanuc_dwell_is_in_milliseconds():
    assert "N30 G04 P1500" in emit_lines(Program((Dwell(1.5),)), FANUC)
    assert parse("\n".join(emit_lines(Program((Dwell(1.5),)), FANUC)), FANUC).blocks[-1] == Dwell(
        1.5
    )


def test_streaming_writes_chunks_not_one_string(rng):
    n = CHUNK * 2 + 5
    xs = np.round(rng.uniform(-10, 10, n), 3).tolist()
    p = Program(tuple(Linear(x=x, feed=100.0) for x in xs))

    class Counting(LineCollector):
        def __init__(self):
            super().__init__()
            self.chunks = 0
            self.biggest = 0

        def write(self, text):
            self.chunks += 1
            self.biggest = max(self.biggest, text.count("\n"))
            super().write(text)

    w = Counting()
    assert emit(p, LINUXCNC, w) == n + 2
    assert w.chunks >= 3 and w.biggest <= CHUNK
    assert len(w.lines) == n + 2


def test_text_writer_streams_to_text_and_binary_streams_and_files(tmp_path):
    p = Program((Rapid(x=1.0),))
    s, b = io.StringIO(), io.BytesIO()
    emit(p, GRBL, TextWriter(s))
    emit(p, GRBL, TextWriter(b))
    path = tmp_path / "p.nc"
    with TextWriter(path) as w:
        emit(p, GRBL, w)
    assert s.getvalue() == b.getvalue().decode() == path.read_text() == "G21\nG94G17G90\nG0X1\n"


def test_line_limit_ignores_separators_like_grbl():
    spaced = replace(LINUXCNC, max_line_length=12)
    p = Program((Linear(x=1.0, y=2.0, feed=100.0),) * 40)  # "G1 X1 Y2 F100" = 10 + 3 spaces
    for vectorize in (True, False):
        assert emit_lines(p, spaced, vectorize=vectorize)[2] == "G1 X1 Y2 F100"
    tighter = replace(LINUXCNC, max_line_length=9)
    for vectorize in (True, False):
        with pytest.raises(GCodeError):
            emit_lines(p, tighter, vectorize=vectorize)
