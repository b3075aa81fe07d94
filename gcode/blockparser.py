"""The strict one-block parser: read a whole block, check it, then commit modal state.

:class:`BlockParser` is the reference implementation of G-code semantics in this package.
It follows grbl's ``gc_execute_line`` split (STEP 1 read words, STEP 2-3 check them
against the current state, STEP 4 commit): a block that fails any check raises a
:class:`~gcode.errors.GCodeError` with its code and line, and leaves the parser's
:class:`~gcode.modal.ModalState` exactly as it was. The whole-file parser
(:mod:`gcode.parser`) uses it for every line its vectorized fast path does not take, and
the simulator can feed it one received line at a time.

Values are converted to the IR's units here: lengths x ``MM_PER_INCH`` under G20, never
rotary words, and never inverse-time feeds (1/min).

Reading a block takes time linear in its length whatever the text: comments are split off
in one pass, and words are matched by a pattern that cannot backtrack
(:data:`gcode.numbers.NUMBER_PATTERN`); a number beyond the float range is error 2, and
so is a value that leaves it once converted (an inch value, an incremental target).

Where GRBL and LinuxCNC decide differently, the :class:`~gcode.dialects.Dialect` flags
say which rule applies (comments, feed-mode words, R-arc tolerance, inverse-time F0), and
the error message of those dialects names the controller's own error. Where they agree,
every dialect follows them: a G1/G2/G3 written out without axis words still needs a feed
(error 22), and G2/G3 need axis words (error 26).

Examples
--------
>>> from gcode.blockparser import BlockParser
>>> bp = BlockParser()
>>> bp.parse_line("G20 G1 X1 F10", 1)
[Linear(x=25.4, y=None, z=None, a=None, b=None, c=None, feed=254.0)]
>>> bp.state.units.name, bp.state.position[0]
('INCH', 25.4)
"""

from __future__ import annotations

import math
import re
from dataclasses import replace

from gcode.dialects import GENERIC, Dialect
from gcode.errors import (
    ArcError,
    DialectError,
    ErrorCode,
    FeedError,
    GCodeError,
    ModalError,
    SyntaxGCodeError,
)
from gcode.interpreter import interpret
from gcode.modal import G_GROUPS, M_GROUPS, ModalGroup, ModalState, MotionMode
from gcode.numbers import MM_PER_INCH, NUMBER_PATTERN
from gcode.program import (
    AXES,
    Arc,
    Block,
    Comment,
    Coolant,
    CoolantMode,
    DistanceMode,
    Dwell,
    FeedMode,
    Linear,
    Plane,
    Program,
    ProgramEnd,
    Rapid,
    SetDistanceMode,
    SetFeedMode,
    SetPlane,
    SetUnits,
    SetWorkOffset,
    Spindle,
    SpindleDirection,
    ToolChange,
    Units,
)

__all__ = [
    "ARC_RADIUS_ABS_TOLERANCE_MM",
    "ARC_RADIUS_MAX_ERROR_MM",
    "ARC_RADIUS_REL_TOLERANCE",
    "INVERSE_TIME_FLOOR_RATE",
    "MAX_LINE_NUMBER",
    "BlockParser",
]

#: IJK arcs: start and end radii may differ by this much in any case (mm). Same rule as
#: grbl ``gcode.c`` (0.005 mm); it absorbs the rounding of 3-decimal mm and 4-decimal
#: inch coordinates (at most about 0.004 mm on a radius).
ARC_RADIUS_ABS_TOLERANCE_MM = 0.005
#: ... and beyond that, by at most this fraction of the radius (grbl: 0.001) ...
ARC_RADIUS_REL_TOLERANCE = 0.001
#: ... and never by more than this (mm, grbl: 0.5).
ARC_RADIUS_MAX_ERROR_MM = 0.5
#: Largest N word (grbl ``MAX_LINE_NUMBER``).
MAX_LINE_NUMBER = 10_000_000
#: Dialects with ``inverse_time_zero_feed``: an inverse-time move never runs slower than
#: this many program units (mm or inch; degrees for rotary-only moves) per minute, as in
#: LinuxCNC ``interp_inverse.cc`` (``rate = MAX(0.1, length * F)``).
INVERSE_TIME_FLOOR_RATE = 0.1

