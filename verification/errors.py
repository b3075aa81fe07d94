"""Errors of the verification package.

:class:`VerificationError` derives from :class:`toolpath.errors.ToolpathError` (itself a
``ValueError``): every verification error is a problem with what the caller passed
(options, a surface that is not one, a cutter this version cannot model, a program with no
motion), and the ``toolpath`` command already turns that family into one stderr line and
exit status 2.
"""

from __future__ import annotations

from toolpath.errors import ToolpathError

__all__ = ["UnsupportedCutterError", "VerificationError"]


class VerificationError(ToolpathError):
    """Base of every error raised by :mod:`verification`."""


class UnsupportedCutterError(VerificationError):
    """The cutter's shape has no material-removal kernel here.

    Ball, flat and bull-nose cutters all have one; kept for callers that catch it.
    """
