"""Controller dialects as data: one frozen ``Dialect`` and the presets.

A dialect says what a controller accepts and how text is laid out for it: decimals, axis
letters, arcs, inverse time, tool change, O words, ``%`` delimiters, line numbers, comment
style, line-length limit, modal suppression and the preamble/postamble (IR blocks, written
through the same formatter as the program). Both the emitter and the parser read it.

Presets: :data:`GRBL`, :data:`LINUXCNC`, :data:`FANUC` and the permissive
:data:`GENERIC` (everything we can parse, no line limit), the parser's default.

Examples
--------
>>> from gcode.dialects import dialect_by_name
>>> d = dialect_by_name("grbl")
>>> d.axes, d.max_line_length, d.inverse_time
(('x', 'y', 'z'), 79, False)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

from gcode.decimals import Decimals
from gcode.program import (
    AXES,
    Block,
    DistanceMode,
    FeedMode,
    Plane,
    SetDistanceMode,
    SetFeedMode,
    SetPlane,
)

__all__ = [
    "FANUC",
    "GENERIC",
    "GRBL",
    "LINUXCNC",
    "CommentStyle",
    "Dialect",
    "dialect_by_name",
    "dialect_names",
]


class CommentStyle(Enum):
    """How comments are written: ``(text)`` or ``; text``."""

    PARENS = "parens"
    SEMICOLON = "semicolon"


_SAFE_START: tuple[Block, ...] = (
    SetFeedMode(FeedMode.UNITS_PER_MINUTE),
    SetPlane(Plane.XY),
    SetDistanceMode(DistanceMode.ABSOLUTE),
)


@dataclass(frozen=True, slots=True)
class Dialect:
    """What one controller accepts and how G-code text is laid out for it.

    Parameters
    ----------
    name : str
        Preset name.
    axes : tuple of str
        Axis words accepted, as IR field names (``"x"`` ... ``"c"``).
    decimals : Decimals
        Decimals per kind of value.
    trim_zeros : bool
        Drop trailing fraction zeros.
    keep_point : bool
        Keep the decimal point on integral values (``X10.``), for controls that read
        point-less numbers in least-input increments (Fanuc).
    max_line_length : int or None
        Longest block in characters, counted as GRBL counts them (spaces and comments
        excluded); None for no limit. The emitter also keeps comment lines within it
        (wrapped), and ``check_program`` warns about longer lines, comments included.
    word_separator : str
        Text between words (``""`` for compact GRBL streaming).
    comment_style : CommentStyle
        Comment syntax written by the emitter (the parser reads both).
    arcs : bool
        G2/G3 accepted.
    inverse_time : bool
        G93 accepted.
    tool_change : bool
        M6 accepted.
    o_words : bool
        ``O`` program-number words accepted.
    program_number : bool
        The emitter writes an ``O`` line (``O0001 (NAME)``).
    program_number_digits : int
        Zero padding of the program number.
    percent : bool
        The emitter writes ``%`` delimiter lines (the parser accepts ``%`` when
        ``accept_percent``).
    accept_percent : bool
        The parser accepts ``%`` lines.
    line_numbers : bool
        The emitter writes N words.
    line_number_start, line_number_step, line_number_max : int
        N numbering: first, increment, and the value after which numbering restarts.
    suppress_modal : bool
        Omit the motion G word and F when unchanged (F is always written in G93).
    pad_codes : bool
        Write G and M numbers with two digits (``G01``).
    dwell_ms : bool
        G4 P is in milliseconds (Fanuc) instead of seconds.
    preamble, postamble : tuple of Block
        Blocks written before and after the program's own blocks (after the units line).
    comments_to_line_end : bool
        Comments are stripped the way GRBL's ``protocol.c`` strips them: a ``(`` comment
        runs to the first ``)`` or, unclosed, to the end of the line (the block before it
        still runs), and a ``(`` inside a comment is plain text. When False (default) an
        unclosed or nested ``(`` is error 101, as in LinuxCNC ("Unclosed comment found",
        "Nested comment found").
    comments_split_words : bool
        A ``( )`` comment ends the word before it, as in LinuxCNC's ``interp_read.cc``
        (each item is read whole; a digit after a comment is "Bad character used"): then
        ``G9(c)4`` is an error, not ``G94``. When False, comments are removed first and the
        text around them joins up, as in GRBL.
    feed_mode_word_resets_feed : bool
        Every G93/G94 word, even one that repeats the current mode, leaves the feed rate
        undefined (LinuxCNC ``convert_feed_mode`` sets it to 0), so the next feed move
        needs an F. When False, only a change of mode does (GRBL).
    exact_r_arcs : bool
        An R-form arc whose radius is shorter than half its chord by any amount is
        rejected (GRBL ``gcode.c``: error 34 when ``4 r**2 - x**2 - y**2 < 0``). When False
        it may be shorter by up to ``ARC_RADIUS_ABS_TOLERANCE_MM`` (rounding of written
        coordinates) and is then a half circle.
    inverse_time_zero_feed : bool
        An inverse-time (G93) feed move with ``F0`` is accepted and runs at the
        controller's floor rate (LinuxCNC ``interp_inverse.cc``: the canonical feed is
        ``max(0.1, length * F)`` units/min). When False, F must be > 0 (GRBL error 22).
    """

    name: str
    axes: tuple[str, ...] = AXES
    decimals: Decimals = field(default_factory=Decimals)
    trim_zeros: bool = True
    keep_point: bool = False
    max_line_length: int | None = None
    word_separator: str = " "
    comment_style: CommentStyle = CommentStyle.PARENS
    arcs: bool = True
    inverse_time: bool = True
    tool_change: bool = True
    o_words: bool = True
    program_number: bool = False
    program_number_digits: int = 4
    percent: bool = False
    accept_percent: bool = True
    line_numbers: bool = False
    line_number_start: int = 10
    line_number_step: int = 10
    line_number_max: int = 99999
    suppress_modal: bool = True
    pad_codes: bool = False
    dwell_ms: bool = False
    preamble: tuple[Block, ...] = ()
    postamble: tuple[Block, ...] = ()
    comments_to_line_end: bool = False
    comments_split_words: bool = False
    feed_mode_word_resets_feed: bool = False
    exact_r_arcs: bool = False
    inverse_time_zero_feed: bool = False

    def __post_init__(self) -> None:
        bad = [a for a in self.axes if a not in AXES]
        if bad:
            raise ValueError(f"Dialect.axes must be among {AXES}, got {bad!r}")
        if self.max_line_length is not None and self.max_line_length < 8:
            raise ValueError(f"max_line_length too small: {self.max_line_length!r}")
        if self.word_separator not in ("", " "):
            raise ValueError(f"word_separator must be '' or ' ', got {self.word_separator!r}")
        if self.line_number_step <= 0 or self.line_number_start < 0:
            raise ValueError("line numbers need start >= 0 and step > 0")


#: GRBL 1.1: XYZ only, 79 characters (80-byte line buffer incl. NUL, error:11 beyond),
#: no tool change, arcs, no O words, no ``%``, compact text. Verdicts follow GRBL 1.1h's
#: ``protocol.c`` and ``gcode.c``: comments end at ``)`` or the line end, R arcs may not be
#: short of half the chord by any amount (error 34), G1/G2/G3 need a feed even without axis
#: words (error 22), G2/G3 need axis words (error 26).
#:
#: Stricter than GRBL by choice: **G93 is refused** (error 20) although GRBL 1.1 accepts
#: inverse time, because this project's GRBL machines are 3-axis and never need it, and a
#: G93 program sent to them is almost surely meant for another machine.
GRBL = Dialect(
    name="grbl",
    axes=("x", "y", "z"),
    max_line_length=79,
    word_separator="",
    inverse_time=False,
    tool_change=False,
    o_words=False,
    accept_percent=False,
    preamble=_SAFE_START,
    comments_to_line_end=True,
    exact_r_arcs=True,
)

#: LinuxCNC 2.9: A/B/C, G93, tool change, O words; rs274ngc's LINELEN is 255. Verdicts
#: follow rs274ngc: a comment inside a word is an error (``G9(c)4``), every G93/G94 word
#: leaves F undefined, G93 moves need F on every move but accept ``F0`` (floor rate 0.1
#: units/min), unclosed and nested comments are errors.
#:
#: Stricter than LinuxCNC by choice: ``G2``/``G3`` with I/J/K but no axis word (a full
#: circle in LinuxCNC) is refused (error 26), as GRBL refuses it, so that a program's arcs
#: get one verdict on both controllers; write a full circle with its end point.
LINUXCNC = Dialect(
    name="linuxcnc",
    max_line_length=255,
    preamble=_SAFE_START,
    comments_split_words=True,
    feed_mode_word_resets_feed=True,
    inverse_time_zero_feed=True,
)

#: Fanuc-style ISO: ``%`` delimiters, ``O0001 (NAME)``, N numbers, ``G01``, points on
#: integral values, G4 P in milliseconds.
FANUC = Dialect(
    name="fanuc",
    keep_point=True,
    program_number=True,
    percent=True,
    line_numbers=True,
    pad_codes=True,
    dwell_ms=True,
    preamble=_SAFE_START,
)

#: Everything the parser understands, no line limit: the parser's default.
GENERIC = Dialect(name="generic")

_PRESETS = {d.name: d for d in (GRBL, LINUXCNC, FANUC, GENERIC)}


def dialect_names() -> tuple[str, ...]:
    """Return the preset names."""
    return tuple(_PRESETS)


def dialect_by_name(name: str) -> Dialect:
    """Return the preset called ``name`` (case-insensitive).

    Parameters
    ----------
    name : str
        ``"grbl"``, ``"linuxcnc"``, ``"fanuc"`` or ``"generic"``.

    Returns
    -------
    Dialect
        The preset.

    Raises
    ------
    ValueError
        For an unknown name; the message lists the known ones.
    """
    try:
        return _PRESETS[name.strip().lower()]
    except KeyError:
        raise ValueError(
            f"unknown dialect {name!r}; known: {', '.join(sorted(_PRESETS))}"
        ) from None