# Whole-block and one-word patterns. NUMBER_PATTERN is unambiguous and possessive and
# every word starts with a letter, which no number holds, so the repetition cannot
# backtrack either (`*+`): a fullmatch is linear in the block's length on any text.
_WORDS_RE = re.compile(rf"(?:[A-Z]{NUMBER_PATTERN})*+")
_WORD_RE = re.compile(rf"([A-Z])({NUMBER_PATTERN})")
# ... the same with comment marks "(" allowed between words, never inside one
_SPLIT_WORDS_RE = re.compile(rf"\(*+(?:[A-Z]{NUMBER_PATTERN}\(*+)*+")
_VALUE_LETTERS = frozenset("XYZABCIJKRFSTPNO")
_AXIS_LETTERS = ("X", "Y", "Z", "A", "B", "C")
_LENGTH_LETTERS = frozenset("XYZIJKR")
_PAREN_SPLIT = re.compile(r"\(([^()]*+)\)")
_PRINTABLE = re.compile(r"[\t\r\x20-\x7e]*")


def _syntax(code: ErrorCode, message: str) -> SyntaxGCodeError:
    return SyntaxGCodeError(code, message)


def _short(raw: str) -> str:
    """A number's text for a message: long ones shortened, with their length."""
    return raw if len(raw) <= 24 else f"{raw[:12]}...{raw[-4:]} ({len(raw)} characters)"


def _beyond_range(what: str) -> SyntaxGCodeError:
    return _syntax(
        ErrorCode.BAD_NUMBER_FORMAT, f"{what} is beyond the floating-point range (1.8e308)"
    )


def _says(d: Dialect, grbl: str | None = None, linuxcnc: str | None = None) -> str:
    """The controller's own verdict, appended to a message of the GRBL/LinuxCNC dialects."""
    if d.name == "grbl" and grbl:
        return f" (GRBL {grbl})"
    if d.name == "linuxcnc" and linuxcnc:
        return f" (LinuxCNC: {linuxcnc!r})"
    return ""


def _split_comments(text: str, d: Dialect) -> tuple[list[str], list[str]]:
    """Split a line into its code pieces (between comments) and its comments' texts.

    One pass: every character is looked at a bounded number of times. With
    ``d.comments_to_line_end`` an unclosed ``(`` comments out the rest of the line and a
    ``(`` inside a comment is text (GRBL ``protocol.c``); otherwise both are error 101.
    """
    if ";" not in text:
        if "(" not in text:  # the usual case: no comment at all
            return [text], []
        # one C-level split: code, comment, code, ...
        parts = _PAREN_SPLIT.split(text)
        code = parts[::2]
        if not any("(" in c for c in code):  # else an unclosed or nested '(': see below
            return code, [c.strip() for c in parts[1::2]]
    to_line_end = d.comments_to_line_end
    code = []
    comments: list[str] = []
    pos = 0
    paren = text.find("(")
    semi = text.find(";")
    while True:
        if paren < 0 and semi < 0:
            code.append(text[pos:])
            break
        if semi >= 0 and (paren < 0 or semi < paren):
            code.append(text[pos:semi])
            comments.append(text[semi + 1 :].strip())
            break
        code.append(text[pos:paren])
        close = text.find(")", paren + 1)
        if close < 0:
            if not to_line_end:
                raise _syntax(
                    ErrorCode.UNCLOSED_COMMENT,
                    "'(' comment is not closed" + _says(d, linuxcnc="Unclosed comment found"),
                )
            comments.append(text[paren + 1 :].strip())
            break
        body = text[paren + 1 : close]
        if not to_line_end and "(" in body:
            raise _syntax(
                ErrorCode.UNCLOSED_COMMENT,
                "nested '(' inside a comment" + _says(d, linuxcnc="Nested comment found"),
            )
        comments.append(body.strip())
        pos = close + 1
        paren = text.find("(", pos)
        if 0 <= semi < pos:  # that ';' was inside the comment
            semi = text.find(";", pos)
    return code, comments


