"""parse(emit(p)) == p over seeded random programs; G20 and G21 give the same mm."""

from dataclasses import replace

import numpy as np
import pytest
from programs import assert_blocks_close, random_program

from gcode import (
    FANUC,
    GENERIC,
    GRBL,
    LINUXCNC,
    MM_PER_INCH,
    Linear,
    Program,
    Rapid,
    SetUnits,
    Units,
    emit_lines,
    emit_text,
    parse,
)

DIALECTS = [GRBL, LINUXCNC, FANUC]


@pytest.mark.parametrize("dialect", DIALECTS, ids=lambda d: d.name)
@pytest.mark.parametrize("seed", range(12))
def test_parse_emit_is_identity_at_the_formatter_resolution(dialect, seed):
    rng = np.random.default_rng(seed)
    program = random_program(rng, dialect, n=80)
    text = emit_text(program, dialect)
    back = parse(text, dialect)
    assert back.blocks == dialect.preamble + program.blocks + dialect.postamble
    assert back.units is program.units
    if dialect.program_number:
        assert (back.name, back.number) == (program.name, program.number)
    # the block parser alone gives the identical program and line map
    slow = parse(text, dialect, fast=False)
    assert slow == back and slow.source_lines == back.source_lines


def _random_float_program(rng, n=400):
    blocks = []
    for k in range(n):
        xyz = rng.uniform(-500, 500, 3)
        abc = rng.uniform(-720, 720, 3)
        vals = dict(zip("xyz", xyz.tolist(), strict=False)) | dict(
            zip("abc", abc.tolist(), strict=False)
        )
        if k % 7 == 0:
            blocks.append(Rapid(**vals))
        else:
            blocks.append(Linear(**vals, feed=float(rng.uniform(1.0, 20000.0))))
    return Program(tuple(blocks))


@pytest.mark.parametrize("vectorize", [True, False])
def test_random_floats_round_trip_within_resolution(rng, vectorize):
    program = _random_float_program(rng)
    back = parse(emit_text(program, LINUXCNC, vectorize=vectorize), LINUXCNC)
    n = len(LINUXCNC.preamble)
    assert_blocks_close(
        back.blocks[n:], program.blocks, length_tol=0.0005, angle_tol=0.0005, feed_tol=0.05
    )


def test_g20_and_g21_parse_to_the_same_millimetres(rng):
    program = _random_float_program(rng)
    mm = parse(emit_text(replace(program, units=Units.MM), LINUXCNC), LINUXCNC)
    inch = parse(emit_text(replace(program, units=Units.INCH), LINUXCNC), LINUXCNC)
    assert (mm.units, inch.units) == (Units.MM, Units.INCH)
    # lengths within half an inch-decimal step, feeds within half of 0.01 in/min
    assert_blocks_close(
        inch.blocks,
        mm.blocks,
        length_tol=0.00005 * MM_PER_INCH + 0.0005 + 1e-9,
        angle_tol=0.0,  # rotary words are written the same in both modes
        feed_tol=0.005 * MM_PER_INCH + 0.05 + 1e-9,
    )


def test_inch_text_scales_lengths_and_feed_but_never_rotary_or_inverse_time():
    from gcode import FeedMode, SetFeedMode

    program = Program(
        (
            Linear(x=25.4, a=25.4, feed=254.0),
            SetFeedMode(FeedMode.INVERSE_TIME),
            Linear(x=50.8, c=90.0, feed=12.5),
        ),
        units=Units.INCH,
    )
    lines = emit_lines(program, LINUXCNC)
    assert lines[0] == "G20"
    assert "G1 X1 A25.4 F10" in lines
    assert "X2 C90 F12.5" in lines
    back = parse("\n".join(lines), LINUXCNC)
    assert back.blocks[3:] == program.blocks


def test_units_words_before_motion_are_metadata_and_later_ones_are_blocks():
    text = "G20\nG0 X1\nG21\nG0 X1\n"
    program = parse(text)
    assert program.units is Units.INCH
    assert program.blocks == (Rapid(x=25.4), SetUnits(Units.MM), Rapid(x=1.0))
    assert parse(emit_text(program, GENERIC)).blocks == program.blocks


def test_fast_and_block_parser_agree_on_messy_text():
    text = (
        "%\n( header )\nG21 G90\n  g0 x1 y2\nG1 X 1 0 F100 ; spaced\nX-.5 Y+2.\n"
        "N10 X3\n\n/X4\nG91\nX1 Y1\nX1 Y1\nG90 G20\nX1\nG18 G2 X2 Z0 I0.5 K0\nG1 X3\n%\nX99\n"
    )
    fast = parse(text)
    slow = parse(text, fast=False)
    assert fast == slow and fast.source_lines == slow.source_lines
    assert parse(text, block_delete=True).blocks != fast.blocks
