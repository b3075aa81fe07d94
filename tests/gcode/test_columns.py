"""Columnar move runs: parsed programs keep plain moves as numpy columns.

The lazily built blocks must equal the block parser's objects in every way a caller can
see (values, ==, hash, len, indexing, slicing, iteration, line map, errors), and every
consumer (emitter, interpreter) must give the same result from columns as from objects.
"""

import pickle
from dataclasses import replace

import numpy as np
import pytest
from programs import random_program

from gcode import (
    FANUC,
    GENERIC,
    GRBL,
    LINUXCNC,
    Comment,
    ErrorCode,
    GCodeError,
    Linear,
    Program,
    Rapid,
    emit_text,
    interpret,
    parse,
    parse_with_errors,
)
from gcode.block_sequence import BlockSequence, MoveRun
from gcode.numbers import format_number, format_slots

DIALECTS = [GRBL, LINUXCNC, FANUC, GENERIC]


def _moves_text(rng, n, *, incremental=False, inch=False):
    lines = ["G20" if inch else "G21", "G91" if incremental else "G90"]
    for k in range(n):
        xyz = np.round(rng.uniform(-300, 300, 3), int(rng.integers(0, 7)))
        words = [f"X{xyz[0]}", f"Y{xyz[1]}"] + ([f"Z{xyz[2]}"] if k % 3 else [])
        if k % 5 == 0:
            lines.append("G0 " + " ".join(words))
        else:
            lines.append("G1 " + " ".join(words) + (f" F{100 + k % 7 * 50}" if k % 4 else ""))
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("dialect", DIALECTS, ids=lambda d: d.name)
@pytest.mark.parametrize("seed", range(6))
def test_lazy_blocks_equal_eagerly_parsed_ones(dialect, seed):
    rng = np.random.default_rng(seed)
    text = emit_text(random_program(rng, dialect, n=300), dialect)
    fast = parse(text, dialect)
    slow = parse(text, dialect, fast=False)
    assert isinstance(fast.blocks, BlockSequence) and isinstance(slow.blocks, tuple)
    assert any(isinstance(p, MoveRun) for p in fast.blocks.parts)
    want = slow.blocks
    got = fast.blocks
    assert got == want and want == got and not (got != want)
    assert len(got) == len(want) and tuple(got) == want and list(got) == list(want)
    assert hash(got) == hash(want) and hash(fast) == hash(slow)
    assert repr(got) == repr(want)
    for i in (*range(len(want)), -1, -len(want)):
        assert got[i] == want[i] and type(got[i]) is type(want[i])
    for sl in (slice(3, 77), slice(None, 5), slice(-40, None), slice(1, 200, 7), slice(5, 5)):
        assert tuple(got[sl]) == want[sl] and got[sl] == want[sl]
    assert fast.source_lines == slow.source_lines
    assert [fast.line_of(i) for i in range(len(want))] == list(slow.source_lines)
    assert pickle.loads(pickle.dumps(fast)) == slow
    with pytest.raises(IndexError):
        got[len(want)]


def test_columns_are_read_only_and_the_sequence_immutable():
    p = parse(_moves_text(np.random.default_rng(1), 200))
    runs = [r for r in p.blocks.parts if isinstance(r, MoveRun)]
    assert runs
    with pytest.raises(ValueError):
        runs[0].axes[0, 0] = 1.0
    with pytest.raises(TypeError):
        p.blocks[0] = Rapid(x=1.0)  # type: ignore[index]
    with pytest.raises(AttributeError):
        p.blocks.extra = 1  # type: ignore[attr-defined]


