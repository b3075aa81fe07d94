"""The one exception family of :mod:`machines`.

Every error this package raises for bad input derives from :class:`MachineError`, which is
also a :class:`ValueError`. Messages show the offending value with ``!r`` and name the file,
key, point index or axis letter where there is one.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover - typing only, avoids an import cycle
    from machines.limits import Violation

__all__ = [
    "KinematicsError",
    "LimitError",
    "MachineDefinitionError",
    "MachineError",
    "RateLimitError",
    "TravelLimitError",
    "UnknownAxisError",
    "UnknownMachineError",
    "UnreachableOrientationError",
]


class MachineError(ValueError):
    """Base class of every error raised by :mod:`machines`."""


class UnknownMachineError(MachineError, LookupError):
    """A machine name that matches no shipped definition and no file.

    Attributes
    ----------
    name : str
        The name or path that was asked for.
    available : tuple of str
        Names of the shipped definitions.
    """

    def __init__(self, name: str, available: Sequence[str]) -> None:
        self.name = name
        self.available = tuple(available)
        super().__init__(
            f"unknown machine {name!r}: not a shipped definition and not a file; "
            f"shipped machines: {', '.join(self.available) or '(none)'}"
        )

    def __str__(self) -> str:  # LookupError would otherwise quote the message
        return str(self.args[0])


class UnknownAxisError(MachineError, LookupError):
    """An axis letter the machine does not have."""

    def __str__(self) -> str:
        return str(self.args[0])


class MachineDefinitionError(MachineError):
    """A machine definition (TOML file or mapping) that is malformed.

    Attributes
    ----------
    path : str
        The file, or ``"<mapping>"`` for a definition given as a dict.
    key : str or None
        Dotted key of the offending entry, e.g. ``"axes[3].max_rate"``.
    """

    def __init__(self, message: str, *, path: str, key: str | None = None) -> None:
        self.path = path
        self.key = key
        where = f"{path}: key {key!r}: " if key is not None else f"{path}: "
        super().__init__(where + message)


class KinematicsError(MachineError):
    """Input to the kinematics of the wrong shape or with non-finite or zero vectors."""


class UnreachableOrientationError(KinematicsError):
    """Tool axes the machine cannot produce (e.g. a tilted axis on a 3-axis machine).

    Attributes
    ----------
    indices : tuple of int
        0-based indices of every offending point, ascending.
    """

    def __init__(self, message: str, *, indices: Sequence[int]) -> None:
        super().__init__(message)
        self.indices = tuple(int(i) for i in indices)


class LimitError(MachineError):
    """Base of the errors raised from limit-check records.

    Attributes
    ----------
    violations : tuple of Violation
        Every record found, ordered by point index; the message names the first.
    """

    def __init__(self, violations: Sequence[Violation]) -> None:
        if not violations:
            raise ValueError("a limit error needs at least one violation")
        self.violations = tuple(violations)
        first = self.violations[0]
        more = len(self.violations) - 1
        tail = f" (and {more} more violation{'s' if more != 1 else ''})" if more else ""
        super().__init__(first.message() + tail)


class TravelLimitError(LimitError):
    """Joint values outside an axis's travel (soft limits)."""


class RateLimitError(LimitError):
    """Segments that would move an axis faster than its maximum rate."""
