"""Negative corpus: every tests/data/bad/*.nc names its expected error in its first line.

Header format: ``(expect error CODE line LINE [dialect NAME]: what is wrong)``.
"""

import re

import pytest
from conftest import DATA

from gcode import BlockParser, ErrorCode, GCodeError, dialect_by_name, parse, parse_with_errors

BAD = sorted((DATA / "bad").glob("*.nc"))
HEADER = re.compile(r"\(expect error (\d+) line (\d+)(?: dialect (\w+))?: .+\)")


def _expect(path):
    lines = path.read_text(encoding="ascii").splitlines()
    m = HEADER.fullmatch(lines[0])
    assert m, f"{path.name}: bad header {lines[0]!r}"
    code, line, dialect = int(m[1]), int(m[2]), dialect_by_name(m[3] or "generic")
    return lines, ErrorCode(code), line, dialect


def test_corpus_is_not_empty():
    assert len(BAD) >= 15


@pytest.mark.parametrize("path", BAD, ids=lambda p: p.stem)
@pytest.mark.parametrize("fast", [True, False], ids=["fast", "blockparser"])
def test_bad_program_raises_its_code_at_its_line(path, fast):
    lines, code, line, dialect = _expect(path)
    with pytest.raises(GCodeError) as info:
        parse("\n".join(lines) + "\n", dialect, fast=fast)
    err = info.value
    assert err.code is code, str(err)
    assert err.line == line, str(err)
    assert err.text == lines[line - 1]
    assert str(line) in str(err) and str(int(code)) in str(err)


@pytest.mark.parametrize("path", BAD, ids=lambda p: p.stem)
def test_bad_block_leaves_state_unchanged(path):
    lines, _code, line, dialect = _expect(path)
    bp = BlockParser(dialect)
    for n, text in enumerate(lines[: line - 1], start=1):
        bp.parse_line(text, n)
    before = (bp.state, bp.units, bp.motion_seen, bp.name, bp.number)
    with pytest.raises(GCodeError):
        bp.parse_line(lines[line - 1], line)
    assert (bp.state, bp.units, bp.motion_seen, bp.name, bp.number) == before


@pytest.mark.parametrize("path", BAD, ids=lambda p: p.stem)
def test_collecting_parse_skips_only_the_bad_block(path):
    lines, code, line, dialect = _expect(path)
    program, errors = parse_with_errors("\n".join(lines) + "\n", dialect)
    assert [(e.code, e.line) for e in errors] == [(code, line)]
    # Skipping the bad block must equal a program in which it never existed.
    without = [*lines[: line - 1], "(removed)", *lines[line:]]
    clean = parse("\n".join(without) + "\n", dialect)
    blocks = [b for b in clean.blocks if getattr(b, "text", None) != "removed"]
    assert list(program.blocks) == blocks


def test_collecting_parse_reports_every_error_in_line_order():
    text = "G21\nG1 X1\nG0 G1 X2\nQ1\nG1 X3 F100\nX1e-3\n"
    program, errors = parse_with_errors(text)
    assert [(int(e.code), e.line) for e in errors] == [(22, 2), (21, 3), (20, 4), (2, 6)]
    assert len(program.blocks) == 1 and program.source_lines == (5,)


def test_error_codes_follow_grbl_and_map_ours_to_grbl():
    assert ErrorCode.EXPECTED_COMMAND_LETTER == 1 and ErrorCode.BAD_NUMBER_FORMAT == 2
    assert ErrorCode.LINE_OVERFLOW == 11 and ErrorCode.MODAL_GROUP_VIOLATION == 21
    assert ErrorCode.UNDEFINED_FEED_RATE == 22 and ErrorCode.WORD_REPEATED == 25
    assert ErrorCode.INVALID_TARGET == 33
    assert all(c.grbl < 100 for c in ErrorCode)
    assert all(c >= 100 for c in ErrorCode if c.grbl != c)
    assert ErrorCode.ARC_RADIUS_MISMATCH.grbl == 33


def test_gcode_error_pickles_and_is_a_value_error():
    import pickle

    err = GCodeError(ErrorCode.WORD_REPEATED, "X twice", line=3, text="X1X2")
    back = pickle.loads(pickle.dumps(err))
    assert isinstance(back, ValueError)
    assert (back.code, back.line, back.text, str(back)) == (err.code, 3, "X1X2", str(err))
