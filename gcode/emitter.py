"""The emitter: ``Program`` + ``Dialect`` -> G-code text, streamed through a ``Writer``.

Layout of the output::

    %                     (dialects with % delimiters)
    O0001 (NAME)          (dialects with program numbers)
    G21                   (units line, always: G20 or G21 from Program.units)
    <dialect preamble>    (IR blocks, e.g. G94 G17 G90)
    <program blocks>      (one block per line; consecutive modal-setting blocks share
                           a line when their order is the execution order)
    <dialect postamble>
    %

A comment longer than the dialect's ``max_line_length`` (its delimiters included) is
wrapped at spaces into as many comment lines as it needs, so no line of a program exceeds
the limit (GRBL: a sender that forwards comments counts them in the 128-byte receive
buffer); a parse of such a program reads one comment per line.

Modal words are written only when they change (motion G word, F, S), except that F is
written on every feed move in inverse time (G93), where controllers require it. Lengths
and feeds are converted to inches (``mm / MM_PER_INCH``) when ``Program.units`` is inch;
rotary angles and inverse-time feeds are never scaled.

Runs of rapid and linear moves (the bulk of any program) are formatted column-wise with
numpy (:func:`gcode.numbers.format_matrix`) in chunks of :data:`CHUNK` blocks, so a
10-million-line program streams in bounded memory and at over twice the speed of a
per-line f-string emitter; other blocks go through the scalar formatter, which writes the
same text.

Examples
--------
>>> from gcode.emitter import emit_text
>>> from gcode.dialects import GRBL
>>> from gcode.program import Linear, Program, Rapid
>>> print(emit_text(Program((Rapid(x=0.0, y=0.0), Linear(x=10.0, feed=500.0))), GRBL), end="")
G21
G94G17G90
G0X0Y0
G1X10F500
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from dataclasses import dataclass, replace
from itertools import repeat
from pathlib import Path

import numpy as np
import numpy.typing as npt

from gcode.block_sequence import KIND_LINEAR, MoveRun, block_runs
from gcode.dialects import CommentStyle, Dialect
from gcode.errors import ArcError, DialectError, ErrorCode, SyntaxGCodeError
from gcode.modal import EXECUTION_ORDER, ModalState, MotionMode
from gcode.numbers import MM_PER_INCH, format_number, format_slots
from gcode.program import (
    AXES,
    ROTARY_AXES,
    Arc,
    Block,
    Comment,
    Coolant,
    Dwell,
    FeedMode,
    Linear,
    Program,
    ProgramEnd,
    Rapid,
    SetDistanceMode,
    SetFeedMode,
    SetPlane,
    SetUnits,
    SetWorkOffset,
    Spindle,
    ToolChange,
    Units,
)
from gcode.writer import LineCollector, TextWriter, Writer

__all__ = ["CHUNK", "emit", "emit_file", "emit_lines", "emit_text"]

#: Blocks formatted per vectorized chunk (bounds memory: about 200 bytes per block).
CHUNK = 65536
# Runs shorter than this use the scalar path (numpy set-up costs more than it saves).
_MIN_VECTOR_RUN = 32
_STATE_TYPES = (SetFeedMode, SetPlane, SetUnits, SetWorkOffset, SetDistanceMode)
_RANK = {t: n for n, t in enumerate(EXECUTION_ORDER)}
_MOVE_KIND = {Rapid: 0, Linear: 1}


class _Emitter:
    """Streaming emitter state: what the controller has been told so far."""

    def __init__(self, program: Program, dialect: Dialect, writer: Writer, vectorize: bool):
        self.d = dialect
        self.w = writer
        self.vectorize = vectorize
        self.state = ModalState(units=program.units)
        self.motion: MotionMode | None = None  # None: not yet told
        self.feed_q: int | None = None  # last F as an integer count of output decimals
        self.rpm_text: str | None = None
        self.n_index = 0  # index into the N-number cycle
        self.line_no = 0  # output lines written
        self.pending: list[str] = []
        sep = dialect.word_separator
        self.sep = sep
        width = 2 if dialect.pad_codes else 1
        self.g = {n: f"G{n:0{width}d}" for n in range(100)}
        self.m = {n: f"M{n:0{width}d}" for n in range(100)}
        dec = dialect.decimals
        self.dec_angle = dec.angle
        self.fmt_kw = {"trim": dialect.trim_zeros, "keep_point": dialect.keep_point}

    # ---------------------------------------------------------------- units and numbers
    @property
    def inch(self) -> bool:
        return self.state.units is Units.INCH

    def coord_decimals(self, axis: str) -> int:
        if axis in ROTARY_AXES:
            return self.d.decimals.angle
        return self.d.decimals.coord_inch if self.inch else self.d.decimals.coord_mm

    def feed_decimals(self) -> int:
        if self.state.feed_mode is FeedMode.INVERSE_TIME:
            return self.d.decimals.inverse_time
        return self.d.decimals.feed_inch if self.inch else self.d.decimals.feed_mm

    def feed_out(self, feed: float) -> float:
        if self.state.feed_mode is FeedMode.INVERSE_TIME or not self.inch:
            return feed
        return feed / MM_PER_INCH

    def num(self, value: float, decimals: int) -> str:
        return format_number(value, decimals, **self.fmt_kw)

    # ---------------------------------------------------------------- output
    def next_n(self) -> int:
        d = self.d
        cycle = (d.line_number_max - d.line_number_start) // d.line_number_step + 1
        n = d.line_number_start + d.line_number_step * (self.n_index % cycle)
        self.n_index += 1
        return n

    def code_line(self, words: list[str]) -> None:
        if self.d.line_numbers:
            words.insert(0, f"N{self.next_n()}")
        self.line_no += 1
        limit = self.d.max_line_length
        if limit is not None:
            count = sum(map(len, words))
            if count > limit:
                line = self.sep.join(words)
                raise SyntaxGCodeError(
                    ErrorCode.LINE_OVERFLOW,
                    f"{count} characters exceed the {self.d.name} limit of {limit}",
                    line=self.line_no,
                    text=line,
                )
        self.raw_line(self.sep.join(words), count=False)

    def raw_line(self, text: str, *, count: bool = True) -> None:
        if count:
            self.line_no += 1
        self.pending.append(text)
        if len(self.pending) >= 4096:
            self.flush()

    def flush(self) -> None:
        if self.pending:
            self.w.write("\n".join(self.pending) + "\n")
            self.pending.clear()

    def comment_text(self, text: str) -> str:
        text = " ".join(text.split())  # newlines and tabs become single spaces
        clean = "".join(ch if " " <= ch <= "~" else "?" for ch in text).strip()
        return self._delimit(clean)

    def _delimit(self, clean: str) -> str:
        if self.d.comment_style is CommentStyle.PARENS:
            return "(" + clean.replace("(", "[").replace(")", "]") + ")"
        return "; " + clean

    def comment_lines(self, text: str) -> list[str]:
        """The comment as lines within ``max_line_length`` (wrapped at spaces)."""
        line = self.comment_text(text)
        limit = self.d.max_line_length
        if limit is None or len(line) <= limit:
            return [line]
        width = limit - (len(self._delimit("")))
        body = line[1:-1] if self.d.comment_style is CommentStyle.PARENS else line[2:]
        parts = textwrap.wrap(body, width, break_long_words=True, break_on_hyphens=False)
        return [self._delimit(p) for p in parts]

    # ---------------------------------------------------------------- program
    def run(self, program: Program) -> int:
        d = self.d
        if d.percent:
            self.raw_line("%")
        if d.program_number:
            number = 1 if program.number is None else program.number
            line = f"O{number:0{d.program_number_digits}d}"
            if program.name:
                line += " " + self.comment_text(program.name)
            self.raw_line(line)
        self.code_line([self.g[int(program.units)]])
        self.blocks(d.preamble)
        self.blocks(program.blocks)
        self.blocks(d.postamble)
        if d.percent:
            self.raw_line("%")
        self.flush()
        return self.line_no

    def blocks(self, blocks: Sequence[Block]) -> None:
        for _, part in block_runs(blocks):
            if isinstance(part, MoveRun):
                if self.vectorize and len(part) >= _MIN_VECTOR_RUN:
                    for k in range(0, len(part), CHUNK):
                        self.move_chunk(part[k : k + CHUNK])
                else:
                    self.scalar_chunk(part)
            else:
                self.block_tuple(part)

    def block_tuple(self, blocks: tuple[Block, ...]) -> None:
        n = len(blocks)
        i = 0
        # blocks that are not Rapid/Linear, then n: runs of moves lie between them
        breaks = np.zeros(0, dtype=np.int64)
        kind = np.zeros(0, dtype=np.int8)
        if self.vectorize and n >= _MIN_VECTOR_RUN:
            kind = np.fromiter(map(_MOVE_KIND.get, map(type, blocks), repeat(-1)), np.int8, n)
            breaks = np.append(np.flatnonzero(kind < 0), n)
        while i < n:
            b = blocks[i]
            j = int(breaks[np.searchsorted(breaks, i)]) if breaks.shape[0] else i
            if j - i >= _MIN_VECTOR_RUN:
                for k in range(i, j, CHUNK):
                    stop = min(j, k + CHUNK)
                    self.move_chunk(MoveRun.from_blocks(blocks[k:stop], kind[k:stop]))  # type: ignore[arg-type]
                i = j
                continue
            if isinstance(b, _STATE_TYPES):
                j = i + 1
                while (
                    j < n
                    and isinstance(blocks[j], _STATE_TYPES)
                    and _RANK[type(blocks[j])] > _RANK[type(blocks[j - 1])]
                ):
                    j += 1
                words: list[str] = []
                for s in blocks[i:j]:
                    words.append(self.state_word(s))  # type: ignore[arg-type]
                self.code_line(words)
                i = j
                continue
            self.block(b)
            i += 1

    # ---------------------------------------------------------------- scalar path
    def state_word(
        self, b: SetFeedMode | SetPlane | SetUnits | SetWorkOffset | SetDistanceMode
    ) -> str:
        if isinstance(b, SetFeedMode):
            if b.mode is FeedMode.INVERSE_TIME and not self.d.inverse_time:
                raise DialectError(
                    ErrorCode.UNSUPPORTED_COMMAND, f"{self.d.name} has no inverse time (G93)"
                )
            if b.mode is not self.state.feed_mode:
                self.feed_q = None
            self.state = self.state.apply(b)
            return self.g[int(b.mode)]
        if isinstance(b, SetUnits):
            if b.units is not self.state.units:
                self.feed_q = None
            self.state = self.state.apply(b)
            return self.g[int(b.units)]
        self.state = self.state.apply(b)
        if isinstance(b, SetPlane):
            return self.g[int(b.plane)]
        if isinstance(b, SetWorkOffset):
            return self.g[53 + b.index]
        return self.g[int(b.mode)]

    def axis_words(self, b: Rapid | Linear | Arc) -> list[str]:
        words = []
        inch = self.inch
        for name in self.d_axes_all:
            v = getattr(b, name)
            if v is None:
                continue
            if name not in self.d.axes:
                raise DialectError(
                    ErrorCode.UNSUPPORTED_COMMAND,
                    f"{self.d.name} has no {name.upper()} axis (value {v!r})",
                )
            if inch and name not in ROTARY_AXES:
                v = v / MM_PER_INCH
            words.append(name.upper() + self.num(v, self.coord_decimals(name)))
        return words

    d_axes_all = AXES

    def feed_word(self, feed: float) -> str | None:
        dec = self.feed_decimals()
        out = self.feed_out(feed)
        q = round(out * (10**dec))
        if q <= 0:
            raise SyntaxGCodeError(
                ErrorCode.UNDEFINED_FEED_RATE,
                f"feed {feed!r} is zero at {dec} decimals",
                line=self.line_no + 1,
            )
        inverse = self.state.feed_mode is FeedMode.INVERSE_TIME
        if self.d.suppress_modal and not inverse and q == self.feed_q:
            return None
        self.feed_q = q
        return "F" + self.num(out, dec)

    def motion_words(self, b: Rapid | Linear | Arc, mode: MotionMode) -> list[str]:
        axes = self.axis_words(b)
        words = []
        if mode is not self.motion or not self.d.suppress_modal or not axes:
            words.append(self.g[int(mode)])
        self.motion = mode
        words.extend(axes)
        return words

    def block(self, b: Block) -> None:
        d = self.d
        if isinstance(b, Rapid):
            self.code_line(self.motion_words(b, MotionMode.RAPID))
        elif isinstance(b, Linear):
            words = self.motion_words(b, MotionMode.LINEAR)
            f = self.feed_word(b.feed)
            if f is not None:
                words.append(f)
            self.code_line(words)
        elif isinstance(b, Arc):
            self.arc(b)
        elif isinstance(b, Comment):
            for line in self.comment_lines(b.text):
                self.raw_line(line)
            return
        elif isinstance(b, Dwell):
            if d.dwell_ms:
                p = "P" + format_number(b.seconds * 1000.0, 0)
            else:
                p = "P" + self.num(b.seconds, d.decimals.dwell)
            self.code_line([self.g[4], p])
        elif isinstance(b, Spindle):
            words = [self.m[int(b.direction)]]
            s = format_number(b.rpm, d.decimals.spindle, **self.fmt_kw)
            if s != self.rpm_text or not d.suppress_modal:
                words.append("S" + s)
                self.rpm_text = s
            self.code_line(words)
        elif isinstance(b, Coolant):
            self.code_line([self.m[int(b.mode)]])
        elif isinstance(b, ToolChange):
            if not d.tool_change:
                raise DialectError(
                    ErrorCode.UNSUPPORTED_COMMAND, f"{d.name} has no tool change (M6)"
                )
            self.code_line([f"T{b.tool}", self.m[6]])
        elif isinstance(b, _STATE_TYPES):
            self.code_line([self.state_word(b)])
            return
        elif isinstance(b, ProgramEnd):
            self.code_line([self.m[30 if b.rewind else 2]])
            self.motion = MotionMode.LINEAR  # controllers reset to G1 at program end
            if self.state.feed_mode is FeedMode.INVERSE_TIME:
                self.feed_q = None
        else:
            raise TypeError(f"not a G-code block: {b!r}")
        self.state = self.state.apply(b)

    def arc(self, b: Arc) -> None:
        if not self.d.arcs:
            raise DialectError(ErrorCode.UNSUPPORTED_COMMAND, f"{self.d.name} has no arcs")
        if b.plane is not self.state.plane:
            raise ArcError(
                ErrorCode.INVALID_TARGET,
                f"arc in plane {b.plane.name} while {self.state.plane.name} is active; "
                "put a SetPlane block before it",
            )
        mode = MotionMode.ARC_CW if b.clockwise else MotionMode.ARC_CCW
        words = self.motion_words(b, mode)
        dec = self.d.decimals.coord_inch if self.inch else self.d.decimals.coord_mm
        scale = 1.0 / MM_PER_INCH if self.inch else 1.0
        for name in ("i", "j", "k", "r"):
            v = getattr(b, name)
            if v is not None:
                words.append(name.upper() + self.num(v * scale if self.inch else v, dec))
        f = self.feed_word(b.feed)
        if f is not None:
            words.append(f)
        self.code_line(words)

    # ---------------------------------------------------------------- vector path
    def move_chunk(self, run: MoveRun) -> None:
        """Write a run of moves as one line matrix of 4-byte text slots (see module doc)."""
        m = len(run)
        d = self.d
        is_lin = run.kind == KIND_LINEAR
        words: list[_Word] = []

        if d.line_numbers:
            start, step = d.line_number_start, d.line_number_step
            cycle = (d.line_number_max - start) // step + 1
            ns = start + step * ((self.n_index + np.arange(m)) % cycle)
            digits = format_slots(ns.astype(np.float64), 0)
            if digits is None:
                return self.scalar_chunk(run)
            words.append(_Word((b"N",), None, None, digits))

        present = [~np.isnan(run.axes[:, n]) for n in range(6)]
        any_axis = np.zeros(m, dtype=np.bool_)
        for col in present:
            any_axis |= col
        code = is_lin.astype(np.intp)  # 0 = G0, 1 = G1
        if d.suppress_modal:
            prev = np.empty(m, dtype=np.intp)
            prev[0] = -1 if self.motion is None else int(self.motion)
            prev[1:] = code[:-1]
            write_g = (code != prev) | ~any_axis
        else:
            write_g = None
        words.append(_Word((self.g[0].encode(), self.g[1].encode()), write_g, code, []))

        inch = self.inch
        for n, name in enumerate(AXES):
            axis_present = present[n]
            if not axis_present.any():
                continue
            if name not in d.axes:
                raise DialectError(
                    ErrorCode.UNSUPPORTED_COMMAND, f"{d.name} has no {name.upper()} axis"
                )
            vals = run.axes[:, n]
            every = bool(axis_present.all())
            if not every:
                vals = np.where(axis_present, vals, 0.0)
            if inch and name not in ROTARY_AXES:
                vals = vals / MM_PER_INCH
            digits = format_slots(vals, self.coord_decimals(name), **self.fmt_kw)
            if digits is None:
                return self.scalar_chunk(run)
            words.append(
                _Word((name.upper().encode(),), None if every else axis_present, None, digits)
            )

        last_q = self.feed_q
        lin_idx = np.flatnonzero(is_lin)
        if lin_idx.shape[0]:
            inverse = self.state.feed_mode is FeedMode.INVERSE_TIME
            feeds = run.feed[lin_idx]
            if inch and not inverse:
                feeds = feeds / MM_PER_INCH
            dec = self.feed_decimals()
            q = np.rint(feeds * float(10**dec))
            if float(q.max()) >= 2.0**62:
                return self.scalar_chunk(run)
            qi = q.astype(np.int64)
            if (qi <= 0).any():
                return self.scalar_chunk(run)  # the scalar path raises at the right line
            if d.suppress_modal and not inverse:
                prev_q = np.empty_like(qi)
                prev_q[0] = -1 if self.feed_q is None else self.feed_q
                prev_q[1:] = qi[:-1]
                changed = qi != prev_q
            else:
                changed = np.ones(qi.shape, dtype=np.bool_)
            digits = format_slots(feeds[changed], dec, **self.fmt_kw)  # written F only
            if digits is None:
                return self.scalar_chunk(run)
            write_f = np.zeros(m, dtype=np.bool_)
            f_rows = lin_idx[changed]
            write_f[f_rows] = True
            f_slots = []
            for col in digits:
                full = np.zeros(m, dtype=col.dtype)
                full[f_rows] = col
                f_slots.append(full)
            words.append(_Word((b"F",), write_f, None, f_slots))
            last_q = int(qi[-1])
            feed = float(run.feed[lin_idx[-1]])
        else:
            feed = self.state.feed

        text, n_words = _line_matrix(words, self.sep.encode(), m)
        limit = d.max_line_length
        if limit is not None and text.shape[1] > limit:  # some line may be too long: count
            count = np.count_nonzero(text, axis=1) - 1  # minus the newline
            if self.sep:  # separators are not counted (GRBL strips spaces)
                count -= np.maximum(n_words - 1, 0) * len(self.sep)
            if int(count.max()) > limit:
                bad = int(np.flatnonzero(count > limit)[0])
                self.flush()
                self.line_no += bad + 1
                line = bytes(text[bad][text[bad] != 0]).decode("ascii").rstrip("\n")
                raise SyntaxGCodeError(
                    ErrorCode.LINE_OVERFLOW,
                    f"{int(count[bad])} characters exceed the {d.name} limit of {limit}",
                    line=self.line_no,
                    text=line,
                )
        self.flush()
        self.w.write(str(text.tobytes().translate(None, b"\0"), "ascii"))
        self.line_no += m
        if d.line_numbers:
            self.n_index += m
        self.motion = MotionMode.LINEAR if is_lin[-1] else MotionMode.RAPID
        self.feed_q = last_q
        self.state = replace(self.state, motion=self.motion, feed=feed)
        return None

    def scalar_chunk(self, run: MoveRun) -> None:
        for b in run.blocks():
            self.block(b)


@dataclass(frozen=True)
class _Word:
    """One word of every line of a chunk, as columns of text slots.

    ``heads[v]`` starts the word (its letter, or the whole G code) on rows of variant
    ``v`` (``variant`` per row, None for 0); ``digits`` are the value's slot columns
    from :func:`~gcode.numbers.format_slots` (empty for none); ``present`` says which
    lines have the word (None: all).
    """

    heads: tuple[bytes, ...]
    present: npt.NDArray[np.bool_] | None
    variant: npt.NDArray[np.intp] | None
    digits: list[npt.NDArray[np.uint32] | npt.NDArray[np.uint16]]


def _line_matrix(
    words: list[_Word], sep: bytes, m: int
) -> tuple[npt.NDArray[np.uint8], npt.NDArray[np.int64]]:
    """Lines as rows of bytes: NUL-padded words, separators, a final newline.

    Deleting every NUL byte of the matrix gives the text. Also returns the number of
    words on each line. A word's head comes from a table indexed by whether the word is
    present, whether an earlier word is (then the separator goes in front), and its
    variant. Every slot column is written as one strided 2- or 4-byte column.
    """
    head_bytes = 2 * max(-(-(len(sep) + len(h)) // 2) for w in words for h in w.heads)
    head_type = np.uint16 if head_bytes == 2 else np.uint32 if head_bytes == 4 else None
    if head_type is None:
        raise ValueError(f"word heads of {head_bytes} bytes (separator {sep!r}) are too long")
    width = sum(head_bytes + sum(d.itemsize for d in w.digits) for w in words) + 2
    matrix = np.empty((m, width), dtype=np.uint8)

    def column(offset: int, dtype: type) -> npt.NDArray[np.generic]:
        return np.ndarray((m,), dtype=dtype, buffer=matrix, offset=offset, strides=(width,))

    seen = np.zeros(m, dtype=np.bool_)  # an earlier word is on the line
    n_words = np.zeros(m, dtype=np.int64)
    c = 0
    for w in words:
        # rows: absent, then (no earlier word, earlier word) x variants
        texts = [b"", *(s + h for s in (b"", sep) for h in w.heads)]
        table = np.frombuffer(b"".join(t.ljust(head_bytes, b"\0") for t in texts), head_type)
        index = seen * len(w.heads) if sep else np.zeros(m, dtype=np.intp)
        if w.variant is not None:
            index = index + w.variant
        index += 1
        if w.present is not None:
            index *= w.present
        column(c, head_type)[...] = table[index]
        c += head_bytes
        for digits in w.digits:
            out = column(c, digits.dtype.type)
            if w.present is None:
                out[...] = digits
            else:
                np.multiply(digits, w.present, out=out)
            c += digits.itemsize
        if w.present is not None:
            seen |= w.present
            n_words += w.present
        else:
            seen[:] = True
            n_words += 1
    column(c, np.uint16)[...] = ord("\n")  # one newline byte and one NUL, either order
    return matrix, n_words


def emit(program: Program, dialect: Dialect, writer: Writer, *, vectorize: bool = True) -> int:
    """Write ``program`` as G-code text for ``dialect`` through ``writer``, streaming.

    Parameters
    ----------
    program : Program
        Blocks in mm, degrees, mm/min; ``program.units`` selects G20 or G21 text.
    dialect : Dialect
        Target controller.
    writer : Writer
        Receives chunks of complete lines.
    vectorize : bool
        Use the numpy column formatter for runs of moves (same text either way).

    Returns
    -------
    int
        Number of lines written.

    Raises
    ------
    GCodeError
        LINE_OVERFLOW for a block longer than the dialect's limit (``line`` is the
        output line), UNSUPPORTED_COMMAND for blocks the dialect cannot express,
        INVALID_TARGET for an arc outside the active plane, NOT_FINITE for NaN/inf.
    """
    return _Emitter(program, dialect, writer, vectorize).run(program)


def emit_lines(program: Program, dialect: Dialect, *, vectorize: bool = True) -> list[str]:
    """Return the emitted lines (without newlines); for tests and small programs."""
    collector = LineCollector()
    emit(program, dialect, collector, vectorize=vectorize)
    return collector.lines


def emit_text(program: Program, dialect: Dialect, *, vectorize: bool = True) -> str:
    """Return the emitted text as one string; for small programs only (use :func:`emit`)."""
    collector = LineCollector()
    emit(program, dialect, collector, vectorize=vectorize)
    return collector.text


def emit_file(program: Program, dialect: Dialect, path: str | Path) -> int:
    r"""Stream ``program`` to the file ``path`` (ASCII, ``"\n"`` newlines).

    Returns
    -------
    int
        Number of lines written.
    """
    with TextWriter(path) as writer:
        return emit(program, dialect, writer)
