"""Golden files: hand-built programs -> exact text per dialect, and text -> IR traces.

Regenerate after an intended format change with ``GCODE_REGEN_GOLDEN=1 pytest ...`` and
review the diff line by line.
"""

import os
from dataclasses import replace

import pytest
from conftest import DATA
from programs import assert_blocks_close, golden_3axis, golden_5axis

from gcode import FANUC, GRBL, LINUXCNC, Units, emit, emit_text, parse
from gcode.writer import TextWriter

GOLDEN = DATA / "golden"
CASES = {
    "grbl_3axis": (GRBL, golden_3axis()),
    "linuxcnc_3axis": (LINUXCNC, golden_3axis()),
    "linuxcnc_5axis": (LINUXCNC, golden_5axis()),
    "linuxcnc_5axis_inch": (LINUXCNC, replace(golden_5axis(), units=Units.INCH)),
    "fanuc_3axis": (FANUC, golden_3axis()),
    "fanuc_5axis": (FANUC, golden_5axis()),
}
REGEN = os.environ.get("GCODE_REGEN_GOLDEN") == "1"


def _trace(text, dialect):
    program = parse(text, dialect)
    head = f"units={program.units.name} name={program.name!r} number={program.number!r}\n"
    rows = [
        f"{line}: {block!r}\n"
        for line, block in zip(program.source_lines, program.blocks, strict=False)
    ]
    return head + "".join(rows)


@pytest.mark.parametrize("name", sorted(CASES))
def test_emitter_matches_golden_text_byte_for_byte(name, tmp_path):
    dialect, program = CASES[name]
    path = GOLDEN / f"{name}.nc"
    out = tmp_path / "out.nc"
    with TextWriter(out) as w:
        emit(program, dialect, w)
    got = out.read_bytes()
    if REGEN:
        path.write_bytes(got)
    assert got == path.read_bytes()
    assert emit_text(program, dialect, vectorize=False).encode("ascii") == got


@pytest.mark.parametrize("name", sorted(CASES))
def test_parser_matches_golden_ir_trace(name):
    dialect, _ = CASES[name]
    text = (GOLDEN / f"{name}.nc").read_text(encoding="ascii")
    path = GOLDEN / f"{name}.expected"
    got = _trace(text, dialect)
    if REGEN:
        path.write_text(got, encoding="utf-8")
    assert got == path.read_text(encoding="utf-8")


def test_golden_grbl_is_compact_and_within_limit():
    text = (GOLDEN / "grbl_3axis.nc").read_text(encoding="ascii")
    assert " " not in text.replace("(golden 3-axis: corner with arc)", "")
    assert all(len(line) <= 79 for line in text.splitlines())
    assert "-0" not in text.replace("X-0.", "")  # -0.0004 was written as 0


def test_golden_5axis_round_trips_exactly_in_mm():
    for dialect in (LINUXCNC, FANUC):
        program = golden_5axis()
        back = parse(emit_text(program, dialect), dialect)
        assert back.blocks == dialect.preamble + program.blocks
        assert (back.name, back.number) == (("GOLDEN5", 1002) if dialect is FANUC else (None, None))


def test_golden_3axis_round_trips_within_resolution():
    for dialect in (GRBL, LINUXCNC, FANUC):
        program = golden_3axis()
        back = parse(emit_text(program, dialect), dialect)
        n = len(dialect.preamble)
        assert_blocks_close(
            back.blocks[n:], program.blocks, length_tol=0.0005, angle_tol=0.0005, feed_tol=0.05
        )
