"""Blocks stored in runs: plain moves as numpy columns, everything else as objects.

A parsed program is mostly rapid and linear moves. As frozen objects they cost about
0.4 us and 150 bytes each to create, which alone is slower than reading the text. Here
a run of such moves is a :class:`MoveRun`: columns of kind, axis values (mm, degrees)
and feed (mm/min or 1/min). :class:`BlockSequence` chains move runs and tuples of other
blocks into one read-only sequence whose items are the frozen ``Rapid``/``Linear``
objects, built when indexed or iterated. It compares equal to the tuple of its blocks,
so ``Program.blocks`` keeps its values whichever way it is stored. Consumers that can
use the columns (emitter, interpreter) read them through :func:`block_runs`.

Examples
--------
>>> import numpy as np
>>> from gcode.block_sequence import BlockSequence, MoveRun
>>> from gcode.program import Comment, Linear, Rapid
>>> run = MoveRun(
...     np.array([0, 1], dtype=np.int8),
...     np.array([[1.0, 2.0, np.nan, np.nan, np.nan, np.nan], [3.0] + [np.nan] * 5]),
...     np.array([np.nan, 500.0]),
... )
>>> seq = BlockSequence([(Comment("start"),), run])
>>> seq[2]
Linear(x=3.0, y=None, z=None, a=None, b=None, c=None, feed=500.0)
>>> seq == (Comment("start"), Rapid(x=1.0, y=2.0), Linear(x=3.0, feed=500.0))
True
"""

from __future__ import annotations

from bisect import bisect_right
from collections import deque
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass, fields
from itertools import accumulate, repeat
from operator import attrgetter
from typing import Any, overload

import numpy as np
import numpy.typing as npt

from gcode.program import AXES, Block, Linear, Rapid, StoredBlocks

__all__ = ["KIND_LINEAR", "KIND_RAPID", "BlockSequence", "MoveRun", "Part", "block_runs"]

#: Values of :attr:`MoveRun.kind`.
KIND_RAPID, KIND_LINEAR = 0, 1
# rows materialised per step when iterating a run
_CHUNK = 4096
_GETTERS = tuple(attrgetter(name) for name in AXES)
_GET_ROTARY = attrgetter("a", "b", "c")
_KIND_OF = {Rapid: KIND_RAPID, Linear: KIND_LINEAR}


