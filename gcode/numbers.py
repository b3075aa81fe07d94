"""The one number formatter and reader for all G-code text.

Every number the emitter writes goes through :func:`format_number` (one value) or
:func:`format_slots` / :func:`format_matrix` (a whole column, vectorized with numpy,
same text); the parser reads numbers
with :func:`read_number` or the same grammar (:data:`NUMBER_PATTERN`). Rules:

* fixed point with a number of decimals chosen by the kind of value (:class:`Decimals`);
* never an exponent (``1e-05``), never ``-0``, never ``nan``/``inf`` (refused);
* independent of the process locale (no ``locale`` calls, ASCII digits and ``.`` only);
* optional trim of trailing zeros (``1.500`` -> ``1.5``, ``2.000`` -> ``2``) and an option
  to keep the decimal point on integral values (``2.``) for Fanuc-style controls, where a
  coordinate without a point is read in least-input increments (``X2`` = 0.002 mm).

Rounding is half-to-even of ``value * 10**decimals`` in binary floating point, identical
in the scalar and the vectorized paths (``round`` and ``np.rint`` agree on every float).

Examples
--------
>>> from gcode.numbers import format_number, read_number
>>> format_number(-0.0004, 3), format_number(1e-20, 3), format_number(12.5, 3)
('0', '0', '12.5')
>>> format_number(2.0, 3, keep_point=True), format_number(1e21, 3)
('2.', '1000000000000000000000')
>>> read_number("-.5"), read_number("10.")
(-0.5, 10.0)
"""

from __future__ import annotations

import math
import re
from functools import lru_cache

import numpy as np
import numpy.typing as npt

from gcode.decimals import Decimals, NumberKind
from gcode.errors import ErrorCode, SyntaxGCodeError

__all__ = [
    "MM_PER_INCH",
    "NUMBER_PATTERN",
    "Decimals",
    "NumberKind",
    "format_array",
    "format_matrix",
    "format_number",
    "format_slots",
    "read_number",
]

#: Millimetres per inch, exact by definition (1959 international inch). Lengths are
#: converted with ``mm / MM_PER_INCH`` and ``inch * MM_PER_INCH``; never with a rounded
#: reciprocal, and never for rotary axes.
MM_PER_INCH = 25.4

#: The number grammar shared by emitter and parser: optional sign, digits with an
#: optional point, or a point followed by digits. ASCII digits only; no exponent.
#: Written without ambiguous repetition (a digit run can be split only one way) and with
#: possessive quantifiers, so a regex built from it never backtracks: matching takes time
#: linear in the text's length, even for lines that almost match (issue 26).
NUMBER_PATTERN = r"[+-]?+(?:[0-9]++(?:\.[0-9]*+)?+|\.[0-9]++)"
_NUMBER_RE = re.compile(NUMBER_PATTERN)

# Values whose scaled magnitude exceeds this leave the int64 vector path.
_VECTOR_LIMIT = 2.0**62


def _not_finite(value: float) -> SyntaxGCodeError:
    return SyntaxGCodeError(ErrorCode.NOT_FINITE, f"cannot write {value!r} as G-code")


def format_number(
    value: float, decimals: int = 3, *, trim: bool = True, keep_point: bool = False
) -> str:
    """Format one value as fixed-point G-code text.

    Parameters
    ----------
    value : float
        The value, already in the output unit (mm, inch, degrees, ...).
    decimals : int
        Digits after the point (0-9).
    trim : bool
        Drop trailing zeros of the fraction (and the point if nothing is left).
    keep_point : bool
        With ``decimals > 0``, keep a trailing ``.`` on integral values (``2.``).

    Returns
    -------
    str
        ASCII text: optional ``-``, digits, optional point and fraction.

    Raises
    ------
    GCodeError
        Code NOT_FINITE for NaN or infinity.
    """
    value = float(value)
    if not math.isfinite(value):
        raise _not_finite(value)
    if abs(value) < 1e15:
        q = round(value * (10**decimals))
    else:  # beyond 2**50 floats are (nearly) integers: exact decimal rounding
        from fractions import Fraction  # only here: it loads the decimal module

        q = round(Fraction(value) * 10**decimals)  # exact, half to even
    digits = str(abs(q))
    sign = "-" if q < 0 else ""
    if decimals == 0:
        return sign + digits
    digits = digits.rjust(decimals + 1, "0")
    whole, frac = digits[:-decimals], digits[-decimals:]
    if trim:
        frac = frac.rstrip("0")
    if frac:
        return f"{sign}{whole}.{frac}"
    return f"{sign}{whole}." if keep_point else sign + whole


#: Digits of 0..9999, four ASCII codes each (zero padded): whole parts are written four
#: digits per table look-up instead of one digit per division.
_DIGITS4 = (ord("0") + np.arange(10_000)[:, None] // np.array([1000, 100, 10, 1]) % 10
            ).astype(np.uint8)
