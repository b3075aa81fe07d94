r"""The whole-program parser: G-code text -> ``Program`` with a map to source lines.

Strict and atomic per block (see :mod:`gcode.blockparser`): the first bad block raises a
:class:`~gcode.errors.GCodeError` with its code, 1-based line and text, and nothing after
it is parsed. :func:`parse_with_errors` instead skips bad blocks (the modal state stays
as it was before each of them) and returns every error, for whole-program checks.

Understood: ``( )`` and ``;`` comments, ``/`` block delete, ``%`` delimiters, N words,
O program numbers (dialects with O words), G0-G3, G4, G17-G19, G20/G21, G54-G59,
G90/G91, G93/G94, M2/M30, M3/M4/M5, M6 with T, M7/M8/M9, F, S, P. The result is always
in mm: a G20 program parses to the same millimetre IR as its G21 twin. Units words
before the first move set ``Program.units`` (no block); later ones become ``SetUnits``.

Plain move lines (the bulk of real programs) are tokenized and applied with numpy
(:mod:`gcode._scan`) and kept as columns (a :class:`~gcode.block_sequence.BlockSequence`
of move runs, whose blocks are built when used); everything else goes through the block
parser, with identical results (``fast=False`` forces the block parser everywhere).

Examples
--------
>>> from gcode.parser import parse
>>> p = parse("G21\nG0 X0 Y0\nG1 X10 F500\n")
>>> p.blocks[1]
Linear(x=10.0, y=None, z=None, a=None, b=None, c=None, feed=500.0)
>>> p.source_lines
(2, 3)
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt

from gcode._scan import fast_run, scan
from gcode.block_sequence import BlockSequence, MoveRun
from gcode.blockparser import BlockParser
from gcode.dialects import GENERIC, Dialect
from gcode.errors import GCodeError
from gcode.program import Block, Program, Units

__all__ = ["parse", "parse_file", "parse_with_errors"]


def _parse(
    text: str,
    dialect: Dialect,
    *,
    block_delete: bool,
    collect: bool,
    fast: bool,
) -> tuple[Program, list[GCodeError]]:
    bp = BlockParser(dialect, block_delete=block_delete)
    data = text.encode("utf-8")
    sc = scan(data, dialect)
    n = sc.n_lines
    slow = sc.slow if fast else np.ones(n, dtype=np.bool_)
    slow_at = np.flatnonzero(slow)
    parts: list[tuple[Block, ...] | MoveRun] = []
    pending: list[Block] = []  # blocks of slow lines since the last move run
    lines: list[npt.NDArray[np.int64]] = []
    errors: list[GCodeError] = []

    def one(k: int) -> None:
        try:
            new = bp.parse_line(sc.line_text(k), k + 1)
        except GCodeError as err:
            if not collect:
                raise
            errors.append(err)
            return
        if new:
            pending.extend(new)
            lines.append(np.full(len(new), k + 1, dtype=np.int64))

    i = 0
    while i < n and not bp.ended:
        if slow[i]:
            one(i)
            i += 1
            continue
        at = int(np.searchsorted(slow_at, i))
        j = int(slow_at[at]) if at < slow_at.shape[0] else n
        k, moves, move_lines = fast_run(sc, i, j, bp)
        if len(moves):
            parts.append(tuple(pending))
            pending.clear()
            parts.append(moves)
            lines.append(move_lines)
        i = k
        if k < j:  # this line needs the block parser (error or arc)
            one(k)
            i = k + 1
    parts.append(tuple(pending))
    src = tuple(np.concatenate(lines).tolist()) if lines else ()
    blocks = parts[0] if len(parts) == 1 else BlockSequence(parts)
    program = Program(
        blocks,
        name=bp.name,
        number=bp.number,
        units=bp.units if bp.units is not None else Units.MM,
        source_lines=src,
    )
    return program, errors


def parse(
    text: str,
    dialect: Dialect = GENERIC,
    *,
    block_delete: bool = False,
    fast: bool = True,
) -> Program:
    """Parse G-code text strictly into a ``Program`` (mm, degrees, mm/min).

    Parameters
    ----------
    text : str
        The program.
    dialect : Dialect
        What is accepted; the default accepts everything the package understands.
    block_delete : bool
        Block-delete switch: skip lines starting with ``/`` when True.
    fast : bool
        Use the vectorized path for plain move lines (same result, faster).

    Returns
    -------
    Program
        Blocks in execution order; ``source_lines`` maps each to its 1-based line.

    Raises
    ------
    GCodeError
        At the first bad block, with ``code``, ``line`` and ``text``.
    """
    program, _ = _parse(text, dialect, block_delete=block_delete, collect=False, fast=fast)
    return program


def parse_with_errors(
    text: str,
    dialect: Dialect = GENERIC,
    *,
    block_delete: bool = False,
    fast: bool = True,
) -> tuple[Program, list[GCodeError]]:
    """Parse without stopping: bad blocks are skipped and reported.

    Each bad block leaves the modal state as it was before it, exactly as a controller
    that rejects the line and carries on.

    Parameters
    ----------
    text : str
        The program.
    dialect : Dialect
        What is accepted.
    block_delete : bool
        Block-delete switch.
    fast : bool
        Use the vectorized path for plain move lines.

    Returns
    -------
    (Program, list of GCodeError)
        The good blocks and every error in line order.
    """
    return _parse(text, dialect, block_delete=block_delete, collect=True, fast=fast)


def parse_file(
    path: str | Path, dialect: Dialect = GENERIC, *, block_delete: bool = False
) -> Program:
    """Parse the G-code file at ``path`` (UTF-8/ASCII); see :func:`parse`.

    Returns
    -------
    Program
        The parsed program.
    """
    text = Path(path).read_text(encoding="utf-8", errors="replace")
    return parse(text, dialect, block_delete=block_delete)
