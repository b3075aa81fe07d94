"""Error model of the G-code package: one base exception and one table of codes.

``ErrorCode`` is the single table of numbered G-code errors. Codes 1-38 are GRBL 1.1's
``error:N`` numbers and are used only where the meaning matches GRBL's (see grbl
``report.h`` and ``doc/csv/error_codes_en_US.csv``). Codes from 100 upward are ours, for
conditions GRBL does not number separately; :attr:`ErrorCode.grbl` gives the GRBL number a
GRBL-compatible controller (or our simulator) reports on the wire for each of them.

Examples
--------
>>> from gcode.errors import ErrorCode, GCodeError
>>> err = GCodeError(ErrorCode.BAD_NUMBER_FORMAT, "exponent in 'X1e-3'", line=7, text="X1e-3")
>>> err.code, err.line
(<ErrorCode.BAD_NUMBER_FORMAT: 2>, 7)
>>> str(err)
"line 7: error 2 (BAD_NUMBER_FORMAT): exponent in 'X1e-3' [X1e-3]"
"""

from __future__ import annotations

from enum import IntEnum

__all__ = [
    "ArcError",
    "DialectError",
    "ErrorCode",
    "FeedError",
    "GCodeError",
    "ModalError",
    "PostError",
    "SyntaxGCodeError",
]


class ErrorCode(IntEnum):
    """Numbered G-code errors (GRBL 1.1 numbers below 100, ours from 100)."""

    #: A word must start with a letter A-Z; another character was found (GRBL 1).
    EXPECTED_COMMAND_LETTER = 1
    #: A word's value is missing or is not a plain fixed-point number (GRBL 2).
    #: This covers a letter with no number (``X Y1``) and exponents (``X1e-3``).
    BAD_NUMBER_FORMAT = 2
    #: A value that must not be negative is negative (F, S, T, P, N) (GRBL 4).
    NEGATIVE_VALUE = 4
    #: The line is longer than the dialect's line buffer (GRBL 11).
    LINE_OVERFLOW = 11
    #: An unknown word, or one the dialect does not support (GRBL 20).
    UNSUPPORTED_COMMAND = 20
    #: Two commands of one modal group in one block (GRBL 21).
    MODAL_GROUP_VIOLATION = 21
    #: A feed move with no feed rate defined (or no F in inverse time, G93) (GRBL 22).
    UNDEFINED_FEED_RATE = 22
    #: A G, M or T value that must be an integer is not (GRBL 23).
    COMMAND_VALUE_NOT_INTEGER = 23
    #: Two commands in one block both want the axis words (GRBL 24).
    AXIS_COMMAND_CONFLICT = 24
    #: A word repeated in one block (GRBL 25).
    WORD_REPEATED = 25
    #: A command needs axis words and the block has none (GRBL 26).
    NO_AXIS_WORDS = 26
    #: The N line number is not a non-negative integer within range (GRBL 27).
    INVALID_LINE_NUMBER = 27
    #: A command needs a value word that is missing (G4 without P) (GRBL 28).
    VALUE_WORD_MISSING = 28
    #: An arc has no axis word in its plane (GRBL 32).
    NO_AXIS_WORDS_IN_PLANE = 32
    #: The motion target is invalid: arc end equal to start with R, an R too small to
    #: reach the end, or a zero radius (GRBL 33).
    INVALID_TARGET = 33
    #: An R-form arc cannot reach its end point: the radius is shorter than half the
    #: chord (GRBL 34).
    ARC_RADIUS_ERROR = 34
    #: An arc has no centre offset word in its plane (GRBL 35).
    NO_OFFSETS_IN_PLANE = 35
    #: Value words that nothing in the block uses (IJK or R without an arc) (GRBL 36).
    UNUSED_WORDS = 36
    #: Tool number out of range (GRBL 38).
    TOOL_NUMBER_OUT_OF_RANGE = 38
    #: Start and end radii of an IJK arc disagree beyond tolerance (ours; GRBL says 33).
    ARC_RADIUS_MISMATCH = 100
    #: A ``(`` comment is not closed on its line (ours; LinuxCNC rejects it too).
    UNCLOSED_COMMENT = 101
    #: A non-ASCII or control character in a block (ours; GRBL drops such bytes).
    INVALID_CHARACTER = 102
    #: A value is NaN or infinite and cannot be written (ours; emitter side).
    NOT_FINITE = 103

    @property
    def grbl(self) -> int:
        """The GRBL 1.1 ``error:N`` number a GRBL-compatible controller reports."""
        return _GRBL_EQUIVALENT.get(self, int(self))


_GRBL_EQUIVALENT = {
    ErrorCode.ARC_RADIUS_MISMATCH: 33,
    ErrorCode.UNCLOSED_COMMENT: 20,
    ErrorCode.INVALID_CHARACTER: 1,
    ErrorCode.NOT_FINITE: 2,
}


class GCodeError(ValueError):
    """A G-code error with its numbered code, 1-based source line and source text.

    Parameters
    ----------
    code : ErrorCode
        What went wrong (GRBL number where the meaning matches).
    message : str
        Human-readable detail; offending values are shown with ``!r``.
    line : int or None
        1-based source line number (or output line number for emitter errors).
    text : str or None
        The source line (or output line) the error refers to.
    """

    def __init__(
        self,
        code: ErrorCode,
        message: str,
        *,
        line: int | None = None,
        text: str | None = None,
    ) -> None:
        self.code = ErrorCode(code)
        self.message = message
        self.line = line
        self.text = text
        super().__init__(self.__str__())

    def __str__(self) -> str:
        where = f"line {self.line}: " if self.line is not None else ""
        src = f" [{self.text.strip()}]" if self.text is not None else ""
        return f"{where}error {int(self.code)} ({self.code.name}): {self.message}{src}"

    def __reduce__(self) -> tuple[object, ...]:
        return (_rebuild, (type(self), self.code, self.message, self.line, self.text))

    def at(self, line: int, text: str) -> GCodeError:
        """Return a copy of this error located at ``line`` with source ``text``.

        Parameters
        ----------
        line : int
            1-based line number.
        text : str
            The source line.

        Returns
        -------
        GCodeError
            Same class, code and message, with the location filled in.
        """
        return type(self)(self.code, self.message, line=line, text=text)


def _rebuild(
    cls: type[GCodeError], code: ErrorCode, message: str, line: int | None, text: str | None
) -> GCodeError:
    return cls(code, message, line=line, text=text)


class SyntaxGCodeError(GCodeError):
    """Malformed text: letters, numbers, comments, line length (codes 1, 2, 11, 101, 102)."""


class ModalError(GCodeError):
    """Modal-group conflicts, repeated or unused words, unsupported commands."""


class FeedError(GCodeError):
    """Feed-rate problems: undefined feed, missing F in inverse time (code 22)."""


class ArcError(GCodeError):
    """Invalid arcs: radius mismatch, missing in-plane words, unreachable targets."""


class DialectError(GCodeError):
    """A block the target dialect cannot express (A/B/C on GRBL, M6 without tool change)."""


class PostError(GCodeError):
    """A toolpath the post cannot turn into a program for this machine and dialect.

    For example a 5-axis toolpath (tilted tool axes) for a 3-axis machine, or a machine
    whose rotary axes the dialect cannot write (code UNSUPPORTED_COMMAND).
    """
