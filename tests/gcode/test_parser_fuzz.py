"""Hostile input for the G-code parser (issue 26): no hang, no traceback, paths that agree.

* The word reader's fast path (one fullmatch of a non-backtracking pattern) and its
  hand-written scanner accept the same texts and read the same words.
* Random lines of up to 10,000 characters, and numbers beyond the float range in every
  word, end in an accepted block or a clean :class:`GCodeError` naming the line, in every
  dialect; the whole-file parser's vectorized path agrees with the block parser on them.
* The lines that hung the old backtracking tokenizer (5 words of 8 digits then ``!``,
  11 words of 6 digits then ``!``, 9 words of 20 digits then ``!``, and 10,000-character
  lines) are parsed in a child process within a generous bound that only catastrophic
  (exponential or quadratic) behaviour can exceed. This is not a speed test: the per-line
  figures are printed by ``benchmarks/bench_parser.py``.
"""

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from gcode import FANUC, GENERIC, GRBL, LINUXCNC, BlockParser, ErrorCode, GCodeError
from gcode.blockparser import _SPLIT_WORDS_RE, _words_fast, _words_scan
from gcode.numbers import read_number
from gcode.parser import parse_with_errors

DIALECTS = [GRBL, LINUXCNC, FANUC, GENERIC]
ROOT = Path(__file__).resolve().parents[2]

_TOKENS = st.one_of(
    st.sampled_from(list("GXYZABCIJKRFNMSTPOE")),
    st.sampled_from(list("0123456789.+-")),
    st.text("0123456789", min_size=1, max_size=400),
    st.sampled_from([" ", "\t", "(", ")", ";", "!", "%", "/", "G1", "G2", "G93", "X1.5"]),
)
_LINES = st.lists(_TOKENS, max_size=400).map(lambda t: "".join(t)[:10_000])
_CODE = st.lists(
    st.one_of(
        st.sampled_from(list("GXYZFNE")),
        st.sampled_from(list("0123456789.+-!")),
        st.text("0123456789", min_size=1, max_size=30),
    ),
    max_size=60,
).map("".join)


@settings(max_examples=400, deadline=None, derandomize=True)
@given(_CODE)
def test_fast_words_and_scanner_agree(code):
    fast = _words_fast(code)
    try:
        scanned = _words_scan(code)
    except GCodeError as err:
        assert fast is None, f"scanner rejects what the fast path reads: {err}"
        assert err.code in (ErrorCode.EXPECTED_COMMAND_LETTER, ErrorCode.BAD_NUMBER_FORMAT)
        # the parser's reader (scanning only after the good words) says the same
        with pytest.raises(GCodeError) as info:
            BlockParser()._read_words(code)
        assert info.value.message == err.message
        return
    assert BlockParser()._read_words(code) == scanned
    if fast is not None:
        assert scanned == fast
    else:  # only an E (a word the parser then refuses) keeps the fast path off
        assert "E" in code


@settings(max_examples=200, deadline=None, derandomize=True)
@given(st.lists(_CODE, min_size=1, max_size=5))
def test_words_between_comments_read_as_each_piece_alone(pieces):
    """LinuxCNC: the one-pass read of words with comment marks equals piece by piece."""
    together = _words_fast("(".join(pieces), _SPLIT_WORDS_RE)
    alone = [_words_fast(p) for p in pieces]
    if "E" in "".join(pieces):
        assert together is None
    elif any(a is None for a in alone):
        assert together is None
    else:
        assert together == [w for a in alone for w in a]


@settings(max_examples=150, deadline=None, derandomize=True)
@given(_LINES, st.sampled_from(DIALECTS))
def test_random_lines_give_a_block_or_a_gcode_error(line, dialect):
    bp = BlockParser(dialect)
    try:
        bp.parse_line(line, 7)
    except GCodeError as err:
        assert err.line == 7 and isinstance(err.code, ErrorCode)


