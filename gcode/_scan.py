"""Vectorized fast path of the parser: whole-file tokenizing and runs of plain moves.

:func:`scan` classifies every line of a file at once with numpy. A line is *fast* when it
holds only upper-case words from ``G X Y Z A B C F N`` (axes limited to the dialect),
each at most once, with well-formed fixed-point numbers (at most 16 characters, read
exactly as ``float(text)`` by :mod:`gcode._digits`), spaces only between words, G only 0
or 1, non-negative F, a valid N, and fits the dialect's line limit. Every other line
(comments, M/S/T words, arcs, anything suspicious) is *slow* and goes through
:class:`~gcode.blockparser.BlockParser`, which raises the exact error.

The scan touches each byte a few times only: one ``bytes.translate`` into character
classes, one pass for the positions of the non-number bytes (letters, spaces, newlines,
others), and from then on works per word: a word's number is the run of bytes between
its letter and the next such position.

:func:`fast_run` applies a run of consecutive fast lines to the modal state with array
operations: motion mode and feed are forward-filled from the state at the start of the
run, and the first row that would be an error or an arc move stops the run, so that row
is handed to the block parser. The moves become a :class:`~gcode.block_sequence.MoveRun`
(columns, no block objects). The result is identical to parsing each line with the block
parser (tests check this on random and mutated programs).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np
import numpy.typing as npt

from gcode._digits import PAD, read_numbers, windows
from gcode.block_sequence import MoveRun
from gcode.blockparser import MAX_LINE_NUMBER, BlockParser
from gcode.dialects import Dialect
from gcode.numbers import MM_PER_INCH
from gcode.program import AXES, DistanceMode, FeedMode, Units

__all__ = ["Scan", "fast_run", "scan"]

_COLS = "GXYZABCFN"
_G, _F, _N = 0, 7, 8

# character classes: digits, point and signs make up numbers (class 0), the others
# end them
_NUM, _SPACE, _NL, _LETTER, _OTHER = range(5)


@lru_cache(maxsize=8)
def _tables(axes: tuple[str, ...]) -> tuple[bytes, npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    """Byte -> class table, and for letters byte -> column of ``_COLS`` and 2**column."""
    cls = bytearray([_OTHER]) * 256
    for ch in b" \t\r":
        cls[ch] = _SPACE
    cls[ord("\n")] = _NL
    for ch in b"0123456789.+-":
        cls[ch] = _NUM
    col = np.zeros(256, dtype=np.int64)
    for n, ch in enumerate(_COLS):
        if ch.lower() in AXES and ch.lower() not in axes:
            continue  # axis the dialect lacks: slow path reports it
        cls[ord(ch)] = _LETTER
        col[ord(ch)] = n
    return bytes(cls), col, np.ldexp(1.0, col)


@dataclass
class Scan:
    """Per-line results of :func:`scan`.

    Attributes
    ----------
    data : bytes
        The UTF-8 text.
    starts, ends : ndarray of int64
        Byte offsets of each line (``ends`` excludes the newline).
    slow : ndarray of bool
        Lines the block parser must handle.
    values : ndarray of float64, shape (n_lines, 9)
        Values of words ``G X Y Z A B C F N`` in text units; NaN where absent (and
        meaningless on slow lines).
    """

    data: bytes
    starts: npt.NDArray[np.int64]
    ends: npt.NDArray[np.int64]
    slow: npt.NDArray[np.bool_]
    values: npt.NDArray[np.float64]

    @property
    def n_lines(self) -> int:
        """Number of lines."""
        return int(self.starts.shape[0])

    def line_text(self, i: int) -> str:
        """Return line ``i`` (0-based) as text."""
        return self.data[int(self.starts[i]) : int(self.ends[i])].decode("utf-8", "replace")


def scan(data: bytes, dialect: Dialect) -> Scan:
    """Classify and tokenize all lines of ``data`` at once.

    The text is handled in pieces of about :data:`PIECE_BYTES` whole lines, so that the
    per-word arrays stay in the processor caches.

    Parameters
    ----------
    data : bytes
        UTF-8 G-code text.
    dialect : Dialect
        Decides which axis letters are fast and the line-length limit.

    Returns
    -------
    Scan
        Line offsets, slow-line mask and word values of the fast lines.
    """
    table, col_table, bit_table = _tables(dialect.axes)
    padded = bytes(PAD) + data + (b"" if data.endswith(b"\n") else b"\n")
    text = _Text(
        np.frombuffer(padded, dtype=np.uint8, offset=PAD),
        np.frombuffer(padded.translate(table), dtype=np.uint8, offset=PAD),
        windows(padded),
        col_table,
        bit_table,
    )
    size = len(padded) - PAD
    pieces = []
    a = 0
    while a < size:
        b = padded.find(b"\n", PAD + min(a + PIECE_BYTES, size - 1)) - PAD + 1
        pieces.append(_scan_piece(text, a, b))
        a = b
    if not pieces:  # pragma: no cover - the padded text always holds a newline
        raise AssertionError("scan of an empty text")
    starts, ends, slow, values = (np.concatenate(p) for p in zip(*pieces, strict=True))
    if dialect.max_line_length is not None:
        slow |= (ends - starts) > dialect.max_line_length
    return Scan(data, starts, ends, slow, values)


#: Bytes of text scanned per piece (whole lines; a line longer than this is one piece).
PIECE_BYTES = 1 << 19


@dataclass(frozen=True)
class _Text:
    raw: npt.NDArray[np.uint8]  # the text (ends with a newline)
    cls: npt.NDArray[np.uint8]  # character class of every byte
    win: npt.NDArray[np.uint64]  # windows(padded)
    col_table: npt.NDArray[np.int64]  # letter byte -> column of _COLS
    bit_table: npt.NDArray[np.float64]  # letter byte -> 2.0**column


def _scan_piece(
    text: _Text, a: int, b: int
) -> tuple[
    npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.bool_], npt.NDArray[np.float64]
]:
    """Scan the lines in text bytes ``a .. b-1`` (``b - 1`` is a newline).

    Returns the starts, ends, slow mask and (n, 9) values of those lines.
    """
    raw = text.raw[a:b]
    cls = text.cls[a:b]
    # positions of the bytes that are not part of numbers, and their classes
    bnd = np.flatnonzero(cls)
    bcls = cls[bnd]
    is_nl = bcls == _NL
    nl = bnd[is_nl]
    n_lines = nl.shape[0]
    starts = np.empty(n_lines, dtype=np.int64)
    starts[:1] = 0
    starts[1:] = nl[:-1] + 1
    slow = np.zeros(n_lines, dtype=np.bool_)

    def mark(pos: npt.NDArray[np.int64]) -> None:
        slow[np.searchsorted(nl, pos)] = True

    other = bcls == _OTHER
    if other.any():
        mark(bnd[other])
    li = np.flatnonzero(bcls == _LETTER)  # letters, as indices into bnd
    letters = bnd[li]
    gap = np.diff(bnd)  # > 1: a number follows boundary k
    word_len = gap[li]  # letter + number
    # every number run must follow a letter (a letter without one is read as bad below)
    if np.count_nonzero(gap > 1) != np.count_nonzero(word_len > 1):
        # a number after a space or newline ("X1 0", a line starting with a digit)
        loose = np.flatnonzero((gap > 1) & (bcls[:-1] != _LETTER))
        mark(bnd[loose] + 1)
    if cls[0] == _NUM:
        slow[0] = True
    line_of = np.cumsum(is_nl, dtype=np.int32)[li]  # newlines before each letter
    letter = raw[letters]
    col = text.col_table[letter]
    # numbers: an optional sign right after the letter, then digits and one point
    end = letters + word_len
    first = raw[letters + 1]  # a letter is never last: the text ends with a newline
    minus = first == ord("-")
    signed = minus | (first == ord("+"))
    nums, bad = read_numbers(text.win[a:], end, word_len - 1 - signed, minus)
    if bad.any():
        slow[line_of[bad]] = True
    values = np.full(n_lines * len(_COLS), np.nan)
    values[line_of * len(_COLS) + col] = nums
    values = values.reshape(n_lines, len(_COLS))
    # a letter twice on one line: adding the lines' 2**column values carries, so the
    # sum has fewer one bits than the line has words
    words = np.bincount(line_of, minlength=n_lines)
    bits = np.bincount(line_of, weights=text.bit_table[letter], minlength=n_lines)
    slow |= np.bitwise_count(bits.astype(np.uint16)) != words
    g = values[:, _G]
    f = values[:, _F]
    nw = values[:, _N]
    with np.errstate(invalid="ignore"):
        slow |= ~np.isnan(g) & (g != 0.0) & (g != 1.0)
        slow |= f < 0.0
        slow |= ~np.isnan(nw) & ((nw < 0.0) | (nw != np.floor(nw)) | (nw > MAX_LINE_NUMBER))
    return starts + a, nl + a, slow, values


def _ffill(
    values: npt.NDArray[np.float64], has: npt.NDArray[np.bool_], initial: float
) -> npt.NDArray[np.float64]:
    m = values.shape[0]
    at = np.where(has, np.arange(m), -1)
    np.maximum.accumulate(at, out=at)
    return np.where(at >= 0, values[np.maximum(at, 0)], initial)


def fast_run(
    sc: Scan, i: int, j: int, bp: BlockParser
) -> tuple[int, MoveRun, npt.NDArray[np.int64]]:
    """Apply fast lines ``i .. j-1`` to ``bp.state`` until one needs the block parser.

    Parameters
    ----------
    sc : Scan
        Result of :func:`scan`.
    i, j : int
        0-based line range of consecutive fast lines.
    bp : BlockParser
        Its state is read at the start and committed at the end.

    Returns
    -------
    (k, moves, lines)
        Lines ``i .. k-1`` were applied; ``k < j`` means line ``k`` must go through the
        block parser (an error, or an arc move in modal G2/G3). ``moves`` holds their
        rapid and linear moves (mm, degrees, effective feed) and ``lines`` the 1-based
        line of each move.
    """
    st = bp.state
    vals = sc.values[i:j]
    m = vals.shape[0]
    axes = vals[:, 1:7]
    present = ~np.isnan(axes)
    has_axes = present.any(axis=1)
    g = vals[:, _G]
    motion = _ffill(g, ~np.isnan(g), float(int(st.motion)))
    inch = st.units is Units.INCH
    inverse = st.feed_mode is FeedMode.INVERSE_TIME
    f = vals[:, _F]
    f_has = ~np.isnan(f)
    f_mm = f * MM_PER_INCH if (inch and not inverse) else f
    feed = _ffill(f_mm, f_has, np.nan if st.feed is None else st.feed)
    # a G1 needs a feed with axis words or, written out, without them (GRBL error 22)
    feed_move = (has_axes & (motion == 1.0)) | (g == 1.0)
    with np.errstate(invalid="ignore"):
        if inverse:
            bad = feed_move & ~(f_has & (f > 0.0))
        else:
            bad = feed_move & ~(feed > 0.0)
    bad |= has_axes & (motion >= 2.0)
    bad_at = np.flatnonzero(bad)
    k = int(bad_at[0]) if bad_at.shape[0] else m
    rows = np.flatnonzero(has_axes[:k])
    mm = axes[rows]  # a copy; NaN stays NaN
    if inch:
        mm[:, :3] *= MM_PER_INCH
    kind = motion[rows].astype(np.int8)
    moves = MoveRun(kind, mm, np.where(kind == 1, feed[rows], np.nan))
    if k == 0:
        return i, moves, rows + (i + 1)

    # commit: motion, feed and position after line k-1
    position = list(st.position)
    incremental = st.distance is DistanceMode.INCREMENTAL
    for n in range(6):
        col = mm[:, n]
        col = col[~np.isnan(col)]
        if not col.shape[0]:
            continue
        if incremental:
            position[n] = float(np.cumsum(np.concatenate(([position[n]], col)))[-1])
        else:
            position[n] = float(col[-1])
    last_feed = float(feed[k - 1])
    bp.state = replace(
        st,
        motion=type(st.motion)(int(motion[k - 1])),
        feed=None if np.isnan(last_feed) else last_feed,
        position=tuple(position),  # type: ignore[arg-type]
    )
    if rows.shape[0]:
        bp.motion_seen = True
    return i + k, moves, rows + (i + 1)
