"""Vectorized fast path of the parser: whole-file tokenizing and runs of plain moves.

:func:`scan` classifies every line of a file at once with numpy. A line is *fast* when it
holds only upper-case words from ``G X Y Z A B C F N`` (axes limited to the dialect),
each at most once, with well-formed fixed-point numbers (read by numpy's correctly
rounded ``strtod``, so values equal ``float(text)``), spaces only between words, G only
0 or 1, non-negative F, a valid N, and fits the dialect's line limit. Every other line
(comments, M/S/T words, arcs,
anything suspicious) is *slow* and goes through :class:`~gcode.blockparser.BlockParser`,
which raises the exact error.

:func:`fast_run` applies a run of consecutive fast lines to the modal state with array
operations: motion mode and feed are forward-filled from the state at the start of the
run, and the first row that would be an error or an arc move stops the run, so that row
is handed to the block parser. The result is identical to parsing each line with the
block parser (tests check this).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from gcode.blockparser import MAX_LINE_NUMBER, BlockParser
from gcode.dialects import Dialect
from gcode.numbers import MM_PER_INCH
from gcode.program import AXES, DistanceMode, FeedMode, Linear, Rapid, Units, _build_many

__all__ = ["Scan", "fast_run", "scan"]

_COLS = "GXYZABCFN"
_G, _F, _N = 0, 7, 8

# character classes (digits and the point first: the scan splits on "> _DOT")
_DIGIT, _DOT, _OTHER, _SPACE, _NL, _SIGN, _LETTER = range(7)


def _classes(dialect: Dialect) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.int64]]:
    cls = np.full(256, _OTHER, dtype=np.uint8)
    for ch in " \t\r":
        cls[ord(ch)] = _SPACE
    cls[ord("\n")] = _NL
    cls[ord("0") : ord("9") + 1] = _DIGIT
    cls[ord(".")] = _DOT
    cls[ord("+")] = cls[ord("-")] = _SIGN
    col = np.full(256, -1, dtype=np.int64)
    for n, ch in enumerate(_COLS):
        if ch.lower() in AXES and ch.lower() not in dialect.axes:
            continue  # axis the dialect lacks: slow path reports it
        cls[ord(ch)] = _LETTER
        col[ord(ch)] = n
    return cls, col


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
        Values of words ``G X Y Z A B C F N`` in text units; NaN where absent.
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
    raw = np.frombuffer(data, dtype=np.uint8)
    n = raw.shape[0]
    buf = np.concatenate((raw, np.full(3, ord("\n"), dtype=np.uint8)))  # look-ahead pad
    cls_table, col_table = _classes(dialect)
    nl = np.flatnonzero(raw == ord("\n"))
    starts = np.concatenate(([0], nl + 1)).astype(np.int64)
    ends = np.concatenate((nl, [n])).astype(np.int64)
    if data.endswith(b"\n"):
        starts, ends = starts[:-1], ends[:-1]
    n_lines = starts.shape[0]
    cls = cls_table[buf]
    head = cls[:n]
    slow = np.zeros(n_lines + 1, dtype=np.bool_)

    def mark(pos: npt.NDArray[np.int64]) -> None:
        slow[np.searchsorted(nl, pos)] = True

    # one pass over the text for everything but digits and points (about a third of
    # the bytes), then split that smaller set by class
    special = np.flatnonzero(head > _DOT)
    special_cls = head[special]
    mark(special[special_cls == _OTHER])
    letters = special[special_cls == _LETTER]
    # every letter is followed by a number: [sign] digit..., or [sign] . digit...
    p = letters + 1
    p = p + (cls[p] == _SIGN)
    ok = (cls[p] == _DIGIT) | ((cls[p] == _DOT) & (cls[p + 1] == _DIGIT))
    mark(letters[~ok])
    signs = special[special_cls == _SIGN]
    mark(signs[cls[signs - 1] != _LETTER])  # signs only right after a letter
    spaces = special[special_cls == _SPACE]
    after = cls[spaces + 1]
    mark(spaces[(after != _SPACE) & (after != _LETTER) & (after != _NL)])  # "X1 0" is slow
    first = cls[starts]
    slow[:n_lines] |= (first == _DIGIT) | (first == _DOT) | (first == _SIGN)
    if dialect.max_line_length is not None:
        slow[:n_lines] |= (ends - starts) > dialect.max_line_length
    line_of = np.searchsorted(nl, letters)
    col = col_table[buf[letters]]
    # a letter twice on one line: the sum of one-hot bits differs from their OR
    bits = np.left_shift(1, col)
    if letters.shape[0]:
        group = np.flatnonzero(np.diff(line_of, prepend=-1))
        ored = np.bitwise_or.reduceat(bits, group)
        summed = np.add.reduceat(bits, group)
        slow[line_of[group[ored != summed]]] = True
    # Numbers: blank letters, newlines and slow lines, then let numpy's strtod read them
    # all (correctly rounded, like float()). Only "1.2.3" style tokens can still split
    # into extra numbers; they are found, made slow, and the read repeated.
    seg = np.diff(np.concatenate((starts, [n])))
    trans = np.arange(256, dtype=np.uint8)
    trans[cls_table == _LETTER] = ord(" ")
    trans[[ord("\n"), ord("\r"), ord("\t")]] = ord(" ")
    text = trans[raw]
    for _ in range(2):
        fast_tok = ~slow[line_of]
        if slow[:n_lines].any():
            text[np.repeat(slow[:n_lines], seg)] = ord(" ")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            nums = np.fromstring(text.tobytes().decode("ascii"), sep=" ")
        if nums.shape[0] == int(fast_tok.sum()):
            break
        dots = np.flatnonzero(head == _DOT)
        tok_of_dot = np.searchsorted(letters, dots, side="right") - 1
        multi = np.bincount(tok_of_dot, minlength=letters.shape[0]) > 1
        slow[line_of[multi]] = True
    else:  # pragma: no cover - defensive: give everything to the block parser
        slow[:] = True
        fast_tok = np.zeros(letters.shape[0], dtype=np.bool_)
        nums = np.empty(0)
    values = np.full((n_lines + 1, len(_COLS)), np.nan)
    values[line_of[fast_tok], col[fast_tok]] = nums
    values = values[:n_lines]
    slow = slow[:n_lines]
    g = values[:, _G]
    f = values[:, _F]
    nw = values[:, _N]
    with np.errstate(invalid="ignore"):
        slow |= ~np.isnan(g) & (g != 0.0) & (g != 1.0)
        slow |= f < 0.0
        slow |= ~np.isnan(nw) & ((nw < 0.0) | (nw != np.floor(nw)) | (nw > MAX_LINE_NUMBER))
    return Scan(data, starts, ends, slow, values)


def _ffill(
    values: npt.NDArray[np.float64], has: npt.NDArray[np.bool_], initial: float
) -> npt.NDArray[np.float64]:
    m = values.shape[0]
    at = np.where(has, np.arange(m), -1)
    np.maximum.accumulate(at, out=at)
    return np.where(at >= 0, values[np.maximum(at, 0)], initial)


def _column(
    v: npt.NDArray[np.float64], present: npt.NDArray[np.bool_]
) -> list[float | None] | None:
    """Column values with None where absent (None alone: absent everywhere, broadcast)."""
    if present.all():
        return v.tolist()  # type: ignore[no-any-return]
    if not present.any():
        return None
    obj = v.astype(object)
    obj[~present] = None
    return obj.tolist()  # type: ignore[no-any-return]


def fast_run(
    sc: Scan, i: int, j: int, bp: BlockParser
) -> tuple[int, list[Rapid | Linear], npt.NDArray[np.int64]]:
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
    (k, blocks, lines)
        Lines ``i .. k-1`` were applied; ``k < j`` means line ``k`` must go through the
        block parser (an error, or an arc move in modal G2/G3). ``blocks`` are the moves
        and ``lines`` their 1-based line numbers.
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
    feed_move = has_axes & (motion == 1.0)
    with np.errstate(invalid="ignore"):
        if inverse:
            bad = feed_move & ~(f_has & (f > 0.0))
        else:
            bad = feed_move & ~(feed > 0.0)
    bad |= has_axes & (motion >= 2.0)
    bad_at = np.flatnonzero(bad)
    k = int(bad_at[0]) if bad_at.shape[0] else m
    if k == 0:
        return i, [], np.empty(0, dtype=np.int64)

    present = present[:k]
    moves = has_axes[:k]
    mm = axes[:k].copy()
    if inch:
        mm[:, :3] *= MM_PER_INCH
    rows = np.flatnonzero(moves)
    kind = motion[:k][rows]
    rapid_rows = rows[kind == 0.0]
    lin_rows = rows[kind == 1.0]
    out = np.empty(rows.shape[0], dtype=object)
    for cls, sel, mask in (
        (Rapid, rapid_rows, kind == 0.0),
        (Linear, lin_rows, kind == 1.0),
    ):
        if sel.shape[0] == 0:
            continue
        cols: dict[str, object] = {
            name: _column(mm[sel, n], present[sel, n]) for n, name in enumerate(AXES)
        }
        if cls is Linear:
            cols["feed"] = feed[:k][sel].tolist()
        objs = _build_many(cls, int(sel.shape[0]), cols)  # type: ignore[arg-type]
        tmp = np.empty(len(objs), dtype=object)
        tmp[:] = objs
        out[mask] = tmp

    # commit: motion, feed and position after line k-1
    position = list(st.position)
    incremental = st.distance is DistanceMode.INCREMENTAL
    for n in range(6):
        col_present = present[:, n]
        if not col_present.any():
            continue
        col = mm[col_present, n]
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
    return i + k, out.tolist(), rows + (i + 1)