def _frozen(a: npt.NDArray[Any]) -> npt.NDArray[Any]:
    a = a.view()  # a read-only view: the caller's array keeps its own flags
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class MoveRun:
    """Consecutive ``Rapid``/``Linear`` blocks as read-only columns.

    Attributes
    ----------
    kind : ndarray of int8, shape (m,)
        :data:`KIND_RAPID` or :data:`KIND_LINEAR`.
    axes : ndarray of float64, shape (m, 6)
        X Y Z (mm) and A B C (degrees) as programmed; NaN where the word is absent.
    feed : ndarray of float64, shape (m,)
        Effective feed of linear moves (mm/min, 1/min in inverse time, > 0); NaN for
        rapids.

    The values must satisfy the block classes' checks (finite axes, feeds > 0): blocks
    are built from them without re-checking. :meth:`from_blocks` guarantees this.
    """

    kind: npt.NDArray[np.int8]
    axes: npt.NDArray[np.float64]
    feed: npt.NDArray[np.float64]

    def __post_init__(self) -> None:
        m = self.kind.shape[0]
        if self.axes.shape != (m, 6) or self.feed.shape != (m,):
            raise ValueError(
                f"MoveRun columns disagree: kind {self.kind.shape}, axes {self.axes.shape} "
                f"(want ({m}, 6)), feed {self.feed.shape} (want ({m},))"
            )
        for name in ("kind", "axes", "feed"):
            object.__setattr__(self, name, _frozen(getattr(self, name)))

    def __len__(self) -> int:
        return int(self.kind.shape[0])

    def __getitem__(self, rows: slice) -> MoveRun:
        """The rows ``rows`` (a slice with step 1) as a run sharing these columns."""
        return MoveRun(self.kind[rows], self.axes[rows], self.feed[rows])

    @classmethod
    def from_blocks(
        cls, blocks: Sequence[Rapid | Linear], kind: npt.NDArray[np.int8] | None = None
    ) -> MoveRun:
        """Columns of ``blocks`` (all ``Rapid`` or ``Linear``), read attribute by attribute.

        ``kind``, if given, is the caller's kind column of the same blocks.
        """
        m = len(blocks)
        if kind is None:
            kind = np.fromiter(map(_KIND_OF.__getitem__, map(type, blocks)), np.int8, m)
        axes = np.full((m, 6), np.nan)
        # rotary words are usually absent everywhere: one pass finds out for all three
        rotary_absent = m > 0 and set(map(_GET_ROTARY, blocks)) == {(None, None, None)}
        for n, getter in enumerate(_GETTERS):
            if n >= 3 and rotary_absent:
                break
            try:  # every block has the word: one pass straight into floats
                axes[:, n] = np.fromiter(map(getter, blocks), np.float64, m)
            except TypeError:  # some are None (numpy reads None as NaN)
                col = list(map(getter, blocks))
                if col.count(None) < m:
                    axes[:, n] = np.array(col, dtype=np.float64)
        feed = np.fromiter(map(getattr, blocks, repeat("feed"), repeat(np.nan)), np.float64, m)
        return cls(kind, axes, feed)

    @classmethod
    def checked(
        cls,
        kind: npt.NDArray[np.int8],
        axes: npt.NDArray[np.float64],
        feed: npt.NDArray[np.float64],
    ) -> MoveRun:
        """Columns from a producer, checked as the block classes check their values.

        Axis values must be finite or NaN (absent) and linear feeds finite and > 0;
        otherwise the ``ValueError`` of the first offending block is raised, as building
        the blocks one by one would.
        """
        bad = np.isinf(axes).any(axis=1)
        with np.errstate(invalid="ignore"):
            bad |= (kind == KIND_LINEAR) & ~(np.isfinite(feed) & (feed > 0.0))
        bad |= (kind != KIND_LINEAR) & (kind != KIND_RAPID)
        at = np.flatnonzero(bad)
        if at.shape[0]:
            r = int(at[0])
            _block_of(int(kind[r]), axes[r], float(feed[r]))  # raises the block's error
            raise ValueError(f"MoveRun row {r} is not a valid move")  # pragma: no cover
        return cls(kind, axes, feed)

    def blocks(self, start: int = 0, stop: int | None = None) -> list[Rapid | Linear]:
        """Build the frozen blocks of rows ``start .. stop-1``."""
        kind = self.kind[start:stop]
        axes = self.axes[start:stop]
        feed = self.feed[start:stop]
        m = kind.shape[0]
        out: list[Any] = [None] * m
        for cls, code in ((Rapid, KIND_RAPID), (Linear, KIND_LINEAR)):
            rows = np.flatnonzero(kind == code)
            if rows.shape[0] == 0:
                continue
            sub = axes[rows]
            present = ~np.isnan(sub)
            cols: dict[str, Any] = {
                name: _column(sub[:, n], present[:, n]) for n, name in enumerate(AXES)
            }
            if cls is Linear:
                cols["feed"] = feed[rows].tolist()
            objs = _build_many(cls, int(rows.shape[0]), cols)
            if rows.shape[0] == m:
                return objs
            for r, obj in zip(rows.tolist(), objs, strict=True):
                out[r] = obj
        return out

    def equals(self, other: MoveRun) -> bool:
        """Same blocks (absent words match absent words; -0.0 equals 0.0 as in floats)."""
        return (
            np.array_equal(self.kind, other.kind)
            and np.array_equal(self.axes, other.axes, equal_nan=True)
            and np.array_equal(self.feed, other.feed, equal_nan=True)
        )


def _block_of(kind: int, row: npt.NDArray[np.float64], feed: float) -> Rapid | Linear:
    """One block built through its class (with its checks) from a row of columns."""
    words = {name: float(v) for name, v in zip(AXES, row.tolist(), strict=True) if v == v}
    if kind == KIND_RAPID:
        return Rapid(**words)
    if kind == KIND_LINEAR:
        return Linear(**words, feed=feed)
    raise ValueError(f"MoveRun kind must be {KIND_RAPID} or {KIND_LINEAR}, got {kind}")


def _column(v: npt.NDArray[np.float64], present: npt.NDArray[np.bool_]) -> list[Any] | None:
    """Column values with None where absent (None alone: absent everywhere)."""
    if present.all():
        return v.tolist()  # type: ignore[no-any-return]
    if not present.any():
        return None
    obj = v.astype(object)
    obj[~present] = None
    return obj.tolist()  # type: ignore[no-any-return]


def _build_many(cls: type, n: int, columns: dict[str, Any]) -> list[Any]:
    """Build ``n`` instances of a slotted frozen block class from columns, fast.

    Equivalent to ``[cls(**{k: col[i] ...}) for i in range(n)]`` but sets the slots
    directly (about 3x faster than calling ``__init__``), so it skips ``__post_init__``:
    the columns must already satisfy the class's checks. A non-list column value (None)
    is broadcast to all rows.
    """
    objs = list(map(object.__new__, repeat(cls, n)))
    for f in fields(cls):
        col = columns.get(f.name, f.default)
        values: Iterable[Any] = col if isinstance(col, list) else repeat(col, n)
        deque(map(getattr(cls, f.name).__set__, objs, values), maxlen=0)
    return objs


Part = tuple[Block, ...] | MoveRun


