"""run_program gives the same run from a columnar program as from block objects.

Parsed and posted programs hold plain moves as numpy columns; the instant-mode run reads
them without building blocks. Every result (summary, journal, clock, position, modal
state, alarm) must equal the run of the same blocks held as a tuple of objects.
"""

from dataclasses import replace

import numpy as np
import pytest

from gcode import GRBL, PostOptions, parse, post
from gcode.block_sequence import BlockSequence, MoveRun
from gcode.machine_frame import work_offsets
from simulator import Controller, run_program
from toolpath import MoveKind, Toolpath


def _text(rng, n, *, out_of_travel_at=None):
    """Long stretches of plain moves between dwells, spindle, arcs, G91 and G20 blocks."""
    lines = ["G21", "G90", "G0X-10Y-10Z-5", "G1Z-6F600"]
    x, y = -50.0, -50.0
    for k in range(n):
        r = rng.random()
        x = min(-1.0, max(-700.0, x + rng.uniform(-5, 5)))
        y = min(-1.0, max(-500.0, y + rng.uniform(-5, 5)))
        if k == out_of_travel_at:
            lines.append(f"G1X{x:.3f}Y{y:.3f}Z25")
        elif r < 0.01:
            lines.append(f"G2X{x:.3f}Y{y:.3f}R20F1200")
        elif r < 0.015:
            lines.append("G4P0.1")
        elif r < 0.02:
            lines.append(f"M3S{rng.integers(1, 20) * 1000}")
        elif r < 0.022:
            lines.append("G91G1X0.5F900")
            lines.append("G90")
        elif r < 0.03:
            lines.append(f"G0X{x:.3f}Y{y:.3f}")
        elif r < 0.5:
            lines.append(f"G1X{x:.3f}Y{y:.3f}")
        else:
            lines.append(f"G1X{x:.3f}Y{y:.3f}F{rng.choice([600, 1500, 3000])}")
    lines.append("G4P0.2")
    lines.append("M5")
    return "\n".join(lines) + "\n"


def _run(machine, program, offsets=None):
    c = Controller(machine, work_offsets=offsets)
    run = run_program(c, program)
    j = c.journal
    state = (c.now_s, c.position(), c.parser_state, c.alarm)
    return run, j.lines(), j.positions(), j.times_s(), *state


def _assert_same_run(machine, program, offsets=None):
    objects = replace(program, blocks=tuple(program.blocks))
    a, b = _run(machine, program, offsets), _run(machine, objects, offsets)
    assert a[0] == b[0]
    for x, y in zip(a[1:4], b[1:4], strict=True):
        assert np.array_equal(np.asarray(x), np.asarray(y))
    assert a[4:] == b[4:]
    return a[0]


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("stop", [None, "early", "late"])
def test_columnar_and_object_programs_run_the_same(router, seed, stop):
    rng = np.random.default_rng(seed)
    n = 600
    at = {None: None, "early": int(rng.integers(5, 60)), "late": int(rng.integers(300, n))}[stop]
    text = _text(rng, n, out_of_travel_at=at)
    program = parse(text, GRBL)
    assert isinstance(program.blocks, BlockSequence)
    assert any(isinstance(p, MoveRun) for p in program.blocks.parts)
    run = _assert_same_run(router, program)
    assert (run.alarm is None) == (stop is None)
    # the block parser's own objects run the same too
    slow = parse(text, GRBL, fast=False)
    assert _run(router, slow)[0] == run


def _raster(rng, rows):
    """A zig-zag finishing raster over a wavy surface, rows joined by rapids or links."""
    pts, kinds, feeds = [[0.0, 0.0, 60.0]], [MoveKind.RAPID], [0.0]
    for r in range(rows):
        n = int(rng.integers(20, 120))
        x = np.linspace(0.0, 80.0, n)[:: 1 if r % 2 == 0 else -1]
        y = np.full(n, 3.0 * r)
        z = 30.0 + 2.0 * np.sin(x / 7.0 + r)
        pts.extend(np.column_stack([x, y, z]).tolist())
        link = MoveKind.RAPID if rng.random() < 0.3 else MoveKind.LINK
        kinds += [link] + [MoveKind.CUT] * (n - 1)
        feeds += [0.0 if link == MoveKind.RAPID else 900.0] + [float(rng.choice([800, 2000]))] * (
            n - 1
        )
    return Toolpath(pts, [0.0, 0.0, 1.0], kinds, feeds, [0] * len(pts))


@pytest.mark.parametrize("seed", range(2))
def test_posted_program_runs_the_same_as_its_objects(router, seed):
    tp = _raster(np.random.default_rng(seed), 12)
    program = post(tp, router, GRBL, options=PostOptions(arcs=seed == 0))
    assert isinstance(program.blocks, BlockSequence) and program.source_lines is None
    run = _assert_same_run(router, program, work_offsets(router))
    assert run.alarm is None and run.blocks > 200
