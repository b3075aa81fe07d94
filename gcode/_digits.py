"""Vectorized reading of many fixed-point numbers from one byte buffer (SWAR).

The scan of :mod:`gcode._scan` knows where every number of a file starts and ends;
this module reads them all at once. Each number is read from eight-byte windows viewed
as little-endian ``uint64`` ("SIMD within a register"): the point is found and squeezed
out with bit masks, then three multiply-and-shift steps turn eight ASCII digits into
their value (Lemire's method), for millions of numbers per numpy operation.

A number ``D`` with ``d`` digits after the point is returned as the exact integer
``D * 10**d`` and ``d``; ``integer / 10.0**d`` is then the correctly rounded value,
equal to ``float(text)``, whenever the integer is below 2**53 (both operands are exact
floats and IEEE division rounds once). Numbers it cannot read that way (more than 16
characters, 2**53 or more, two points, a sign inside) are flagged for the caller,
which gives their lines to the block parser.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["EXACT_LIMIT", "PAD", "read_numbers", "windows"]

#: Bytes of zero padding the buffer needs in front of the text (one window).
PAD = 8
#: Integers below this are exact float64 values.
EXACT_LIMIT = 2**53

_U = np.uint64
_ALL = (1 << 64) - 1
# MASK[n]: the last n bytes of a window (the chunk of a number that ends the window)
_MASK = np.array([0] + [(_ALL << (8 * (8 - n))) & _ALL for n in range(1, 9)], dtype=np.uint64)
# divisors 10**d (d = 0..15, all exact) and, from index 16 on, -10**d for negatives
_DIVISOR = np.concatenate((10.0 ** np.arange(16), -(10.0 ** np.arange(16))))


def windows(padded: bytes) -> npt.NDArray[np.uint64]:
    """Overlapping eight-byte windows of ``padded`` = ``PAD`` zero bytes + text.

    ``windows(padded)[e]`` holds text bytes ``e-8 .. e-1``: the eight bytes *ending* at
    text offset ``e`` (the view shares the buffer; rows are unaligned).
    """
    return np.ndarray((len(padded) - PAD + 1,), dtype="<u8", buffer=padded, strides=(1,))


def _chunk(
    win: npt.NDArray[np.uint64], end: npt.NDArray[np.int64], n: npt.NDArray[np.int64]
) -> tuple[npt.NDArray[np.uint64], npt.NDArray[np.int64], npt.NDArray[np.bool_]]:
    """Read digit chunks of ``n <= 8`` bytes ending at ``end`` (digits and one point).

    Returns
    -------
    (value, after, bad)
        ``value``: the digits as an integer, times 10 if the chunk holds the point;
        ``after``: bytes from the point to the end (0 without a point), so the chunk's
        number is ``value / 10**after``; ``bad``: two points, or a sign in the chunk.
    """
    x = win[end]
    x &= _MASK[n]
    # '.', '+' and '-' have bit 0x20 set and 0x10 clear; digits have 0x10 set
    marks = x << _U(1)
    np.invert(marks, out=marks)
    marks &= x
    marks &= _U(0x2020202020202020)
    bad = np.bitwise_count(marks) > 1
    signs = x << _U(5)  # bit 0 is set in '+' and '-', clear in '.'
    signs &= marks
    bad |= signs != 0
    point = marks >> _U(5)  # 0x01 in the point byte
    below = point - _U(1)  # bytes before the point; all ones without a point
    after = point << _U(8)
    after -= _U(1)
    np.invert(after, out=after)  # bytes after the point; none without one
    after &= x
    after >>= _U(8)  # close the gap left by the point
    x &= below
    x |= after
    x &= _U(0x0F0F0F0F0F0F0F0F)
    x *= _U(2561)
    x >>= _U(8)
    x &= _U(0x00FF00FF00FF00FF)
    x *= _U(6553601)
    x >>= _U(16)
    x &= _U(0x0000FFFF0000FFFF)
    x *= _U(42949672960001)
    x >>= _U(32)
    n_after = 8 - (np.bitwise_count(below) >> 3).astype(np.int64)
    return x, n_after, bad


def read_numbers(
    win: npt.NDArray[np.uint64],
    end: npt.NDArray[np.int64],
    n: npt.NDArray[np.int64],
    negative: npt.NDArray[np.bool_],
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
    """Values of the numbers occupying text ``[end - n, end)``, negated where asked.

    Parameters
    ----------
    win : ndarray of uint64
        :func:`windows` of the padded text.
    end, n : ndarray of int64
        End offsets (exclusive) and lengths of the numbers: digits and at most one point,
        no sign (the caller strips it). Lengths 1..16 can be read.
    negative : ndarray of bool
        The number had a minus sign (the result is ``-float(text)``, -0.0 for zero).

    Returns
    -------
    (values, bad)
        ``values`` equal to ``float(text)`` where ``bad`` is False. ``bad`` marks numbers
        that are not ``digits[.digits]`` / ``.digits`` / ``digits.``, that have more than
        16 characters, or whose digits reach 2**53 (these need a scalar reader).
    """
    value, n_after, bad = _chunk(win, end, np.minimum(n, 8))
    bad |= (n < 1) | (n > 16)
    digits = n - (n_after > 0)  # digits in the number (the point is not one)
    bad |= digits < 1
    long = np.flatnonzero(n > 8)
    if long.shape[0]:  # 9..16 characters: add the chunk in front of the last eight bytes
        lo, lo_after = value[long], n_after[long]
        hi, hi_after, hi_bad = _chunk(win, end[long] - 8, np.clip(n[long] - 8, 0, 8))
        point_lo, point_hi = lo_after > 0, hi_after > 0
        bad[long] |= hi_bad | (point_lo & point_hi)
        # hi digits come before the 8 bytes of lo; a point in hi made hi ten times its
        # digits, one in lo made lo ten times its (7) digits: both keep lo's scale
        scale = np.where(point_hi, _U(10**7), _U(10**8))
        merged = hi * scale + lo
        value[long] = merged
        n_after[long] = np.where(point_lo, lo_after, np.where(point_hi, hi_after + 7, 0))
        bad[long] |= merged >= _U(EXACT_LIMIT)
    out = value.astype(np.float64)
    n_after += negative * 16
    out /= _DIVISOR[n_after]  # n_after <= 15 before the sign offset
    return out, bad
