"""The post stores stretches of moves as columns: same blocks as building them one by one.

The reference below is the post's former move loop (one frozen Rapid/Linear per move,
feed-mode and plane blocks as it goes); the columnar post must give a program equal to
it block for block, on random 3- and 5-axis paths with arcs, G93 sweeps, rapids and
dropped moves, and every consumer (emitter, interpreter, check, parser) must give the
same result from the columns as from the objects.
"""

import importlib
from dataclasses import replace

import numpy as np
import pytest
from toolpaths import random_mixed

from gcode import (
    FANUC,
    GENERIC,
    GRBL,
    LINUXCNC,
    FeedMode,
    Linear,
    PostOptions,
    Rapid,
    SetFeedMode,
    Units,
    emit_text,
    interpret,
    parse,
    post,
)
from gcode.block_sequence import BlockSequence, MoveRun
from gcode.check import check_program
from gcode.program import AXES
from machines import load_machine

post_module = importlib.import_module("gcode.post")  # the package's ``post`` is the function

# machine, dialect, five-axis path, options
CASES = [
    ("trunnion-ac", LINUXCNC, True, PostOptions()),
    ("head-table-bc", FANUC, True, PostOptions(joint_tolerance_mm=None, number=5)),
    ("trunnion-ac", GENERIC, True, PostOptions(units=Units.INCH, coolant=None)),
    ("trunnion-ac", LINUXCNC, True, PostOptions(inverse_time=False, arcs=False)),
    ("grbl-router", GRBL, False, PostOptions()),
    ("grbl-router", GRBL, False, PostOptions(units=Units.INCH)),
]


def _eager_write_moves(w, moves, arcs):
    """The former post loop: one block object per written move."""
    words = moves.words.tolist()
    changed = moves.changed.tolist()
    rapid, inverse, feed = moves.rapid.tolist(), moves.inverse.tolist(), moves.feed.tolist()
    i = 1
    while i < len(words):
        if i in arcs:
            after, arc = arcs[i]
            w.feed_mode_to(FeedMode.UNITS_PER_MINUTE)
            w.plane_to(arc.plane)
            w.add(arc)
            i = after
            continue
        if not any(changed[i]):
            i += 1
            continue
        axes = {name: words[i][k] for k, name in enumerate(AXES) if changed[i][k]}
        if rapid[i]:
            w.add(Rapid(**axes))
        else:
            w.feed_mode_to(FeedMode.INVERSE_TIME if inverse[i] else FeedMode.UNITS_PER_MINUTE)
            w.add(Linear(**axes, feed=feed[i]))
        i += 1


def _both(monkeypatch, tp, machine, dialect, options):
    columns = post(tp, machine, dialect, options=options)
    with monkeypatch.context() as m:
        m.setattr(post_module, "_write_moves", _eager_write_moves)
        eager = post(tp, machine, dialect, options=options)
    return columns, eager


@pytest.mark.parametrize("case", range(len(CASES)))
@pytest.mark.parametrize("seed", range(4))
def test_posted_columns_equal_the_blocks_built_one_by_one(monkeypatch, case, seed):
    machine_name, dialect, five, options = CASES[case]
    machine = load_machine(machine_name)
    tp = random_mixed(np.random.default_rng(100 * case + seed), 40, five_axis=five)
    columns, eager = _both(monkeypatch, tp, machine, dialect, options)
    assert isinstance(eager.blocks, tuple)
    assert isinstance(columns.blocks, BlockSequence)
    assert any(isinstance(p, MoveRun) for p in columns.blocks.parts)
    assert columns == eager and eager == columns
    assert tuple(columns.blocks) == eager.blocks  # every block, by value and type
    assert [type(b) for b in columns.blocks] == [type(b) for b in eager.blocks]
    text = emit_text(columns, dialect)
    assert text == emit_text(eager, dialect)
    assert text == emit_text(columns, dialect, vectorize=False)
    a, b = interpret(columns), interpret(eager)
    for name in ("start", "end", "kind", "feed", "inverse_time", "centre", "plane", "line"):
        assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name
    assert check_program(columns, machine, dialect) == check_program(eager, machine, dialect)
    assert parse(text, dialect).blocks[len(dialect.preamble) :] == columns.blocks


