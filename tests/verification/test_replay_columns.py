"""Replay reads runs of moves held as columns the same as block objects."""

import dataclasses

import pytest

from gcode.block_sequence import MoveRun, block_runs
from gcode.parser import parse
from machines import load_machine
from verification.errors import VerificationError
from verification.replay import _first_known, _motion_mask

TEXT = "G21 G90 G94\nG0 X1 Y2\nG0 X3\nG1 X4 F100\nG1 Y5\nG0 Z5\nG1 X6\nM5\nG1 X7\n"


def _as_objects(program):
    return dataclasses.replace(program, blocks=tuple(program.blocks))


def test_first_known_axis_and_motion_mask_agree_for_columns_and_objects():
    program = parse(TEXT)
    assert any(isinstance(part, MoveRun) for _, part in block_runs(program.blocks))
    machine = load_machine("grbl-router")
    objects = _as_objects(program)
    assert _first_known(program, machine) == _first_known(objects, machine) == 4
    assert _motion_mask(program).tolist() == _motion_mask(objects).tolist()


def test_an_axis_never_programmed_is_named():
    program = parse("G21\nG0 X1 Y2\nG1 X2 F100\n")
    with pytest.raises(VerificationError, match="axis Z"):
        _first_known(program, load_machine("grbl-router"))
