"""Interpreter: absolute segments, arcs kept as arcs, linearization within tolerance."""

import math

import numpy as np
import pytest

from gcode import (
    Arc,
    DistanceMode,
    Dwell,
    FeedMode,
    Linear,
    Program,
    Rapid,
    SetDistanceMode,
    SetFeedMode,
    SetWorkOffset,
    interpret,
    parse,
)
from gcode.interpreter import KIND_ARC_CCW, KIND_ARC_CW, KIND_LINEAR, KIND_RAPID


def test_absolute_incremental_and_work_offsets():
    p = Program(
        (
            Rapid(x=1.0, y=2.0),
            SetDistanceMode(DistanceMode.INCREMENTAL),
            Linear(x=1.0, feed=100.0),
            Linear(y=-2.0, a=90.0, feed=100.0),
            SetDistanceMode(DistanceMode.ABSOLUTE),
            SetWorkOffset(2),
            Rapid(z=5.0),
        )
    )
    seg = interpret(p, work_offsets={2: [100.0, 0, 0, 0, 0, 0]})
    assert seg.kind.tolist() == [KIND_RAPID, KIND_LINEAR, KIND_LINEAR, KIND_RAPID]
    assert seg.end.tolist() == [
        [1, 2, 0, 0, 0, 0], [2, 2, 0, 0, 0, 0], [2, 0, 0, 90, 0, 0], [102, 0, 5, 90, 0, 0],
    ]  # fmt: skip
    assert seg.start[1:].tolist() == [[1, 2, 0, 0, 0, 0], [2, 2, 0, 0, 0, 0], [102, 0, 0, 90, 0, 0]]
    assert seg.line.tolist() == [1, 3, 4, 7]


def test_vectorized_runs_match_modal_state_positions(rng):
    from gcode import ModalState

    blocks = []
    for k in range(300):
        if k % 50 == 0:
            mode = DistanceMode.INCREMENTAL if k % 100 else DistanceMode.ABSOLUTE
            blocks.append(SetDistanceMode(mode))
        vals = {
            a: float(v)
            for a, v in zip("xyz", rng.uniform(-5, 5, 3), strict=False)
            if rng.random() < 0.6
        }
        blocks.append(Linear(**(vals or {"x": 1.0}), feed=300.0))
    seg = interpret(Program(tuple(blocks)))
    st = ModalState()
    ends = []
    for b in blocks:
        st = st.apply(b)
        if isinstance(b, Linear):
            ends.append(st.position)
    assert np.array_equal(seg.end, np.array(ends))


def test_arc_length_time_and_linearization():
    text = "G21 G90 G17\nG0 X10 Y0\nG3 X0 Y10 I-10 J0 F600\nG2 X10 Y0 R-10 Z2\nG4 P1.5\n"
    seg = interpret(parse(text))
    assert seg.kind.tolist() == [KIND_RAPID, KIND_ARC_CCW, KIND_ARC_CW]
    assert np.allclose(seg.centre[1, :2], [0, 0]) and np.allclose(seg.centre[2, :2], [10, 10])
    lengths = seg.lengths()
    assert lengths[1] == pytest.approx(5 * math.pi)
    assert lengths[2] == pytest.approx(math.hypot(15 * math.pi, 2.0))  # 270 degree helix
    assert seg.durations()[1] == pytest.approx(60 * 5 * math.pi / 600)
    assert seg.dwell_s == 1.5
    tol = 0.001
    lin = seg.linearize(tol)
    assert (lin.kind != KIND_ARC_CW).all() and (lin.kind != KIND_ARC_CCW).all()
    arc_rows = lin.line == 3
    mid = (lin.start[arc_rows, :2] + lin.end[arc_rows, :2]) / 2
    r_start = np.hypot(*lin.start[arc_rows, :2].T)
    assert np.allclose(r_start, 10.0)
    assert (10.0 - np.hypot(*mid.T)).max() <= tol + 1e-12
    assert np.array_equal(lin.end[arc_rows][-1], seg.end[1])
    assert lin.lengths()[arc_rows].sum() == pytest.approx(5 * math.pi, rel=1e-4)


def test_inverse_time_durations_and_bounds():
    p = Program((SetFeedMode(FeedMode.INVERSE_TIME), Linear(x=5.0, a=30.0, feed=2.0), Dwell(1.0)))
    seg = interpret(p)
    assert seg.inverse_time.tolist() == [True]
    assert seg.durations().tolist() == [30.0]
    lo, hi = seg.bounds()
    assert lo.tolist() == [0.0] * 6 and hi.tolist() == [5.0, 0, 0, 30.0, 0, 0]


def test_full_circle_and_empty_program():
    seg = interpret(parse("G0 X5 Y0\nG2 X5 Y0 I-5 J0 F100\n"))
    assert seg.lengths()[1] == pytest.approx(10 * math.pi)
    empty = interpret(Program(()))
    assert len(empty) == 0 and empty.lengths().shape == (0,)
    with pytest.raises(ValueError):
        seg.linearize(0.0)
    _ = Arc  # imported for readers: arcs come from parse above