def test_inverse_time_runs_are_columns_and_write_f_on_every_line(monkeypatch):
    tp = random_mixed(np.random.default_rng(11), 60)
    columns, _ = _both(monkeypatch, tp, load_machine("trunnion-ac"), LINUXCNC, PostOptions())
    mode = FeedMode.UNITS_PER_MINUTE
    g93_runs = 0
    for part in columns.blocks.parts:
        if isinstance(part, MoveRun):
            g93_runs += mode is FeedMode.INVERSE_TIME
            continue
        for b in part:
            if isinstance(b, SetFeedMode):
                mode = b.mode
    assert g93_runs > 0
    lines = emit_text(columns, LINUXCNC).splitlines()
    g93, motion, checked = False, "G0", 0
    for line in lines:
        words = line.split()
        g93 = (g93 or "G93" in words) and "G94" not in words
        motion = next((w for w in words if w in ("G0", "G1", "G2", "G3")), motion)
        if g93 and motion == "G1" and words[-1][0] in "XYZAC" + "F":
            assert words[-1].startswith("F"), line
            checked += 1
    assert checked > 100


def test_short_stretches_stay_objects_and_tiny_programs_a_tuple():
    from toolpaths import pocket_3axis

    program = post(pocket_3axis(), load_machine("grbl-router"), GRBL)
    assert isinstance(program.blocks, tuple)
    tp = random_mixed(np.random.default_rng(3), 40)
    program = post(tp, load_machine("trunnion-ac"), LINUXCNC)
    runs = [p for p in program.blocks.parts if isinstance(p, MoveRun)]
    assert runs and min(map(len, runs)) >= post_module._MIN_COLUMN_RUN


def _short_columns(blocks, sizes=(1, 2, 3, 5)):
    """The blocks with their plain moves stored as columns of ``sizes`` moves, in turn."""
    parts, stretch, other = [], [], []
    for b in (*blocks, None):
        if isinstance(b, Rapid | Linear):
            if other:
                parts.append(tuple(other))
                other = []
            stretch.append(b)
            continue
        at, k = 0, 0
        while at < len(stretch):
            parts.append(MoveRun.from_blocks(stretch[at : at + sizes[k % len(sizes)]]))
            at, k = at + sizes[k % len(sizes)], k + 1
        stretch = []
        if b is not None:
            other.append(b)
    return BlockSequence(parts + ([tuple(other)] if other else []))


@pytest.mark.parametrize("seed", range(3))
def test_short_stretches_as_columns_still_equal_the_objects(monkeypatch, seed):
    """The post keeps stretches under ``_MIN_COLUMN_RUN`` moves as objects; consumers
    must still read shorter ones (parsed programs hold any length) as the objects."""
    tp = random_mixed(np.random.default_rng(seed), 30)
    machine = load_machine("head-table-bc")
    _, eager = _both(monkeypatch, tp, machine, LINUXCNC, PostOptions())
    columns = replace(eager, blocks=_short_columns(eager.blocks))
    assert {len(p) for p in columns.blocks.parts if isinstance(p, MoveRun)} >= {1, 2, 3}
    assert columns == eager
    a, b = interpret(columns), interpret(eager)
    for name in ("start", "end", "kind", "feed", "inverse_time", "centre", "plane", "line"):
        assert np.array_equal(getattr(a, name), getattr(b, name), equal_nan=True), name
    assert emit_text(columns, LINUXCNC) == emit_text(eager, LINUXCNC)
    assert emit_text(columns, replace(LINUXCNC, suppress_modal=False)) == emit_text(
        eager, replace(LINUXCNC, suppress_modal=False)
    )


def test_checked_columns_raise_the_error_of_the_first_bad_block():
    kind = np.array([0, 1, 1], dtype=np.int8)
    axes = np.full((3, 6), np.nan)
    axes[:, 0] = [1.0, 2.0, 3.0]
    good = MoveRun.checked(kind, axes, np.array([np.nan, 100.0, 200.0]))
    assert good.blocks() == [Rapid(x=1.0), Linear(x=2.0, feed=100.0), Linear(x=3.0, feed=200.0)]
    with pytest.raises(ValueError, match=r"Linear.feed must be finite and > 0, got 0.0"):
        MoveRun.checked(kind, axes, np.array([np.nan, 0.0, np.inf]))
    axes[1, 2] = np.inf
    with pytest.raises(ValueError, match=r"Linear.z must be finite"):
        MoveRun.checked(kind, axes, np.array([np.nan, 100.0, 200.0]))
    with pytest.raises(ValueError, match="kind"):
        MoveRun.checked(np.array([0, 2, 1], dtype=np.int8), np.zeros((3, 6)), np.ones(3))
