"""Argument types shared by the commands, and library errors told in their flags.

Types for argparse's ``type=``, and a library error about a value a flag gave, told with
that flag: one line of error each.
"""

from __future__ import annotations

import argparse
import contextlib
from collections.abc import Iterator

from toolpath.errors import ToleranceNotReachedError

from .cli_files import CommandLineError

__all__ = ["fit_tolerance_flag", "positive_int"]


def positive_int(text: str) -> int:
    """A count such as ``--workers``: an integer >= 1 (argparse names the flag)."""
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text!r}")
    return value


@contextlib.contextmanager
def fit_tolerance_flag(flag: str) -> Iterator[None]:
    """A fit that cannot reach its tolerance, told with the command's ``flag`` (``--tol``).

    (:meth:`~toolpath.errors.ToleranceNotReachedError.advice`.)
    """
    try:
        yield
    except ToleranceNotReachedError as exc:
        raise CommandLineError(exc.advice(flag)) from None
