"""The one exception family of :mod:`toolpath`.

Every error a user can provoke with bad input derives from :class:`ToolpathError`, which is
also a :class:`ValueError`, and names the offending value, point index or file line.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable

__all__ = [
    "ClosureWarning",
    "ConvergenceWarning",
    "DataFileError",
    "FitError",
    "InvalidParameterError",
    "InvalidPointsError",
    "LogRangeError",
    "ToleranceNotReachedError",
    "ToolpathError",
    "UnfairFitWarning",
    "reissue_warnings",
    "tolerance_to_give",
]


class ToolpathError(ValueError):
    """Base class of every error raised by :mod:`toolpath` for bad input or failed fits."""


class InvalidPointsError(ToolpathError):
    """Point data of the wrong shape, with non-finite values, duplicates or no length.

    Attributes
    ----------
    index : int or None
        0-based index of the first offending point, when there is one.
    """

    def __init__(self, message: str, *, index: int | None = None) -> None:
        super().__init__(message)
        self.index = index


class InvalidParameterError(ToolpathError):
    """A keyword option with an unknown name, value out of range or wrong type."""


class DataFileError(ToolpathError):
    """A point file that cannot be read.

    Attributes
    ----------
    path : str
        The file.
    line : int or None
        1-based line number of the first offending line, when there is one.
    """

    def __init__(self, message: str, *, path: str, line: int | None = None) -> None:
        where = f"{path}:{line}: " if line is not None else f"{path}: "
        super().__init__(where + message)
        self.path = path
        self.line = line


class FitError(ToolpathError):
    """A fit that cannot be carried out or cannot reach the requested tolerance."""


class ToleranceNotReachedError(FitError):
    """A fit whose error stays above the tolerance with the most control points allowed.

    Attributes
    ----------
    tol_mm : float
        The tolerance asked.
    best_mm : float
        The smallest largest error reached (mm).
    control_points : int
        Control points of that fit (the most allowed).
    """

    def __init__(self, message: str, *, tol_mm: float, best_mm: float,
                 control_points: int) -> None:
        super().__init__(message)
        self.tol_mm, self.best_mm, self.control_points = tol_mm, best_mm, control_points

    def advice(self, flag: str) -> str:
        """The failure told with the command-line ``flag`` that sets the tolerance.

        The message names the library's keywords (``tol``, ``max_control_points``, which
        no command offers); a command-line user reads what to give the flag instead: 5 %
        above the best error, rounded up to two digits.
        """
        looser = tolerance_to_give(1.05 * self.best_mm)
        return (f"the fit cannot reach {flag} {self.tol_mm:g} mm: with the most control points "
                f"the fitter allows ({self.control_points}) it stays {self.best_mm:.4g} mm off "
                f"the data; give {flag} {looser:g} or more (noisy points, or edges sampled "
                "coarser than their radius, need a looser fit)")


class LogRangeError(FitError):
    """A streamline fit whose ``G`` would leave the data's log range (``exp`` out of range).

    Raised for a knot vector too dense for the data in some stretch, or a near-singular cone
    frame; the fitter tries its next cone frame before giving up.
    """


class ConvergenceWarning(UserWarning):
    """An iterative refinement stopped before converging; the result is still valid."""


class ClosureWarning(UserWarning):
    """Sections whose seams read otherwise than most of the blade's, fitted as most read."""


class UnfairFitWarning(ConvergenceWarning):
    """A fit within its tolerance that stays unfair after its knots were mended.

    Concave where the data turn convex (or estimated off the data between points).
    ``unfairness`` orders such fits, fairest first (fewer unfair stretches, fewer intervals
    off the data, a shallower deepest stretch, a smaller largest estimate); the streamline
    fitters try their next cone frame on it (:func:`toolpath.streamline_curve.fit_in_frames`).
    """

    def __init__(self, message: str, unfairness: tuple[float, ...] = ()) -> None:
        super().__init__(message)
        self.unfairness = tuple(unfairness)


def tolerance_to_give(value_mm: float) -> float:
    """``value_mm`` rounded up to two significant figures: a tolerance to type into a flag."""
    if value_mm <= 0.0:
        return 0.0
    step = 10.0 ** (math.floor(math.log10(value_mm)) - 1)
    return round(math.ceil(value_mm / step - 1e-9) * step, 12)


def reissue_warnings(caught: Iterable[warnings.WarningMessage]) -> None:
    """Warn again what ``warnings.catch_warnings(record=True)`` caught.

    Through the filters in force now, as though it had never been caught (an "error"
    filter raises it here).
    """
    for warning in caught:
        warnings.warn_explicit(warning.message, warning.category, warning.filename,
                               warning.lineno)
