"""Argument types shared by the commands, and library errors told in their flags.

Types for argparse's ``type=``, and a library error about a value a flag gave, told with
that flag: one line of error each.
"""

from __future__ import annotations

import argparse
import contextlib
import math
from collections.abc import Iterator

from toolpath.errors import ToleranceNotReachedError

from .cli_files import CommandLineError

__all__ = ["fit_tolerance_flag", "looser_tolerance_mm", "positive_int"]


def positive_int(text: str) -> int:
    """A count such as ``--workers``: an integer >= 1 (argparse names the flag)."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}")
    return value


def looser_tolerance_mm(best_mm: float) -> float:
    """A round tolerance a little above a fit's best error: 5 % more, up to 2 digits."""
    value = 1.05 * best_mm
    step = 10.0 ** (math.floor(math.log10(value)) - 1)
    return round(math.ceil(value / step) * step, 12)


@contextlib.contextmanager
def fit_tolerance_flag(flag: str) -> Iterator[None]:
    """A fit that cannot reach its tolerance, told with the command's ``flag`` (``--tol``).

    The library names its own keywords (``tol``, ``max_control_points``, which no command
    offers); a command-line user reads what to give the flag instead.
    """
    try:
        yield
    except ToleranceNotReachedError as exc:
        raise CommandLineError(
            f"the fit cannot reach {flag} {exc.tol_mm:g} mm: with the most control points "
            f"the fitter allows ({exc.control_points}) it stays {exc.best_mm:.4g} mm off the "
            f"data; give {flag} {looser_tolerance_mm(exc.best_mm):g} or more (noisy points, "
            "or edges sampled coarser than their radius, need a looser fit)") from None
