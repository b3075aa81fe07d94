"""Issue 25: no posted line longer than the dialect's limit, comments included; the check
flags longer lines."""

from dataclasses import replace

from toolpaths import pocket_3axis

from gcode import GRBL, LINUXCNC, Comment, Program, Rapid, emit_text, parse, post
from gcode.check import IssueCode, Severity, check_text
from machines import load_machine

PLACEMENT = (
    "placement: flat (one side up), principal axes: span 212.4 mm along X, chord 48.9 mm "
    "along Y, thickness 9.1 mm along Z; rotated 3.2 deg about Z then 0.4 deg about Y; "
    "origin at the lowest point"
)


def test_posted_grbl_header_comments_fit_79_characters_and_keep_their_words():
    tp = pocket_3axis()
    tp = replace(tp, metadata={**tp.metadata, "placement": PLACEMENT})
    text = emit_text(post(tp, load_machine("grbl-router"), GRBL), GRBL)
    lines = text.splitlines()
    assert max(map(len, lines)) <= GRBL.max_line_length
    comments = [ln[1:-1] for ln in lines if ln.startswith("(")]
    joined = " ".join(comments)
    assert "placement: flat [one side up], principal axes: span 212.4 mm along X" in joined
    assert joined.endswith("0.4 deg about Y; origin at the lowest point")
    assert check_text(text, load_machine("grbl-router"), GRBL) == []


def test_long_comments_wrap_at_spaces_in_either_comment_style():
    words = "the quick brown fox jumps over the lazy dog " * 6
    for dialect in (GRBL, replace(LINUXCNC, max_line_length=40)):
        text = emit_text(Program((Comment(words), Rapid(x=1.0))), dialect)
        body = [ln for ln in text.splitlines() if ln.startswith("(")]
        assert len(body) > 1 and all(len(ln) <= dialect.max_line_length for ln in body)
        rejoined = " ".join(b.text for b in parse(text, dialect).blocks if isinstance(b, Comment))
        assert rejoined == " ".join(words.split())
    no_limit = emit_text(Program((Comment(words),)), replace(LINUXCNC, max_line_length=None))
    assert max(map(len, no_limit.splitlines())) > 200  # nothing wrapped without a limit


def test_check_flags_lines_long_only_with_their_comments_as_warnings():
    text = (
        "G21 G90\n(" + "a" * 180 + ")\nG0 X1 Y1 ; " + "b" * 90 + "\n"
        + "G1" + "X1.1234" * 13 + "F100\n"
    )  # fmt: skip
    issues = check_text(text, load_machine("grbl-router"), GRBL)
    got = [(i.line, i.code, i.severity) for i in issues]
    assert got == [
        (2, IssueCode.LINE_TOO_LONG, Severity.WARNING),
        (3, IssueCode.LINE_TOO_LONG, Severity.WARNING),
        (4, IssueCode.LINE_TOO_LONG, Severity.ERROR),  # the controller's error:11
    ]
    assert "182 characters" in issues[0].message and "limit of 79" in issues[0].message