@settings(max_examples=40, deadline=None, derandomize=True)
@given(st.lists(_LINES.map(lambda s: s[:300]), min_size=1, max_size=6), st.sampled_from(DIALECTS))
def test_fast_and_block_parser_agree_on_random_programs(lines, dialect):
    text = "\n".join(["G21 G90 G1 X0 F100", *[ln.replace("\n", "") for ln in lines]]) + "\n"
    fast, fast_errors = parse_with_errors(text, dialect)
    slow, slow_errors = parse_with_errors(text, dialect, fast=False)
    assert fast == slow
    assert [(e.code, e.line) for e in fast_errors] == [(e.code, e.line) for e in slow_errors]


_BIG = "9" * 400


def test_read_number_refuses_numbers_beyond_float_range():
    assert read_number("9" * 308) == float("9" * 308)
    with pytest.raises(GCodeError) as info:
        read_number("-" + _BIG)
    assert info.value.code is ErrorCode.BAD_NUMBER_FORMAT


@pytest.mark.parametrize("letter", list("GMNTXYZABCFSPRIJKO"))
@pytest.mark.parametrize("dialect", DIALECTS, ids=lambda d: d.name)
def test_numbers_beyond_float_range_are_error_2_naming_the_word(letter, dialect):
    line = f"G1 {letter}{_BIG}.5 F100" if letter != "F" else f"G1 X1 F{_BIG}"
    with pytest.raises(GCodeError) as info:
        BlockParser(dialect).parse_line(line, 3)
    err = info.value
    assert err.line == 3
    if dialect.max_line_length is None:  # else the line is too long first (error 11)
        # every word's number is read before the dialect's words are checked
        assert err.code is ErrorCode.BAD_NUMBER_FORMAT, str(err)
        assert f"{letter}999999999999..." in str(err) and "floating-point range" in str(err)
        assert "characters)" in str(err)  # shortened, with its length


@pytest.mark.parametrize(
    "lines",
    [
        ["G20 G0 X" + "9" * 308],  # finite, but not in mm
        ["G91 G0 X" + "9" * 308, "X" + "9" * 308],  # the incremental target
        ["G20 G1 X1 F" + "9" * 308],  # the feed in mm/min
        ["G20 G0 X0 Y0", "G2 X1 R" + "9" * 308 + " F10"],  # R in mm
        ["G20 G0 X0 Y0", "G2 X1 I" + "9" * 308 + " F10"],  # the arc's centre
    ],
)
def test_values_leaving_float_range_on_conversion_are_error_2(lines):
    text = "\n".join(lines) + "\n"
    for fast in (True, False):
        _, errors = parse_with_errors(text, GENERIC, fast=fast)
        assert [(e.code, e.line) for e in errors] == [(ErrorCode.BAD_NUMBER_FORMAT, len(lines))]
        assert "floating-point range" in str(errors[0])


# the lines that hung the backtracking tokenizer, and 10,000-character lines
_PATHOLOGICAL = """
from gcode import GENERIC, GRBL, LINUXCNC, BlockParser, GCodeError
lines = [
    "".join(c + "12345678" for c in "XYZXY") + "!",
    "".join(c + "123456" for c in "XYZIJKXYZIJ") + "!",
    "".join(c + "1" * 20 for c in "XYZABCIJK") + "!",
    ("X123456789" * 1000)[:9999] + "!",
    "".join("XYZABCIJKR"[i % 10] + str(i % 1000) + ".5" for i in range(1700))[:10000],
    "()" * 5000,
    "(" * 10000,
    "G1 X" + " 1" * 4998,
    "X" + "9" * 9999,
    "X" + "." * 9999,
    "X1." * 3333,
]
for line in lines:
    for dialect in (GRBL, LINUXCNC, GENERIC):
        try:
            BlockParser(dialect).parse_line(line, 1)
        except GCodeError:
            pass
print("done", len(lines))
"""


def test_pathological_lines_cannot_hang_the_parser():
    try:
        out = subprocess.run(
            [sys.executable, "-c", textwrap.dedent(_PATHOLOGICAL)],
            capture_output=True,
            text=True,
            timeout=60,  # generous: they take milliseconds; the old tokenizer took hours
            cwd=ROOT,
            env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"},
        )
    except subprocess.TimeoutExpired:
        pytest.fail("the parser hung on a pathological line (catastrophic backtracking?)")
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("done 11")
