"""Reading point files: CSV with a header (``x,y[,z]``) or whitespace-separated columns.

The field separator is read from the first line: a semicolon, else a comma, else
whitespace. Spreadsheets in locales whose decimal mark is a comma write ``;``-separated
files with numbers like ``143,900063``: with ``;`` a decimal comma is read as a point.
A UTF-8 byte order mark (spreadsheets' "CSV UTF-8") is skipped.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .errors import DataFileError

__all__ = ["read_points", "read_sections"]

_AXES = ("x", "y", "z")


def _parse_row(fields: list[str], *, path: str, line: int, decimal_comma: bool = False
               ) -> list[float]:
    values = []
    for field in fields:
        try:
            value = float(field.replace(",", ".") if decimal_comma else field)
        except ValueError:
            raise DataFileError(f"{field.strip()!r} is not a number", path=path,
                                line=line) from None
        if not math.isfinite(value):
            raise DataFileError(f"{field.strip()!r} is not a finite number", path=path, line=line)
        values.append(value)
    return values


def _read_lines(path: str | Path) -> list[tuple[int, str]]:
    """Numbered non-blank, non-comment lines of a text file."""
    name = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(f"cannot read the file: {exc}", path=name) from None
    lines = [
        (no, raw) for no, raw in enumerate(text.splitlines(), start=1)
        if raw.strip() and not raw.lstrip().startswith("#")
    ]
    if not lines:
        raise DataFileError("the file holds no points", path=name)
    return lines


def _table(path: str | Path, lines: list[tuple[int, str]], columns: list[int],
           n_fields: int, delimiter: str | None) -> NDArray[np.float64]:
    """The numbers of ``columns`` on every line, each line checked for ``n_fields`` fields."""
    name = str(path)
    rows = []
    for no, raw in lines:
        fields = _split(raw, delimiter)
        if len(fields) != n_fields:
            raise DataFileError(
                f"expected {n_fields} columns, found {len(fields)}: {raw.strip()!r}",
                path=name, line=no,
            )
        rows.append(_parse_row([fields[c] for c in columns], path=name, line=no,
                               decimal_comma=delimiter == ";"))
    if not rows:
        raise DataFileError("the file has a header but no points", path=name)
    return np.asarray(rows, dtype=float)


def read_points(path: str | Path) -> NDArray[np.float64]:
    """Read ordered points, in mm, from a text file.

    Accepted forms: CSV whose header names ``x``, ``y`` and optionally ``z`` (other
    columns, such as ``section``, are ignored), or 2 or 3 whitespace- or comma-separated
    numbers per line with no header. Blank lines and lines starting with ``#`` are skipped.

    Returns
    -------
    ndarray, shape (n, 2) or (n, 3)

    Raises
    ------
    DataFileError
        Naming the file and the 1-based line of the first problem.
    """
    lines = _read_lines(path)
    first_no, first = lines[0]
    delimiter = _delimiter(first)
    head = _split(first, delimiter)
    if any(_is_word(f.replace(",", ".") if delimiter == ";" else f) for f in head):
        lowered = [h.strip().lower() for h in head]
        if "x" not in lowered or "y" not in lowered:
            raise DataFileError(
                f"the header {first.strip()!r} must name columns x and y (and optionally z)",
                path=str(path), line=first_no,
            )
        columns = [lowered.index(a) for a in _AXES if a in lowered]
        return _table(path, lines[1:], columns, len(head), delimiter)
    if len(head) not in (2, 3):
        raise DataFileError(
            f"expected 2 or 3 numbers per line, found {len(head)}", path=str(path),
            line=first_no)
    return _table(path, lines, list(range(len(head))), len(head), delimiter)


def read_sections(path: str | Path) -> list[NDArray[np.float64]]:
    """Read blade sections from CSV with the header ``section,x,y,z`` (any column order).

    A section's rows stand together, its points in order; sections are taken by their
    numbers, the lowest first, in whatever order the file lists them.

    Returns
    -------
    list of ndarray, shape (n_j, 3)
        One array per section, hub to tip (validate with :func:`toolpath.as_sections`).

    Raises
    ------
    DataFileError
        A missing column, a bad number, a section number that is not an integer, or a
        section whose rows do not stand together, naming the file line.
    """
    lines = _read_lines(path)
    first_no, first = lines[0]
    delimiter = _delimiter(first)
    lowered = [h.strip().lower() for h in _split(first, delimiter)]
    missing = [c for c in ("section", *_AXES) if c not in lowered]
    if missing:
        raise DataFileError(
            f"the header {first.strip()!r} lacks column(s) {', '.join(missing)}; "
            "blade files need section,x,y,z", path=str(path), line=first_no)
    columns = [lowered.index(c) for c in ("section", *_AXES)]
    table = _table(path, lines[1:], columns, len(lowered), delimiter)
    ids = table[:, 0]
    line_numbers = [no for no, _ in lines[1:]]
    bad = ids != np.round(ids)
    if bad.any():
        i = int(np.argmax(bad))
        raise DataFileError(f"section number {ids[i]!r} is not an integer", path=str(path),
                            line=line_numbers[i])
    starts = np.flatnonzero(np.diff(ids)) + 1
    first_ids = ids[np.r_[0, starts]]
    seen: dict[float, int] = {}
    for k, value in enumerate(first_ids):
        if value in seen:
            i = int(starts[k - 1])
            raise DataFileError(
                f"section {int(value)} comes again after section {int(ids[i - 1])} (its "
                f"rows began on line {line_numbers[seen[value]]}): a section's rows must "
                "stand together", path=str(path), line=line_numbers[i])
        seen[value] = 0 if k == 0 else int(starts[k - 1])
    chunks = np.split(table, starts)
    # hub to tip by section number, however the file lists them
    return [chunks[k][:, 1:] for k in np.argsort(first_ids, kind="stable")]


def _delimiter(first_line: str) -> str | None:
    """The separator the first line uses: ``;``, else ``,``, else whitespace (None).

    (A semicolon first: beside it a comma is a decimal mark, ``1,5;2,25``.)
    """
    if ";" in first_line:
        return ";"
    return "," if "," in first_line else None


def _split(line: str, delimiter: str | None) -> list[str]:
    if delimiter is None:
        return line.split()
    return next(csv.reader(io.StringIO(line), delimiter=delimiter))


def _is_word(field: str) -> bool:
    try:
        float(field)
    except ValueError:
        return True
    return False

