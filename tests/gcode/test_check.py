"""check_program: every kind of issue at its line, a report rather than the first error."""

import pytest
from toolpaths import blade_5axis, pocket_3axis

from gcode import GRBL, LINUXCNC, Issue, IssueCode, Severity, check_program, check_text, post
from gcode.errors import ErrorCode
from machines import load_machine

GRBL_ROUTER = load_machine("grbl-router")  # program X -400..400, Y -300..300, Z -10..110
TRUNNION = load_machine("trunnion-ac")  # A -120..30, C continuous

# One GRBL program with one issue of each kind, each on its own line.
MIXED = """\
G21 G90 G94
G0 X0 Y0 Z5
G1 Z-1 F300
G0 X500
G1 X0 A10 F300
G93
G1 X10 Y10 F2
G1 X10 Y10 Z1 (a long comment does not count toward the limit at all, no matter how long)
G1 X1.000000000 Y2.000000000 Z3.000000000 X1 Y2 Z3 (this one is too long and repeats words)
G1 X100.0000000000000 Y100.0000000000000 Z3.0000000000000 F800.000000000000000000000000
G1 X200 F20000
G0 X395 Y-10
G3 X395 Y10 I-5 J10 F500
G1 X0 Y0
M30
"""


def _by_line(issues):
    return {(i.line, i.code) for i in issues}


def test_each_kind_of_issue_is_found_at_its_line():
    issues = check_text(MIXED, GRBL_ROUTER)
    found = _by_line(issues)
    assert (4, IssueCode.SOFT_LIMIT) in found  # X500 + G54 -400 = 100 > 0
    assert (5, IssueCode.UNSUPPORTED) in found  # A on grbl
    assert (6, IssueCode.UNSUPPORTED) in found  # G93 on grbl
    assert (9, IssueCode.SYNTAX) in found  # repeated words
    assert (10, IssueCode.LINE_TOO_LONG) in found  # 84 characters > 79
    assert (11, IssueCode.FEED_ABOVE_MAX_RATE) in found  # F20000 > X max 8000
    assert (13, IssueCode.SOFT_LIMIT) in found  # arc bulges to X 401 > 400
    lines = [i.line for i in issues]
    assert lines == sorted(lines)
    by_code = {i.code: i for i in reversed(issues)}  # the first of each code
    assert by_code[IssueCode.FEED_ABOVE_MAX_RATE].severity is Severity.WARNING
    too_long = next(i for i in issues if i.line == 10 and i.code is IssueCode.LINE_TOO_LONG)
    assert too_long.error_code is ErrorCode.LINE_OVERFLOW
    assert by_code[IssueCode.SOFT_LIMIT].message == (
        "axis X reaches 100 mm in machine coordinates, beyond its maximum 0 mm"
    )


def test_line_7_is_fine_and_a_comment_makes_a_line_too_long_only_as_a_warning():
    # issue 25: the controller strips the comment, a sender forwarding it counts it
    issues = check_text(MIXED, GRBL_ROUTER)
    found = _by_line(issues)
    assert not any(line in (2, 3, 7, 12, 14, 15) for line, _ in found)
    (eight,) = [i for i in issues if i.line == 8]
    assert eight.code is IssueCode.LINE_TOO_LONG and eight.severity is Severity.WARNING


def test_missing_feed_is_reported_at_the_move_and_later_moves_still_checked():
    issues = check_text("G21 G90\nG1 X10\nG1 X20 F100\nG0 X900\n", GRBL_ROUTER)
    assert [(i.line, i.code) for i in issues] == [
        (2, IssueCode.MISSING_FEED),
        (4, IssueCode.SOFT_LIMIT),
    ]
    assert issues[0].error_code is ErrorCode.UNDEFINED_FEED_RATE


def test_g93_move_without_f_is_a_missing_feed_on_linuxcnc():
    issues = check_text("G21 G90\nG93 G1 X1 A1\n", TRUNNION, LINUXCNC)
    assert [(i.line, i.code) for i in issues] == [(2, IssueCode.MISSING_FEED)]


def test_rotary_travel_and_axes_the_machine_lacks():
    text = "G21 G90\nG0 Z100\nG0 A-125\nG0 A-10\nG0 B5\nG0 C720\n"
    issues = check_text(text, TRUNNION)
    assert [(i.line, i.code) for i in issues] == [
        (3, IssueCode.ROTARY_TRAVEL),
        (5, IssueCode.UNSUPPORTED),
    ]
    assert "axis A reaches -125 deg" in issues[0].message
    assert "linuxcnc on trunnion-ac has no B axis" in issues[1].message


