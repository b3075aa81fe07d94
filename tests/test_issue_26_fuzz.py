"""Issue 26: a bounded fuzz of the parser, the fitters and the command line (a few seconds).

The cases come from ``benchmarks/fuzz.py`` (one set of generators; the benchmark runs them
for minutes in child processes with time-outs); here a fixed seed and a fixed number of
cases run in this process:

* parser: mutated blocks, each ``gcode.parse`` returning a program or raising
  ``GCodeError`` (public API only), numbers beyond float range and the long digit runs
  that once made the tokenizer backtrack included (``hostile=True``);
* fitters: random point sets (NaN/inf, duplicates, int dtype, one to three points, huge
  and tiny scales, random order, random options): a fit or a ``ToolpathError``;
* command line: random argv from the real commands and flags, bad files: exit 0, 1 or 2,
  no traceback on stderr.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import fuzz  # benchmarks/fuzz.py

SEED = 26


def _problems(name: str, count: int, **make) -> list[str]:
    target = fuzz.TARGETS[name]
    found = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for case in fuzz.cases(target, SEED, count, **make):
            problem = fuzz.check_case(target, case)
            if problem is not None:
                found.append(f"{problem}\n  {target.reproducer(case)}")
    return found


def test_mutated_gcode_lines_parse_or_raise_gcode_error():
    assert _problems("parser", 3000, hostile=True) == []


def test_random_point_sets_fit_or_raise_toolpath_error():
    assert _problems("fitters", 40) == []


def test_random_command_lines_exit_0_1_or_2_without_traceback(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)  # the fuzz files' folder is made (and entered) on first use
    assert _problems("cli", 40) == []


@pytest.mark.parametrize("name", sorted(fuzz.TARGETS))
def test_the_cases_are_reproducible_from_the_seed(name):
    target = fuzz.TARGETS[name]
    first = [target.reproducer(c) for c in fuzz.cases(target, SEED, 20)]
    assert first == [target.reproducer(c) for c in fuzz.cases(target, SEED, 20)]
    assert len(set(first)) > 10
