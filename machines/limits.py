"""Travel and rate envelope checks that report violations and never clip.

A check returns a list of :class:`Violation` records, one per axis and side, naming the
first offending point (or segment); :func:`raise_for_violations` turns the first one into a
:class:`~machines.errors.TravelLimitError` or :class:`~machines.errors.RateLimitError`.

Examples
--------
>>> import numpy as np
>>> from machines.machine import load_machine
>>> m = load_machine("trunnion-ac")
>>> joints = np.array([[0.0, 0.0, -100.0, -90.0, 0.0], [0.0, 0.0, -100.0, -125.0, 0.0]])
>>> [v.message() for v in check_travel(m, joints)]
["point 1: axis 'A' = -125 deg is below its minimum -120 deg"]
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import Final

import numpy as np
from numpy.typing import ArrayLike, NDArray

from machines.errors import MachineError, RateLimitError, TravelLimitError
from machines.machine import Machine

__all__ = [
    "RATE_TOLERANCE",
    "TRAVEL_TOLERANCE",
    "Quantity",
    "Side",
    "Violation",
    "check_rates",
    "check_travel",
    "min_segment_times",
    "raise_for_violations",
]

TRAVEL_TOLERANCE: Final[float] = 1e-6
"""Allowance beyond a travel limit, mm or deg: absorbs floating-point round-off of the
kinematics (values computed at exactly the limit), three orders below a 1 um resolution."""

RATE_TOLERANCE: Final[float] = 1e-9
"""Relative allowance on a maximum rate: absorbs round-off in times computed at the limit."""


class Side(StrEnum):
    """Which limit a value broke."""

    MIN = "min"
    MAX = "max"


class Quantity(StrEnum):
    """What was checked: a position (mm or deg) or a rate (mm/min or deg/min)."""

    POSITION = "position"
    RATE = "rate"


@dataclass(frozen=True, slots=True)
class Violation:
    """One axis leaving its envelope on one side.

    Attributes
    ----------
    index : int
        First offending point (positions) or segment (rates; segment ``i`` runs from point
        ``i`` to ``i + 1``), 0-based.
    axis : str
        Axis letter.
    value : float
        The value at `index`: mm or deg for positions, mm/min or deg/min for rates.
    limit : float
        The limit it broke, same unit.
    side : Side
        ``MIN`` (below the minimum) or ``MAX`` (above the maximum).
    quantity : Quantity
        Position or rate.
    unit : str
        Unit of `value` and `limit`.
    count : int
        How many points (segments) break this limit on this axis.
    worst : float
        The furthest value beyond the limit among them.
    """

    index: int
    axis: str
    value: float
    limit: float
    side: Side
    quantity: Quantity = Quantity.POSITION
    unit: str = "mm"
    count: int = 1
    worst: float = float("nan")

    def message(self) -> str:
        """Describe the violation in one sentence (point, axis, value and limit)."""
        where = "point" if self.quantity is Quantity.POSITION else "segment"
        what = "" if self.quantity is Quantity.POSITION else " rate"
        rel = "below its minimum" if self.side is Side.MIN else "above its maximum"
        text = (
            f"{where} {self.index}: axis {self.axis!r}{what} = {self.value:.6g} {self.unit} "
            f"is {rel} {self.limit:.6g} {self.unit}"
        )
        if self.count > 1:
            text += f" ({self.count} {where}s in all, worst {self.worst:.6g} {self.unit})"
        return text


def _joints(machine: Machine, joints: ArrayLike) -> NDArray[np.float64]:
    j = np.asarray(joints, dtype=float)
    if j.ndim == 1:
        j = j[None, :]
    if j.ndim != 2 or j.shape[1] != machine.n_axes:
        raise MachineError(
            f"joints must have shape (n, {machine.n_axes}) for axes {machine.letters!r}, "
            f"got {np.shape(joints)!r}"
        )
    return j


def check_travel(
    machine: Machine, joints: ArrayLike, *, tol: float = TRAVEL_TOLERANCE
) -> list[Violation]:
    """Find joint values outside the travel limits.

    Parameters
    ----------
    machine : Machine
        The machine.
    joints : array_like, shape (n, n_axes)
        Joint values in the machine's axis order (mm, deg unwrapped).
    tol : float, optional
        Allowance beyond each limit, mm or deg (default :data:`TRAVEL_TOLERANCE`).

    Returns
    -------
    list of Violation
        One record per axis and side that is broken, ordered by first offending point
        (then axis order). Empty when everything is within travel. Non-finite values count
        as violations. Continuous and modulo rotary axes have no travel limit.
    """
    j = _joints(machine, joints)
    found: list[Violation] = []
    for col, ax in enumerate(machine.axes):
        if not ax.is_limited:
            continue
        v = j[:, col]
        nan = ~np.isfinite(v)
        for side, bad, limit in (
            (Side.MIN, (v < ax.min - tol) | nan, ax.min),
            (Side.MAX, v > ax.max + tol, ax.max),
        ):
            idx = np.flatnonzero(bad)
            if idx.size:
                worst = float(v[idx].min() if side is Side.MIN else v[idx].max())
                found.append(
                    Violation(
                        index=int(idx[0]),
                        axis=ax.letter,
                        value=float(v[idx[0]]),
                        limit=limit,
                        side=side,
                        unit=ax.unit,
                        count=int(idx.size),
                        worst=worst,
                    )
                )
    order = {letter: i for i, letter in enumerate(machine.letters)}
    found.sort(key=lambda r: (r.index, order[r.axis]))
    return found


def _durations(n_segments: int, durations: ArrayLike) -> NDArray[np.float64]:
    dt = np.asarray(durations, dtype=float)
    if dt.ndim == 0:
        dt = np.full(n_segments, float(dt))
    if dt.shape != (n_segments,):
        raise MachineError(
            f"durations must have shape ({n_segments},) (one per segment), got {dt.shape!r}"
        )
    bad = ~np.isfinite(dt) | (dt < 0.0)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise MachineError(f"durations[{i}] = {float(dt[i])!r} s is not a finite time >= 0")
    return dt


def check_rates(
    machine: Machine, joints: ArrayLike, durations: ArrayLike, *, rtol: float = RATE_TOLERANCE
) -> list[Violation]:
    """Find segments that would move an axis faster than its maximum rate.

    Parameters
    ----------
    machine : Machine
        The machine.
    joints : array_like, shape (n, n_axes)
        Joint values in the machine's axis order (mm, deg unwrapped).
    durations : array_like, shape (n - 1,) or scalar
        Time of each segment, s (>= 0). A zero time with motion is an infinite rate.
    rtol : float, optional
        Relative allowance on each maximum rate (default :data:`RATE_TOLERANCE`).

    Returns
    -------
    list of Violation
        One record per axis whose rate is exceeded (``side`` ``MAX``, ``quantity``
        ``RATE``, values in mm/min or deg/min), ordered by first offending segment.

    Raises
    ------
    MachineError
        For a wrong shape or a negative or non-finite duration.
    """
    j = _joints(machine, joints)
    dt = _durations(max(len(j) - 1, 0), durations)
    if len(j) < 2:
        return []
    step = np.abs(np.diff(j, axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        rate = np.where(step > 0.0, 60.0 * step / dt[:, None], 0.0)  # per minute
    found: list[Violation] = []
    for col, ax in enumerate(machine.axes):
        idx = np.flatnonzero(rate[:, col] > ax.max_rate * (1.0 + rtol))
        if idx.size:
            found.append(
                Violation(
                    index=int(idx[0]),
                    axis=ax.letter,
                    value=float(rate[idx[0], col]),
                    limit=ax.max_rate,
                    side=Side.MAX,
                    quantity=Quantity.RATE,
                    unit=f"{ax.unit}/min",
                    count=int(idx.size),
                    worst=float(rate[idx, col].max()),
                )
            )
    order = {letter: i for i, letter in enumerate(machine.letters)}
    found.sort(key=lambda r: (r.index, order[r.axis]))
    return found


def min_segment_times(machine: Machine, joints: ArrayLike) -> NDArray[np.float64]:
    """Shortest time of each segment with no axis above its maximum rate.

    Parameters
    ----------
    machine : Machine
        The machine.
    joints : array_like, shape (n, n_axes)
        Joint values in the machine's axis order (mm, deg unwrapped).

    Returns
    -------
    numpy.ndarray, shape (n - 1,)
        Seconds per segment: the slowest axis at its maximum rate (acceleration ignored).
    """
    j = _joints(machine, joints)
    rates = np.array([ax.max_rate for ax in machine.axes])  # per minute
    if len(j) < 2:
        return np.zeros(0)
    return 60.0 * (np.abs(np.diff(j, axis=0)) / rates).max(axis=1)


def raise_for_violations(violations: Sequence[Violation]) -> None:
    """Raise for the first violation, if there is any.

    Parameters
    ----------
    violations : sequence of Violation
        Records from :func:`check_travel` or :func:`check_rates`.

    Raises
    ------
    TravelLimitError
        If the first record is a position; the message names point, axis, value and limit.
    RateLimitError
        If the first record is a rate.
    """
    if not violations:
        return
    ordered = sorted(violations, key=lambda r: r.index)
    if ordered[0].quantity is Quantity.POSITION:
        raise TravelLimitError(ordered)
    raise RateLimitError(ordered)