def test_one_issue_per_run_of_offending_lines():
    text = "G21 G90\n" + "".join(f"G0 X{410 + k}\n" for k in range(5)) + "G0 X0\nG0 X420\n"
    issues = check_text(text, GRBL_ROUTER)
    assert [(i.line, i.code) for i in issues] == [
        (2, IssueCode.SOFT_LIMIT),
        (8, IssueCode.SOFT_LIMIT),
    ]
    assert "(lines 2-6)" in issues[0].message and "reaches 14 mm" in issues[0].message


def test_rates_in_inverse_time_and_rotary_only_moves():
    text = "G21 G90\nG0 Z100\nG93 G1 A-30 F1\nG1 A-60 F1000\nG94 G1 C90 F100000\nM30\n"
    issues = check_text(text, TRUNNION)
    assert [(i.line, i.code) for i in issues] == [
        (4, IssueCode.FEED_ABOVE_MAX_RATE),  # 30 deg in 0.06 s = 30000 deg/min > 9000
        (5, IssueCode.FEED_ABOVE_MAX_RATE),  # 90 deg at F100000 deg/min > 18000
    ]
    assert all(i.severity is Severity.WARNING for i in issues)


def test_posted_programs_check_clean_as_programs_and_as_files(tmp_path):
    for machine, dialect, tp in ((GRBL_ROUTER, GRBL, pocket_3axis()),
                                 (TRUNNION, LINUXCNC, blade_5axis())):  # fmt: skip
        program = post(tp, machine, dialect)
        assert check_program(program, machine, dialect) == []
        path = tmp_path / "p.nc"
        from gcode import emit_file

        emit_file(program, dialect, path)
        assert check_program(path, machine) == []
        assert check_program(str(path), machine, dialect) == []


def test_a_program_is_checked_as_the_text_the_dialect_would_get():
    from gcode import Linear, Program, Rapid

    program = Program((Rapid(x=0.0, y=0.0, z=5.0), Linear(x=10.0, a=5.0, feed=300.0)))
    issues = check_program(program, GRBL_ROUTER)
    assert [(i.line, i.code) for i in issues] == [(4, IssueCode.UNSUPPORTED)]
    assert str(issues[0]).startswith("line 4: error unsupported: error 20")


def test_missing_file_raises_os_error(tmp_path):
    with pytest.raises(OSError):
        check_program(tmp_path / "nope.nc", GRBL_ROUTER)


def test_issue_text_has_line_severity_and_code():
    issue = Issue(7, IssueCode.SOFT_LIMIT, "axis X reaches 812 mm")
    assert str(issue) == "line 7: error soft-limit: axis X reaches 812 mm"


def test_a_checked_file_hands_on_the_program_a_strict_parse_reads(tmp_path):
    from gcode import check_file, emit_file, parse_file
    from gcode.check import machine_dialect

    program = post(blade_5axis(), TRUNNION, LINUXCNC)
    path = tmp_path / "p.nc"
    emit_file(program, LINUXCNC, path)
    issues, parsed = check_file(path, TRUNNION)
    assert issues == check_program(path, TRUNNION) == []
    # the very program verification would read from the file: blocks and their lines
    assert parsed == parse_file(path, machine_dialect(TRUNNION, LINUXCNC))
    # where a block fails, the strict parse stops: nothing is handed on, the issue stays
    bad = tmp_path / "bad.nc"
    bad.write_text(MIXED, encoding="utf-8")
    issues, parsed = check_file(bad, GRBL_ROUTER)
    assert parsed is None
    assert _by_line(issues) == _by_line(check_program(bad, GRBL_ROUTER))
    # warnings only (a feed over the machine's rate): the program goes on
    warned = tmp_path / "warned.nc"
    warned.write_text("G21 G90 G94\nG0 X0 Y0 Z5\nG1 X200 F20000\nM30\n", encoding="utf-8")
    issues, parsed = check_file(warned, GRBL_ROUTER)
    assert issues and all(i.severity is Severity.WARNING for i in issues)
    assert parsed == parse_file(warned, machine_dialect(GRBL_ROUTER, GRBL))