# the same rows as one uint32 each: a 1-D gather is far cheaper than a 2-D one
_DIGITS4_U32 = np.ascontiguousarray(_DIGITS4).view(np.uint32).ravel()
# keep masks of a right-aligned 4-digit field by digit count 0..4, as uint32 rows
_KEEP4_U32 = (
    np.array([[0] * (4 - k) + [1] * k for k in range(5)], dtype=np.uint8).view(np.uint32).ravel()
)
# keep masks of a left-aligned 4-digit field by digit count 0..4 (fractions)
_KEEP4_LEFT_U32 = (
    np.array([[1] * k + [0] * (4 - k) for k in range(5)], dtype=np.uint8).view(np.uint32).ravel()
)
# fraction lengths left after trimming trailing zeros, for up to 4 decimals
# (``decimals`` less one per trailing zero of the fraction's digits; none left for 0)
_FRAC_TRIMMED = {
    d: (d - sum(np.arange(10**d) % 10**k == 0 for k in range(1, d + 1))).astype(np.int8)
    for d in range(1, 5)
}


def _digits4(values: npt.NDArray[np.int64]) -> npt.NDArray[np.uint8]:
    """Four zero-padded digits (n, 4) of values in 0..9999."""
    return _DIGITS4_U32[values].view(np.uint8).reshape(values.shape[0], 4)


def _frac_digits(
    frac: npt.NDArray[np.int64], decimals: int, trim: bool
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.bool_]]:
    """Fraction digits (n, decimals) and which of them are written (n, decimals)."""
    n = frac.shape[0]
    if decimals <= 4:
        chars = _digits4(frac)[:, 4 - decimals :]
        n_frac = _FRAC_TRIMMED[decimals][frac] if trim else np.full(n, decimals, np.int8)
        keep = _KEEP4_LEFT_U32[n_frac].view(np.bool_).reshape(n, 4)[:, :decimals]
        return chars, keep
    chars = np.empty((n, decimals), dtype=np.uint8)
    rest = frac
    n_kept = np.full(n, decimals, dtype=np.int64)
    for m in range(decimals - 1, -1, -1):
        rest, digit = np.divmod(rest, 10)
        chars[:, m] = digit + 48
    if trim:
        for k in range(1, decimals + 1):
            n_kept -= (frac % (10**k)) == 0
    return chars, np.arange(decimals) < n_kept[:, None]


