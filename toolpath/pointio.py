"""Reading point files: CSV with a header (``x,y[,z]``) or whitespace-separated columns."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from .errors import DataFileError

__all__ = ["read_points"]

_AXES = ("x", "y", "z")


def _parse_row(fields: list[str], *, path: str, line: int) -> list[float]:
    values = []
    for field in fields:
        try:
            value = float(field)
        except ValueError:
            raise DataFileError(f"{field.strip()!r} is not a number", path=path,
                                line=line) from None
        if not math.isfinite(value):
            raise DataFileError(f"{field.strip()!r} is not a finite number", path=path, line=line)
        values.append(value)
    return values


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
    name = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(f"cannot read the file: {exc}", path=name) from None
    lines = [
        (no, raw) for no, raw in enumerate(text.splitlines(), start=1)
        if raw.strip() and not raw.lstrip().startswith("#")
    ]
    if not lines:
        raise DataFileError("the file holds no points", path=name)
    first_no, first = lines[0]
    delimiter = "," if "," in first else None
    head = _split(first, delimiter)
    if any(_is_word(f) for f in head):
        lowered = [h.strip().lower() for h in head]
        if "x" not in lowered or "y" not in lowered:
            raise DataFileError(
                f"the header {first.strip()!r} must name columns x and y (and optionally z)",
                path=name, line=first_no,
            )
        columns = [lowered.index(a) for a in _AXES if a in lowered]
        expected_fields = len(head)
        body = lines[1:]
    else:
        if len(head) not in (2, 3):
            raise DataFileError(
                f"expected 2 or 3 numbers per line, found {len(head)}", path=name, line=first_no
            )
        columns = list(range(len(head)))
        expected_fields = len(head)
        body = lines
    rows = []
    for no, raw in body:
        fields = _split(raw, delimiter)
        if len(fields) != expected_fields:
            raise DataFileError(
                f"expected {expected_fields} columns, found {len(fields)}: {raw.strip()!r}",
                path=name, line=no,
            )
        rows.append(_parse_row([fields[c] for c in columns], path=name, line=no))
    if not rows:
        raise DataFileError("the file has a header but no points", path=name)
    return np.asarray(rows, dtype=float)


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