def _words_fast(
    code: str, whole: re.Pattern[str] = _WORDS_RE
) -> list[tuple[str, float, str]] | None:
    """Words of a well-formed ``code`` as (letter, value, text), or None.

    One fullmatch (of ``whole``: words, or words and comment marks ``(`` between them)
    and one findall of patterns that cannot backtrack: linear in ``len(code)``. None for
    anything else (including an ``E``, which may be an exponent).
    """
    if "E" not in code and whole.fullmatch(code) is not None:
        return [(m[0], float(m[1]), m[1]) for m in _WORD_RE.findall(code)]
    return None


def _words_scan(code: str, offset: int = 0, note: str = "") -> list[tuple[str, float, str]]:
    """Hand-written scanner: the words of ``code``, or the error at the first bad one.

    Reads letter, optional sign, digits, optional point, digits, each character once
    (linear in ``len(code)``); it accepts exactly the texts :func:`_words_fast` accepts
    and returns the same words (a property test checks this), and for the others names
    the problem at its column (``offset`` + position, 1-based, in the block without
    spaces; ``note`` is appended to the message).
    """
    n = len(code)
    pos = 0
    words = []
    while pos < n:
        letter = code[pos]
        if not ("A" <= letter <= "Z"):
            raise _syntax(
                ErrorCode.EXPECTED_COMMAND_LETTER,
                f"expected a word letter, found {letter!r} at column {offset + pos + 1}" + note,
            )
        j = pos + 1
        if j < n and code[j] in "+-":
            j += 1
        digits = 0
        while j < n and "0" <= code[j] <= "9":
            j += 1
            digits += 1
        if j < n and code[j] == ".":
            j += 1
            while j < n and "0" <= code[j] <= "9":
                j += 1
                digits += 1
        if digits == 0:
            raise _syntax(ErrorCode.BAD_NUMBER_FORMAT, f"letter {letter!r} has no number" + note)
        if j < n and code[j] == "E":
            raise _syntax(
                ErrorCode.BAD_NUMBER_FORMAT,
                f"exponent in {code[pos : j + 3]!r}: numbers must be fixed point",
            )
        raw = code[pos + 1 : j]
        words.append((letter, float(raw), raw))
        pos = j
    return words


