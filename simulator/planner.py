"""The look-ahead planner: a bounded block queue (streaming) and its whole-program twin.

Entry speeds follow grbl's planner: a block may enter no faster than its junction limit
and both blocks' nominal speeds; the last block in the queue must be able to stop at its
end (so a short queue means slow motion); speeds rise only as fast as the acceleration
allows. :class:`PlannerQueue` keeps the backward bound of every queued block up to date
as blocks arrive (grbl ``planner_recalculate``, with its early stop); the forward limit is
applied as each block starts, from the speed the machine really has.

:func:`plan_entry_speeds_sq` computes the same entry speeds for a whole program at once,
assuming the queue is kept full (each block sees the ``planner_blocks - 1`` blocks after
it, as with a sender that keeps the controller busy), with two running minima instead of
a loop. Both give identical speeds for such a stream (tests check this).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

__all__ = ["GRBL_PLANNER_BLOCKS", "MotionBlock", "PlannerQueue", "plan_entry_speeds_sq"]

#: Usable planner blocks of grbl 1.1 (16-block ring, 15 usable; ``$I`` -> ``[OPT:V,15,128]``).
GRBL_PLANNER_BLOCKS = 15

FloatArray = npt.NDArray[np.float64]


@dataclass(slots=True, eq=False)
class MotionBlock:
    """One straight block in the planner queue (joint space: mm and deg as mm).

    Attributes
    ----------
    start, end : tuple of 6 float
        Machine positions X Y Z A B C (mm, deg).
    length : float
        mm.
    unit : tuple of 6 float
        Direction.
    nominal_speed : float
        mm/s.
    accel : float
        mm/s^2.
    max_entry_sq : float
        Junction and nominal limit on the entry speed, (mm/s)^2.
    feed_ratio : float
        Reported feed per unit of joint speed.
    seq : int
        Controller sequence number of the source line.
    last_of_line : bool
        The line is complete when this block is.
    entry_bound_sq : float
        Backward-pass bound on the entry speed, (mm/s)^2.
    riders : list
        Journal records of later lines with no motion, completed with this block.
    """

    start: tuple[float, ...]
    end: tuple[float, ...]
    length: float
    unit: tuple[float, ...]
    nominal_speed: float
    accel: float
    max_entry_sq: float
    feed_ratio: float
    seq: int
    last_of_line: bool = True
    entry_bound_sq: float = 0.0
    riders: list = field(default_factory=list)

    @property
    def decel_sq(self) -> float:
        """``2 a L``: how much the squared speed can change over the block, (mm/s)^2."""
        return 2.0 * self.accel * self.length


class PlannerQueue:
    """Bounded FIFO of :class:`MotionBlock` with backward look-ahead bounds.

    Parameters
    ----------
    capacity : int
        Number of blocks, the executing one included (grbl: 15).
    """

    def __init__(self, capacity: int = GRBL_PLANNER_BLOCKS) -> None:
        if capacity < 1:
            raise ValueError(f"planner capacity must be >= 1 block, got {capacity!r}")
        self.capacity = capacity
        self._q: deque[MotionBlock] = deque()

    def __len__(self) -> int:
        return len(self._q)

    def __iter__(self) -> Iterator[MotionBlock]:
        return iter(self._q)

    def __bool__(self) -> bool:
        return bool(self._q)

    @property
    def full(self) -> bool:
        """No room for another block."""
        return len(self._q) >= self.capacity

    @property
    def free(self) -> int:
        """Blocks that can still be queued."""
        return self.capacity - len(self._q)

    @property
    def head(self) -> MotionBlock | None:
        """The executing (oldest) block."""
        return self._q[0] if self._q else None

    @property
    def tail(self) -> MotionBlock | None:
        """The newest block."""
        return self._q[-1] if self._q else None

    def head_exit_bound_sq(self) -> float:
        """Largest squared exit speed of the head that still lets the queue stop, (mm/s)^2."""
        return self._q[1].entry_bound_sq if len(self._q) > 1 else 0.0

    def append(self, block: MotionBlock) -> None:
        """Queue a block and raise the backward bounds of the blocks before it.

        Raises
        ------
        OverflowError
            When the queue is full (the caller must wait for the head to finish).
        """
        q = self._q
        if len(q) >= self.capacity:
            raise OverflowError(f"planner queue is full ({self.capacity} blocks)")
        block.entry_bound_sq = min(block.max_entry_sq, block.decel_sq)
        q.append(block)
        nxt = block.entry_bound_sq
        for i in range(len(q) - 2, 0, -1):
            b = q[i]
            new = min(b.max_entry_sq, nxt + b.decel_sq)
            if new == b.entry_bound_sq:
                break
            b.entry_bound_sq = new
            nxt = new

    def pop(self) -> MotionBlock:
        """Remove and return the head."""
        return self._q.popleft()

    def clear(self) -> list[MotionBlock]:
        """Empty the queue; return what was in it."""
        out = list(self._q)
        self._q.clear()
        return out


def plan_entry_speeds_sq(
    max_entry_sq: FloatArray,
    decel_sq: FloatArray,
    *,
    planner_blocks: int = GRBL_PLANNER_BLOCKS,
    start_sq: float = 0.0,
) -> FloatArray:
    """Entry speeds of a whole program planned with a full look-ahead window.

    Parameters
    ----------
    max_entry_sq : ndarray, shape (n,)
        Junction/nominal limit on each block's entry, (mm/s)^2; 0 forces a stop before
        the block (start of program, after a synchronizing line).
    decel_sq : ndarray, shape (n,)
        ``2 a L`` of each block, (mm/s)^2.
    planner_blocks : int
        Queue size: block ``k`` is planned with blocks ``k .. k + planner_blocks - 1``
        queued and the last of them stopping at its end.
    start_sq : float
        Squared speed at the start of the first block, (mm/s)^2.

    Returns
    -------
    ndarray, shape (n + 1,)
        Squared entry speed of every block, then the final exit speed (0).

    Notes
    -----
    With prefix sums ``C_m = sum_{i<m} decel_sq_i``, the backward bound on the exit of
    block ``k`` is ``min_{k<m<k+W} (J_m + C_m)`` (and ``C_{k+W}`` for the queue end)
    ``- C_{k+1}``; the forward recursion ``E_{k+1} = min(B_k, E_k + d_k)`` unrolls to
    ``E_i = C_i + min(E_0, min_{k<i} (B_k - C_{k+1}))``: two running minima.
    """
    n = int(max_entry_sq.shape[0])
    w = int(planner_blocks)
    if n == 0:
        return np.zeros(1)
    c = np.zeros(n + 1)
    np.cumsum(decel_sq, out=c[1:])
    vals = np.full(n + w + 1, np.inf)
    vals[:n] = max_entry_sq + c[:n]
    vals[n] = c[n]  # the program end: stop
    if w > 1:
        windows = np.lib.stride_tricks.sliding_window_view(vals[1 : n + w - 1], w - 1)
        m = windows.min(axis=1)[:n]
    else:
        m = np.full(n, np.inf)
    term = c[np.minimum(np.arange(n) + w, n)]
    m = np.minimum(m, term)
    q = m - 2.0 * c[1:]
    prefix = np.minimum.accumulate(np.concatenate(([start_sq], q)))
    e = c + prefix
    e[0] = start_sq
    e[-1] = 0.0
    return np.maximum(e, 0.0)


def _reference_entry_speeds_sq(
    max_entry_sq: list[float], decel_sq: list[float], planner_blocks: int, start_sq: float = 0.0
) -> list[float]:
    """Plain-loop statement of :func:`plan_entry_speeds_sq` (for tests)."""
    n = len(max_entry_sq)
    e = [start_sq]
    for k in range(n):
        top = min(k + planner_blocks, n)
        bound = 0.0
        for m in range(top - 1, k, -1):
            bound = min(max_entry_sq[m], bound + decel_sq[m])
        e.append(min(bound, e[-1] + decel_sq[k]))
    e[-1] = 0.0
    return [max(x, 0.0) for x in e]