class BlockSequence(StoredBlocks):
    """Read-only sequence of blocks chained from tuples and :class:`MoveRun` columns.

    Indexing and iteration build the frozen blocks of move runs on demand (nothing is
    cached: the sequence stays as small as its columns). Equal to any tuple or block
    sequence holding equal blocks; its hash and repr are those of ``tuple(self)``.
    Slices with step 1 are block sequences sharing the columns.

    Parameters
    ----------
    parts : iterable of (tuple of Block) or MoveRun
        Runs in execution order; empty ones are dropped and neighbouring tuples joined,
        so tuples and move runs alternate.
    """

    __slots__ = ("_parts", "_starts")

    def __init__(self, parts: Iterable[Part]) -> None:
        kept: list[Part] = []
        for p in parts:
            if not isinstance(p, tuple | MoveRun):
                raise TypeError(f"BlockSequence parts are tuples or MoveRuns, got {type(p)}")
            if not len(p):
                continue
            if kept and isinstance(p, tuple) and isinstance(kept[-1], tuple):
                kept[-1] = kept[-1] + p  # neighbouring tuples become one
            else:
                kept.append(p)
        self._parts = tuple(kept)
        self._starts = (0, *accumulate(map(len, kept)))

    @property
    def parts(self) -> tuple[Part, ...]:
        """The runs, in order (tuples of blocks and :class:`MoveRun` columns)."""
        return self._parts

    def __len__(self) -> int:
        return self._starts[-1]

    @overload
    def __getitem__(self, index: int) -> Block: ...
    @overload
    def __getitem__(self, index: slice) -> Sequence[Block]: ...
    def __getitem__(self, index: int | slice) -> Block | Sequence[Block]:
        """Block ``index`` (negative from the end), or the blocks of a slice."""
        if isinstance(index, slice):
            return self._slice(index)
        n = len(self)
        i = index.__index__()
        if i < 0:
            i += n
        if not 0 <= i < n:
            raise IndexError(f"block index {index} out of range for {n} blocks")
        k = bisect_right(self._starts, i) - 1
        part = self._parts[k]
        j = i - self._starts[k]
        return part[j] if isinstance(part, tuple) else part.blocks(j, j + 1)[0]

    def _slice(self, index: slice) -> Sequence[Block]:
        start, stop, step = index.indices(len(self))
        if step != 1:
            return tuple(self)[index]
        parts: list[Part] = []
        for k, part in enumerate(self._parts):
            lo, hi = self._starts[k], self._starts[k + 1]
            a, b = max(start, lo) - lo, min(stop, hi) - lo
            if a < b:
                parts.append(part[a:b])
        return BlockSequence(parts)

    def __iter__(self) -> Iterator[Block]:
        for part in self._parts:
            if isinstance(part, tuple):
                yield from part
            else:
                for k in range(0, len(part), _CHUNK):
                    yield from part.blocks(k, k + _CHUNK)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, tuple | BlockSequence):
            return NotImplemented
        if len(self) != len(other):
            return False
        if isinstance(other, BlockSequence) and self._starts == other._starts:
            return all(_parts_equal(a, b) for a, b in zip(self._parts, other._parts, strict=True))
        return all(a == b for a, b in zip(self, other, strict=True))

    def __ne__(self, other: object) -> bool:
        eq = self.__eq__(other)
        return eq if eq is NotImplemented else not eq

    def __hash__(self) -> int:
        return hash(tuple(self))

    def __repr__(self) -> str:
        return repr(tuple(self))

    def __add__(self, other: object) -> tuple[Block, ...]:
        if not isinstance(other, tuple | BlockSequence):
            return NotImplemented
        return (*self, *other)

    def __radd__(self, other: object) -> tuple[Block, ...]:
        if not isinstance(other, tuple):
            return NotImplemented
        return (*other, *self)

    def __reduce__(self) -> tuple[type, tuple[tuple[Part, ...]]]:
        return BlockSequence, (self._parts,)


def _parts_equal(a: Part, b: Part) -> bool:
    if isinstance(a, MoveRun) and isinstance(b, MoveRun):
        return a.equals(b)
    if isinstance(a, tuple) and isinstance(b, tuple):
        return a == b
    seq_a = a if isinstance(a, tuple) else a.blocks()
    seq_b = b if isinstance(b, tuple) else b.blocks()
    return list(seq_a) == list(seq_b)


def block_runs(blocks: Sequence[Block]) -> Iterator[tuple[int, Part]]:
    """Split ``blocks`` into (index of first block, run) with moves as columns.

    Parts of a :class:`BlockSequence` come as stored; any other sequence is one tuple.
    Consumers that handle moves column-wise use this instead of iterating blocks.
    """
    if isinstance(blocks, BlockSequence):
        yield from zip(blocks._starts, blocks.parts, strict=False)
    elif len(blocks):
        yield 0, tuple(blocks)