@pytest.mark.parametrize("incremental", [False, True])
@pytest.mark.parametrize("inch", [False, True])
def test_move_runs_parse_like_the_block_parser(incremental, inch):
    text = _moves_text(np.random.default_rng(7), 2000, incremental=incremental, inch=inch)
    fast, slow = parse(text), parse(text, fast=False)
    assert fast == slow and fast.source_lines == slow.source_lines
    # and every consumer agrees: interpreter segments, emitted text
    a, b = interpret(fast), interpret(slow)
    for name in ("start", "end", "kind", "feed", "inverse_time", "plane", "line"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    for dialect in DIALECTS:
        assert emit_text(fast, dialect) == emit_text(slow, dialect)


def test_long_and_odd_numbers_read_exactly():
    values = [
        "123456.7890123", "-0.000000000001", "+.5", "5.", "0000000000000001", "9007199254740993",
        "-12345678.12345678", ".123456789012345", "12345678901234567", "-0", "0.1000000000",
    ]  # fmt: skip
    text = "".join(f"G0 X{v}\n" for v in values)
    fast, slow = parse(text), parse(text, fast=False)
    assert fast == slow
    assert [b.x for b in fast.blocks] == [float(v) for v in values]


@pytest.mark.parametrize(
    "bad, code",
    [
        ("G1 X1 X2", ErrorCode.WORD_REPEATED),
        ("G1 X1.2.3", ErrorCode.EXPECTED_COMMAND_LETTER),
        ("G1 X-", ErrorCode.BAD_NUMBER_FORMAT),
        ("G1 X1 -2", None),
        ("G1 X1+2", None),
        ("G1 X1 Q2", None),
        ("G1 X1 F0", None),
        ("G5 X1", None),
        ("X1e3", ErrorCode.BAD_NUMBER_FORMAT),
    ],
)
def test_an_error_inside_a_columnar_run_names_its_line(bad, code):
    rng = np.random.default_rng(3)
    lines = _moves_text(rng, 3000).splitlines()
    at = 1777
    lines[at] = bad
    text = "\n".join(lines) + "\n"
    with pytest.raises(GCodeError) as fast_info:
        parse(text)
    with pytest.raises(GCodeError) as slow_info:
        parse(text, fast=False)
    assert (fast_info.value.code, fast_info.value.line) == (
        slow_info.value.code,
        slow_info.value.line,
    )
    assert fast_info.value.line == at + 1 and fast_info.value.text == bad
    if code is not None:
        assert fast_info.value.code is code
    program, errors = parse_with_errors(text)
    assert [(e.code, e.line) for e in errors] == [(fast_info.value.code, at + 1)]
    good, _ = parse_with_errors(text, fast=False)
    assert program == good and program.source_lines == good.source_lines


_VOCAB = [*"GXYZABCFNMST0123456789.-+ \t()/;%", "\n", "G1", "G0", "X", "\r"]


@pytest.mark.parametrize("seed", range(40))
def test_mutated_text_parses_as_the_block_parser_says(seed):
    """Random edits of a move program: fast and block parser agree on blocks, lines, errors."""
    rng = np.random.default_rng(1000 + seed)
    dialect = [GRBL, LINUXCNC, FANUC, GENERIC][seed % 4]
    text = list(_moves_text(rng, 150, incremental=seed % 3 == 0, inch=seed % 5 == 0))
    for _ in range(int(rng.integers(1, 25))):
        k = int(rng.integers(0, len(text)))
        op = rng.integers(0, 3)
        ch = _VOCAB[int(rng.integers(0, len(_VOCAB)))]
        if op == 0:
            text.insert(k, ch)
        elif op == 1:
            del text[k]
        else:
            text[k] = ch
    src = "".join(text)
    fast, fast_errors = parse_with_errors(src, dialect)
    slow, slow_errors = parse_with_errors(src, dialect, fast=False)
    assert [(e.code, e.line, e.text) for e in fast_errors] == [
        (e.code, e.line, e.text) for e in slow_errors
    ]
    assert fast == slow and fast.source_lines == slow.source_lines


def test_block_sequence_joins_neighbouring_tuples_and_drops_empty_runs():
    run = MoveRun.from_blocks([Rapid(x=1.0), Linear(y=2.0, feed=10.0)])
    seq = BlockSequence([(Comment("a"),), run[0:0], (Comment("b"),), run])
    assert len(seq.parts) == 2 and seq.parts[0] == (Comment("a"), Comment("b"))
    assert seq == (Comment("a"), Comment("b"), Rapid(x=1.0), Linear(y=2.0, feed=10.0))
    assert seq + (Comment("c"),) == (*seq, Comment("c"))  # noqa: RUF005 (tests +)
    assert (Comment("c"),) + seq == (Comment("c"), *seq)  # noqa: RUF005
    assert Program(seq) == Program(tuple(seq))
    assert run.blocks() == [Rapid(x=1.0), Linear(y=2.0, feed=10.0)]


def test_format_slots_writes_what_format_number_writes():
    rng = np.random.default_rng(11)
    values = np.concatenate(
        (
            rng.uniform(-2e6, 2e6, 3000),
            np.round(rng.uniform(-999, 999, 3000), 3),
            [0.0, -0.0, -0.0004, 0.0005, -0.0005, 999.9996, -999.9996, 9999.99996, 1e12],
        )
    )
    for decimals in range(7):
        for trim, keep_point in ((True, False), (False, False), (True, True)):
            cols = format_slots(values, decimals, trim=trim, keep_point=keep_point)
            assert cols is not None
            matrix = np.concatenate([c.view(np.uint8).reshape(len(values), -1) for c in cols], 1)
            got = [bytes(row[row != 0]).decode() for row in matrix]
            want = [format_number(v, decimals, trim=trim, keep_point=keep_point) for v in values]
            assert got == want


def test_emitting_columns_is_byte_identical_to_emitting_objects():
    rng = np.random.default_rng(5)
    for dialect in DIALECTS:
        program = random_program(rng, dialect, n=400)
        parsed = parse(emit_text(program, dialect), dialect)
        as_objects = replace(parsed, blocks=tuple(parsed.blocks))
        for d in (dialect, replace(dialect, suppress_modal=False)):
            assert emit_text(parsed, d) == emit_text(as_objects, d)
            assert emit_text(parsed, d) == emit_text(as_objects, d, vectorize=False)