def format_matrix(
    values: npt.ArrayLike, decimals: int = 3, *, trim: bool = True, keep_point: bool = False
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.bool_]] | None:
    """Format a column of values into a character matrix, vectorized.

    Row ``n`` of ``chars[keep]`` (row-major) is exactly ``format_number(values[n], ...)``.
    The emitter places such matrices side by side and compresses them with one boolean
    index into the bytes of many lines at once. Digits and their keep masks come from
    look-up tables (four digits per table row, one uint32 gather), not one division per
    digit.

    Parameters
    ----------
    values : array_like of float, shape (n,)
        Values in the output unit.
    decimals : int
        Digits after the point (0-9).
    trim : bool
        Drop trailing zeros of the fraction.
    keep_point : bool
        Keep a trailing point on integral values when ``decimals > 0``.

    Returns
    -------
    (chars, keep) or None
        ``chars`` uint8 (n, w) ASCII codes and ``keep`` bool (n, w); None when some
        value is too large for the int64 path (callers then use :func:`format_number`).

    Raises
    ------
    GCodeError
        Code NOT_FINITE if any value is NaN or infinite.
    """
    v = np.asarray(values, dtype=np.float64)
    n = v.shape[0]
    top_value = float(np.abs(v).max()) if n else 0.0
    if not math.isfinite(top_value):
        raise _not_finite(float(v[~np.isfinite(v)][0]))
    if top_value >= 1e15:  # format_number's exact-decimal range
        return None
    q = np.rint(v * float(10**decimals))
    mag_f = np.abs(q)
    top_q = float(mag_f.max()) if n else 0.0
    if top_q >= _VECTOR_LIMIT:
        return None
    scale = 10**decimals
    if top_q < 2.0**52:  # exact in float64: floor division without int64 divmod
        whole = np.floor(mag_f / scale).astype(np.int64)
        frac = (mag_f - whole * float(scale)).astype(np.int64)
    else:
        whole, frac = np.divmod(mag_f.astype(np.int64), scale)
    n_whole_max = len(str(int(top_q) // scale))
    groups = -(-n_whole_max // 4)
    width = 1 + n_whole_max + (1 + decimals if decimals else 0)
    chars = np.empty((n, width), dtype=np.uint8)
    keep = np.empty((n, width), dtype=np.bool_)
    chars[:, 0] = ord("-")
    keep[:, 0] = q < 0.0  # -0.0 is not below zero: never "-0"
    n_whole = np.ones(n, dtype=np.int64)
    for k in range(1, n_whole_max):
        n_whole += whole >= 10**k
    if groups == 1:
        chars[:, 1 : 1 + n_whole_max] = _digits4(whole)[:, 4 - n_whole_max :]
        keep4 = _KEEP4_U32[n_whole].view(np.bool_).reshape(n, 4)
        keep[:, 1 : 1 + n_whole_max] = keep4[:, 4 - n_whole_max :]
    else:
        parts, rest = [], whole
        for _ in range(groups):
            rest, group = np.divmod(rest, 10_000)
            parts.append(_digits4(group))
        digits = np.concatenate(parts[::-1], axis=1)
        chars[:, 1 : 1 + n_whole_max] = digits[:, 4 * groups - n_whole_max :]
        keep[:, 1 : 1 + n_whole_max] = np.arange(n_whole_max, 0, -1) <= n_whole[:, None]
    if decimals:
        point = 1 + n_whole_max
        fchars, fkeep = _frac_digits(frac, decimals, trim)
        chars[:, point] = ord(".")
        keep[:, point] = fkeep[:, 0] | keep_point
        chars[:, point + 1 :] = fchars
        keep[:, point + 1 :] = fkeep
    return chars, keep


@lru_cache(maxsize=1)
def _whole_tables() -> dict[str, npt.NDArray[np.uint32]]:
    """Text slots of whole parts, four bytes each, NUL where nothing is written.

    ``full``: 0..9999 zero padded; ``lead``: the same right-aligned without leading
    zeros (one ``0`` for zero); ``blank``: like ``lead`` but empty for zero (leading
    groups of large numbers); ``signed``: ``lead`` of 0..999, then ``-0``..``-999``.
    """
    full = [f"{i:04d}" for i in range(10_000)]
    lead = [str(i) for i in range(10_000)]
    blank = ["", *lead[1:]]
    signed = [*lead[:1000], *("-" + t for t in lead[:1000])]
    return {
        name: np.frombuffer(b"".join(t.encode().rjust(4, b"\0") for t in texts), np.uint32)
        for name, texts in (("full", full), ("lead", lead), ("blank", blank), ("signed", signed))
    }


@lru_cache(maxsize=32)
def _fraction_tables(
    decimals: int, trim: bool, keep_point: bool
) -> tuple[npt.NDArray[np.uint32] | npt.NDArray[np.uint16], ...]:
    """Point and fraction of 0 .. 10**decimals - 1 as 4- and 2-byte slot tables."""
    width = 2 * -(-(decimals + 1) // 2)
    rows = []
    for i in range(10**decimals):
        frac = f"{i:0{decimals}d}"
        if trim:
            frac = frac.rstrip("0")
        text = "." + frac if frac or keep_point else ""
        rows.append(text.encode().ljust(width, b"\0"))
    table = np.frombuffer(b"".join(rows), dtype=np.uint8).reshape(10**decimals, width)
    return tuple(
        np.ascontiguousarray(table[:, c : c + 4 if width - c >= 4 else c + 2]).view(
            np.uint32 if width - c >= 4 else np.uint16
        )[:, 0]
        for c in range(0, width, 4)
    )


def format_slots(
    values: npt.ArrayLike, decimals: int = 3, *, trim: bool = True, keep_point: bool = False
) -> list[npt.NDArray[np.uint32] | npt.NDArray[np.uint16]] | None:
    """Format a column of values as columns of NUL-padded text slots.

    Row ``n``'s text is the bytes of ``slot[n]`` for each returned slot column in order,
    with their NUL bytes deleted: exactly ``format_number(values[n], ...)``. The emitter
    writes such columns side by side into a line matrix and deletes all NUL bytes at
    once. Sign and whole part below 1000 come from one table look-up, larger whole parts
    four digits per look-up, the point and fraction (trimmed or not) from one more when
    ``decimals <= 4``; more decimals go through :func:`format_matrix`.

    Parameters
    ----------
    values : array_like of float, shape (n,)
        Values in the output unit.
    decimals : int
        Digits after the point (0-9).
    trim : bool
        Drop trailing zeros of the fraction.
    keep_point : bool
        Keep a trailing point on integral values when ``decimals > 0``.

    Returns
    -------
    list of ndarray of uint32 or uint16, each shape (n,), or None
        The slot columns (4 or 2 bytes of text per row); None when some value is too
        large for the vector path (callers then use :func:`format_number`).

    Raises
    ------
    GCodeError
        Code NOT_FINITE if any value is NaN or infinite.
    """
    v = np.asarray(values, dtype=np.float64)
    n = v.shape[0]
    if n == 0:
        return []
    if decimals > 4:
        return _slots_of_matrix(format_matrix(v, decimals, trim=trim, keep_point=keep_point))
    scale = float(10**decimals)
    q = v * scale
    np.rint(q, out=q)
    negative = q < 0.0  # -0.0 is not below zero: never "-0"
    np.abs(q, out=q)
    top_q = float(q.max())
    if not math.isfinite(top_q):
        raise _not_finite(float(v[~np.isfinite(v)][0]))
    if top_q >= _VECTOR_LIMIT or float(np.abs(v).max()) >= 1e15:
        return None
    if top_q < 2.0**52:  # exact in float64: floor division without int64 divmod
        whole_f = q / scale
        np.floor(whole_f, out=whole_f)
        whole = whole_f.astype(np.intp)
        whole_f *= scale
        q -= whole_f
        frac = q.astype(np.intp)
    else:
        whole, frac = np.divmod(q.astype(np.int64), 10**decimals)
    tables = _whole_tables()
    top_whole = int(top_q) // 10**decimals
    slots: list[npt.NDArray[np.uint32] | npt.NDArray[np.uint16]] = []
    if top_whole < 1000:  # sign and up to three digits in four bytes
        whole += negative * 1000
        slots.append(tables["signed"][whole])
    else:
        slots.append(np.where(negative, _MINUS_SLOT, _NUL_SLOT))
        groups = -(-len(str(top_whole)) // 4)
        above = np.zeros(n, dtype=np.bool_)  # a higher group is not zero
        for g in range(groups):
            unit = 10 ** (4 * (groups - 1 - g))
            group = (whole // unit) % 10_000
            first = tables["lead" if g == groups - 1 else "blank"][group]
            slots.append(np.where(above, tables["full"][group], first))
            above |= group > 0
    if decimals:
        slots.extend(table[frac] for table in _fraction_tables(decimals, trim, keep_point))
    return slots


_MINUS_SLOT = np.frombuffer(b"\0-", dtype=np.uint16)[0]
_NUL_SLOT = np.uint16(0)


def _slots_of_matrix(
    res: tuple[npt.NDArray[np.uint8], npt.NDArray[np.bool_]] | None,
) -> list[npt.NDArray[np.uint32] | npt.NDArray[np.uint16]] | None:
    """Slot columns from :func:`format_matrix` output (kept characters, NUL elsewhere)."""
    if res is None:
        return None
    chars, keep = res
    n, w = chars.shape
    text = np.zeros((n, w + w % 2), dtype=np.uint8)
    text[:, :w] = np.where(keep, chars, 0)
    pairs = text.view(np.uint16)
    return [np.ascontiguousarray(pairs[:, c]) for c in range(pairs.shape[1])]


def format_array(
    values: npt.ArrayLike, decimals: int = 3, *, trim: bool = True, keep_point: bool = False
) -> list[str]:
    """Format a column of values to a list of strings (vectorized where possible).

    Parameters
    ----------
    values : array_like of float, shape (n,)
        Values in the output unit.
    decimals : int
        Digits after the point.
    trim : bool
        Drop trailing zeros of the fraction.
    keep_point : bool
        Keep a trailing point on integral values when ``decimals > 0``.

    Returns
    -------
    list of str
        Same text as :func:`format_number` for every value.
    """
    v = np.asarray(values, dtype=np.float64)
    res = format_matrix(v, decimals, trim=trim, keep_point=keep_point)
    if res is None:
        return [format_number(x, decimals, trim=trim, keep_point=keep_point) for x in v]
    chars, keep = res
    lengths = keep.sum(axis=1)
    flat = chars[keep].tobytes().decode("ascii")
    ends = np.cumsum(lengths).tolist()
    starts = [0, *ends[:-1]]
    return [flat[s:e] for s, e in zip(starts, ends, strict=True)]


def read_number(text: str) -> float:
    """Read one number written by the formatter (or any plain fixed-point number).

    Parameters
    ----------
    text : str
        ``[+-]digits[.digits]`` or ``[+-].digits``; no spaces, no exponent.

    Returns
    -------
    float
        The value (correctly rounded, as ``float(text)``).

    Raises
    ------
    GCodeError
        Code BAD_NUMBER_FORMAT for anything else (``1e-3``, ``nan``, ``1,5``, ``""``), and
        for numbers beyond the float range (more than 308 integer digits).
    """
    if _NUMBER_RE.fullmatch(text) is None:
        raise SyntaxGCodeError(ErrorCode.BAD_NUMBER_FORMAT, f"not a fixed-point number: {text!r}")
    value = float(text)
    if not math.isfinite(value):
        raise SyntaxGCodeError(
            ErrorCode.BAD_NUMBER_FORMAT,
            f"a number of {len(text)} characters is beyond the floating-point range (1.8e308)",
        )
    return value