class BlockParser:
    """Strict, atomic parser of single blocks that carries the modal state.

    Parameters
    ----------
    dialect : Dialect
        What is accepted (axes, arcs, G93, M6, O words, ``%``, line limit).
    state : ModalState or None
        Initial state (GRBL power-on defaults if None).
    block_delete : bool
        Block-delete switch: when True, lines starting with ``/`` are skipped; when
        False (default) the ``/`` is ignored and the block runs, as on GRBL.

    Attributes
    ----------
    state : ModalState
        State after the last good block.
    units : Units or None
        Units declared before the first motion block (Program metadata).
    name, number : str or None, int or None
        Program name and number from an ``O`` line.
    ended : bool
        True after a closing ``%``: later lines are ignored.
    """

    def __init__(
        self,
        dialect: Dialect = GENERIC,
        *,
        state: ModalState | None = None,
        block_delete: bool = False,
    ) -> None:
        self.dialect = dialect
        self.state = state if state is not None else ModalState()
        self.block_delete = block_delete
        self.motion_seen = False
        self.units: Units | None = None
        self.name: str | None = None
        self.number: int | None = None
        self.percent = 0
        self.ended = False

    # ------------------------------------------------------------------ public
    def parse_line(self, text: str, line: int) -> list[Block]:
        """Parse one source line; commit its effect only if all of it is valid.

        Parameters
        ----------
        text : str
            The line, with or without its newline.
        line : int
            1-based line number for error reports.

        Returns
        -------
        list of Block
            IR blocks in execution order (often one, possibly none).

        Raises
        ------
        GCodeError
            With ``code``, ``line`` and ``text``; the state is unchanged.
        """
        try:
            return self._parse(text)
        except GCodeError as err:
            raise err.at(line, text.rstrip("\r\n")) from None

    # ------------------------------------------------------------------ STEP 1: read
    def _read_words(
        self, code: str, offset: int = 0, note: str = ""
    ) -> list[tuple[str, float, str]]:
        """Words of ``code`` (upper case, no spaces): the fast path, else the scanner's error.

        The scanner starts after the longest run of whole words (a possessive match, so
        linear), where the error is, unless an ``E`` may be an exponent in that run.
        """
        words = _words_fast(code)
        if words is not None:
            return words
        if "E" not in code:
            cut = _WORDS_RE.match(code).end()  # type: ignore[union-attr]  # always matches
            _words_scan(code[cut:], offset + cut, note)  # raises at its first character
        return _words_scan(code, offset, note)

    # ------------------------------------------------------------------ STEP 2-4
    def _parse(self, text: str) -> list[Block]:
        if self.ended:
            return []
        text = text.rstrip("\r\n")
        if _PRINTABLE.fullmatch(text) is None:
            bad = next(ch for ch in text if not (ch in "\t\r" or " " <= ch <= "~"))
            raise _syntax(ErrorCode.INVALID_CHARACTER, f"character {bad!r} is not printable ASCII")
        d = self.dialect
        stripped = text.strip()
        if stripped == "%":
            if not d.accept_percent:
                raise _syntax(ErrorCode.EXPECTED_COMMAND_LETTER, f"'%' is not accepted by {d.name}")
            self.percent += 1
            if self.percent >= 2:
                self.ended = True
            return []
        if stripped.startswith("/"):
            if self.block_delete:
                return []
            text = text.replace("/", "", 1)
        pieces, comments = _split_comments(text, d)
        # "(" marks where a comment was: no code piece holds one
        joined = "".join("(".join(pieces).split()).upper()
        code = joined.replace("(", "") if comments else joined
        limit = d.max_line_length
        if limit is not None and len(code) > limit:
            raise _syntax(
                ErrorCode.LINE_OVERFLOW,
                f"{len(code)} characters exceed the {d.name} limit of {limit}",
            )
        if d.comments_split_words and comments:
            # each piece between comments holds whole words (rs274ngc interp_read.cc)
            words = _words_fast(joined, _SPLIT_WORDS_RE)
            if words is None:  # piece by piece, to name the error (or read an E word)
                note = " (a comment ends the word before it)" + _says(
                    d, linuxcnc="Bad character used / Bad number format"
                )
                words = []
                at = 0
                for c in joined.split("("):
                    words += self._read_words(c, at, note)
                    at += len(c)
        else:
            words = self._read_words(code)

        # -- collect and check words (no state touched yet)
        values: dict[str, float] = {}
        texts: dict[str, str] = {}
        g_words: dict[ModalGroup, int] = {}
        m_words: dict[ModalGroup, int] = {}
        for letter, value, raw in words:
            if not math.isfinite(value):
                raise _beyond_range(f"the number of word {letter}{_short(raw)}")
            if letter in ("G", "M"):
                table = G_GROUPS if letter == "G" else M_GROUPS
                if value != int(value) or int(value) not in table:
                    raise ModalError(
                        ErrorCode.UNSUPPORTED_COMMAND, f"unsupported command {letter}{raw}"
                    )
                num = int(value)
                group = table[num]
                seen = g_words if letter == "G" else m_words
                if group in seen:
                    raise ModalError(
                        ErrorCode.MODAL_GROUP_VIOLATION,
                        f"{letter}{seen[group]} and {letter}{num} are both in {group.value}",
                    )
                seen[group] = num
                continue
            if letter not in _VALUE_LETTERS:
                raise ModalError(ErrorCode.UNSUPPORTED_COMMAND, f"unsupported word {letter}{raw}")
            if letter in values:
                raise ModalError(
                    ErrorCode.WORD_REPEATED, f"word {letter} repeated ({texts[letter]}, {raw})"
                )
            values[letter] = value
            texts[letter] = raw
        self._check_dialect(g_words, m_words, values)

        # -- program number line
        if "O" in values:
            others = set(values) - {"O", "N"}
            if others or g_words or m_words:
                raise ModalError(
                    ErrorCode.UNSUPPORTED_COMMAND,
                    "O words are accepted only as a program number on a line of their own",
                )
            o = values["O"]
            if o < 0 or o != int(o):
                raise ModalError(ErrorCode.COMMAND_VALUE_NOT_INTEGER, f"bad O number {texts['O']}")
        if "N" in values:
            n = values["N"]
            if n < 0 or n != int(n) or n > MAX_LINE_NUMBER:
                raise _syntax(ErrorCode.INVALID_LINE_NUMBER, f"bad line number N{texts['N']}")
        for letter in ("F", "S", "T", "P"):
            if letter in values and values[letter] < 0:
                raise ModalError(
                    ErrorCode.NEGATIVE_VALUE, f"{letter}{texts[letter]} must not be negative"
                )
        if "T" in values and values["T"] != int(values["T"]):
            raise ModalError(
                ErrorCode.COMMAND_VALUE_NOT_INTEGER, f"tool number T{texts['T']} is not integral"
            )

        st = self.state
        blocks: list[Block] = [Comment(c) for c in comments]
        if "O" in values:
            self.number = int(values["O"])
            if comments:
                self.name = comments[0]
            return []

        # -- state after the non-motion parts, in execution order
        feed_mode = st.feed_mode
        feed = st.feed
        if ModalGroup.FEED_MODE in g_words:
            feed_mode = FeedMode(g_words[ModalGroup.FEED_MODE])
            if feed_mode is not st.feed_mode or d.feed_mode_word_resets_feed:
                feed = None
            blocks.append(SetFeedMode(feed_mode))
        units = st.units
        if ModalGroup.UNITS in g_words:
            units = Units(g_words[ModalGroup.UNITS])
        inch = units is Units.INCH
        if "F" in values:
            f = values["F"]
            feed = f * MM_PER_INCH if inch and feed_mode is FeedMode.UNITS_PER_MINUTE else f
            if not math.isfinite(feed):
                raise _beyond_range(f"F{_short(texts['F'])} in mm/min")
        rpm = values.get("S", st.rpm)
        selected = int(values["T"]) if "T" in values else st.selected_tool
        tool = st.tool
        if ModalGroup.TOOL_CHANGE in m_words:
            tool = selected
            blocks.append(ToolChange(tool))
        spindle = st.spindle
        if ModalGroup.SPINDLE in m_words:
            spindle = SpindleDirection(m_words[ModalGroup.SPINDLE])
            blocks.append(Spindle(spindle, rpm))
        elif "S" in values and spindle is not SpindleDirection.OFF:
            blocks.append(Spindle(spindle, rpm))
        mist, flood = st.mist, st.flood
        if ModalGroup.COOLANT in m_words:
            mode = CoolantMode(m_words[ModalGroup.COOLANT])
            mist = mode is CoolantMode.MIST or (mist and mode is not CoolantMode.OFF)
            flood = mode is CoolantMode.FLOOD or (flood and mode is not CoolantMode.OFF)
            blocks.append(Coolant(mode))
        used_p = False
        if g_words.get(ModalGroup.NON_MODAL) == 4:
            if "P" not in values:
                raise ModalError(ErrorCode.VALUE_WORD_MISSING, "G4 needs a P word (dwell time)")
            seconds = values["P"] / 1000.0 if d.dwell_ms else values["P"]
            blocks.append(Dwell(seconds))
            used_p = True
        plane = st.plane
        if ModalGroup.PLANE in g_words:
            plane = Plane(g_words[ModalGroup.PLANE])
            blocks.append(SetPlane(plane))
        new_units_meta = self.units
        if ModalGroup.UNITS in g_words:
            if self.motion_seen:
                blocks.append(SetUnits(units))
            else:
                new_units_meta = units
        wcs = st.wcs
        if ModalGroup.WCS in g_words:
            wcs = g_words[ModalGroup.WCS] - 53
            blocks.append(SetWorkOffset(wcs))
        distance = st.distance
        if ModalGroup.DISTANCE in g_words:
            distance = DistanceMode(g_words[ModalGroup.DISTANCE])
            blocks.append(SetDistanceMode(distance))

        # -- motion
        motion = st.motion
        if ModalGroup.MOTION in g_words:
            motion = MotionMode(g_words[ModalGroup.MOTION])
        scale = MM_PER_INCH if inch else 1.0
        axis_vals: dict[str, float] = {}
        for letter in _AXIS_LETTERS:
            if letter in values:
                v = values[letter]
                if inch and letter in "XYZ":
                    v *= scale
                    if not math.isfinite(v):
                        raise _beyond_range(f"{letter}{_short(texts[letter])} in mm")
                axis_vals[letter.lower()] = v
        arc_words = [w for w in ("I", "J", "K", "R") if w in values]
        position = st.position
        motion_seen = self.motion_seen
        if axis_vals:
            position = self._target(position, axis_vals, distance)
            motion_seen = True
            if motion is MotionMode.RAPID:
                blocks.append(Rapid(**axis_vals))
            else:
                this_feed = self._feed_for_move(motion, feed_mode, feed, "F" in values)
                move: Linear | Arc
                if motion is MotionMode.LINEAR:
                    move = Linear(**axis_vals, feed=this_feed or 1.0)
                else:
                    move = self._arc(
                        motion,
                        plane,
                        axis_vals,
                        values,
                        st.position,
                        position,
                        this_feed or 1.0,
                        scale if inch else 1.0,
                    )
                    arc_words = []
                if this_feed == 0.0:  # inverse-time F0 where the dialect accepts it
                    floor = self._floor_feed(move, replace(st, distance=distance), position, inch)
                    move = replace(move, feed=floor) if floor else None
                if move is not None:
                    blocks.append(move)
        elif ModalGroup.MOTION in g_words and motion is not MotionMode.RAPID:
            # An explicit G1/G2/G3 without axis words still needs a feed (GRBL gcode.c
            # "[Feed rate undefined]", LinuxCNC convert_straight/convert_arc); G2/G3 also
            # need axis words (GRBL error 26; LinuxCNC "R, I, J, and K words all missing
            # for arc", or a full circle from I/J/K alone, which we refuse: see LINUXCNC).
            self._feed_for_move(motion, feed_mode, feed, "F" in values)
            if motion is not MotionMode.LINEAR:
                centre = any(w in values for w in "IJK")
                raise ArcError(
                    ErrorCode.NO_AXIS_WORDS,
                    f"G{int(motion)} without axis words"
                    + _says(
                        d,
                        grbl="error:26",
                        linuxcnc="R, I, J, and K words all missing for arc"
                        if not (centre or "R" in values)
                        else None,
                    )
                    + (
                        " (LinuxCNC would cut a full circle: refused by choice, see LINUXCNC)"
                        if centre and d.name == "linuxcnc"
                        else ""
                    ),
                )
        if arc_words:
            raise ModalError(ErrorCode.UNUSED_WORDS, f"{', '.join(arc_words)} without an arc move")
        if "P" in values and not used_p:
            raise ModalError(ErrorCode.UNUSED_WORDS, "P without G4")
        stop = None
        if ModalGroup.STOP in m_words:
            stop = ProgramEnd(rewind=m_words[ModalGroup.STOP] == 30)
            blocks.append(stop)

        # -- STEP 4: commit
        new = replace(
            st,
            motion=motion,
            plane=plane,
            units=units,
            distance=distance,
            feed_mode=feed_mode,
            wcs=wcs,
            feed=feed,
            spindle=spindle,
            rpm=rpm,
            mist=mist,
            flood=flood,
            tool=tool,
            selected_tool=selected,
            position=position,
        )
        if stop is not None:
            new = new.after_program_end()
        self.state = new
        self.units = new_units_meta
        self.motion_seen = motion_seen
        return blocks

    # ------------------------------------------------------------------ helpers
    def _check_dialect(
        self,
        g_words: dict[ModalGroup, int],
        m_words: dict[ModalGroup, int],
        values: dict[str, float],
    ) -> None:
        d = self.dialect
        for letter in ("A", "B", "C", "X", "Y", "Z"):
            if letter in values and letter.lower() not in d.axes:
                raise DialectError(ErrorCode.UNSUPPORTED_COMMAND, f"{d.name} has no {letter} axis")
        if g_words.get(ModalGroup.FEED_MODE) == 93 and not d.inverse_time:
            why = " (GRBL 1.1 accepts G93; this project's grbl dialect refuses it by choice)"
            raise DialectError(
                ErrorCode.UNSUPPORTED_COMMAND,
                f"{d.name} has no inverse time G93" + (why if d.name == "grbl" else ""),
            )
        if g_words.get(ModalGroup.MOTION) in (2, 3) and not d.arcs:
            raise DialectError(ErrorCode.UNSUPPORTED_COMMAND, f"{d.name} has no arcs")
        if ModalGroup.TOOL_CHANGE in m_words and not d.tool_change:
            raise DialectError(ErrorCode.UNSUPPORTED_COMMAND, f"{d.name} has no tool change M6")
        if "O" in values and not d.o_words:
            raise DialectError(ErrorCode.UNSUPPORTED_COMMAND, f"{d.name} has no O words")

    @staticmethod
    def _target(
        position: tuple[float, ...], axis_vals: dict[str, float], distance: DistanceMode
    ) -> tuple[float, float, float, float, float, float]:
        out = list(position)
        inc = distance is DistanceMode.INCREMENTAL
        for n, name in enumerate(AXES):
            if name in axis_vals:
                out[n] = out[n] + axis_vals[name] if inc else axis_vals[name]
                if not math.isfinite(out[n]):
                    raise _beyond_range(f"the incremental target of {name.upper()}")
        return tuple(out)  # type: ignore[return-value]

    def _feed_for_move(
        self, motion: MotionMode, feed_mode: FeedMode, feed: float | None, has_f: bool
    ) -> float:
        """The feed of a G1/G2/G3 move, or error 22 (0.0: inverse-time F0 accepted)."""
        d = self.dialect
        g = f"G{int(motion)}"
        kind = "G1" if motion is MotionMode.LINEAR else "arc"
        if feed_mode is FeedMode.INVERSE_TIME:
            if not has_f:
                raise FeedError(
                    ErrorCode.UNDEFINED_FEED_RATE,
                    f"{g} in inverse time (G93) without F"
                    + _says(d, "error:22", f"F word missing with inverse time {kind} move"),
                )
            if not feed:
                if d.inverse_time_zero_feed:
                    return 0.0
                raise FeedError(
                    ErrorCode.UNDEFINED_FEED_RATE,
                    "inverse-time F must be > 0" + _says(d, grbl="error:22"),
                )
            return feed
        if not feed:
            zero = "Cannot do G1 with zero feed rate"
            if motion is not MotionMode.LINEAR:
                zero = "Cannot make arc with zero feed rate"
            raise FeedError(
                ErrorCode.UNDEFINED_FEED_RATE,
                f"{g} with no feed rate defined (F is {feed!r})" + _says(d, "error:22", zero),
            )
        return feed

    @staticmethod
    def _floor_feed(
        move: Linear | Arc, state: ModalState, end: tuple[float, ...], inch: bool
    ) -> float | None:
        """Inverse-time feed (1/min) of an ``F0`` move run at the floor rate, None if static.

        LinuxCNC runs an inverse-time move at ``max(0.1, L * F)`` units/min, ``L`` its
        XYZ length (arc length for arcs) in program units, or its rotary distance when no
        linear axis moves; with ``F0`` the move takes ``L / 0.1`` minutes, which is the
        inverse-time feed ``0.1 / L``. A move of length 0 takes no time and is left out.
        """
        length = float(interpret(Program((move,)), state=state).lengths()[0])
        if inch:
            length /= MM_PER_INCH
        if length == 0.0:
            rotary = [e - s for s, e in zip(state.position[3:], end[3:], strict=True)]
            length = math.sqrt(sum(r * r for r in rotary))
        if length == 0.0:
            return None
        return INVERSE_TIME_FLOOR_RATE / length

    def _arc(
        self,
        motion: MotionMode,
        plane: Plane,
        axis_vals: dict[str, float],
        values: dict[str, float],
        start: tuple[float, ...],
        end: tuple[float, ...],
        feed: float,
        scale: float,
    ) -> Arc:
        u, v, _ = plane.axes
        if u not in axis_vals and v not in axis_vals:
            raise ArcError(
                ErrorCode.NO_AXIS_WORDS_IN_PLANE, f"arc without {u.upper()} or {v.upper()} word"
            )
        iu, iv = AXES.index(u), AXES.index(v)
        su, sv, eu, ev = start[iu], start[iv], end[iu], end[iv]
        cw = motion is MotionMode.ARC_CW
        if "R" in values:
            if any(w in values for w in "IJK"):
                raise ModalError(ErrorCode.UNUSED_WORDS, "I/J/K with R: give one centre form")
            r = values["R"] * scale
            if not math.isfinite(r):
                raise _beyond_range("the R word in mm")
            chord = math.hypot(eu - su, ev - sv)
            if chord == 0.0:
                raise ArcError(ErrorCode.INVALID_TARGET, "R arc with end point equal to start")
            # GRBL errs when 4 r^2 - chord^2 < 0, with no tolerance; the same test as
            # |r| < chord / 2, written so that it cannot overflow
            tolerance = 0.0 if self.dialect.exact_r_arcs else ARC_RADIUS_ABS_TOLERANCE_MM
            if chord / 2.0 - abs(r) > tolerance:
                raise ArcError(
                    ErrorCode.ARC_RADIUS_ERROR,
                    f"radius {abs(r)!r} mm is shorter than half the chord {chord / 2!r} mm"
                    + _says(self.dialect, grbl="error:34"),
                )
            return Arc(clockwise=cw, **axis_vals, r=r, plane=plane, feed=feed)
        ou, ov = plane.offsets
        offs = {w.lower(): values[w] * scale for w in "IJK" if w in values}
        if ou not in offs and ov not in offs:
            raise ArcError(
                ErrorCode.NO_OFFSETS_IN_PLANE,
                f"arc in {plane.name} without {ou.upper()} or {ov.upper()} offset",
            )
        cu, cv = su + offs.get(ou, 0.0), sv + offs.get(ov, 0.0)
        r0 = math.hypot(su - cu, sv - cv)
        r1 = math.hypot(eu - cu, ev - cv)
        if not math.isfinite(r0 + r1):
            raise _beyond_range("the arc's centre or radius")
        if r0 == 0.0:
            raise ArcError(ErrorCode.INVALID_TARGET, "arc centre coincides with its start")
        delta = abs(r1 - r0)
        if delta > ARC_RADIUS_ABS_TOLERANCE_MM and (
            delta > ARC_RADIUS_MAX_ERROR_MM or delta > ARC_RADIUS_REL_TOLERANCE * r0
        ):
            raise ArcError(
                ErrorCode.ARC_RADIUS_MISMATCH,
                f"start radius {r0:.6f} mm and end radius {r1:.6f} mm differ by {delta:.6f} mm",
            )
        return Arc(clockwise=cw, **axis_vals, **offs, plane=plane, feed=feed)
