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

_WORDS_RE = re.compile(rf"(?:[A-Z]{NUMBER_PATTERN})*")
_WORD_RE = re.compile(rf"([A-Z])({NUMBER_PATTERN})")
_NUM_RE = re.compile(NUMBER_PATTERN)
_VALUE_LETTERS = frozenset("XYZABCIJKRFSTPNO")
_AXIS_LETTERS = ("X", "Y", "Z", "A", "B", "C")
_LENGTH_LETTERS = frozenset("XYZIJKR")
_PRINTABLE = re.compile(r"[\t\r\x20-\x7e]*")


def _syntax(code: ErrorCode, message: str) -> SyntaxGCodeError:
    return SyntaxGCodeError(code, message)


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
    def _split_comments(self, text: str) -> tuple[str, list[str]]:
        code: list[str] = []
        comments: list[str] = []
        pos = 0
        n = len(text)
        while pos < n:
            paren = text.find("(", pos)
            semi = text.find(";", pos)
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
                raise _syntax(ErrorCode.UNCLOSED_COMMENT, "'(' comment is not closed")
            body = text[paren + 1 : close]
            if "(" in body:
                raise _syntax(ErrorCode.UNCLOSED_COMMENT, "nested '(' inside a comment")
            comments.append(body.strip())
            pos = close + 1
        return "".join(code), comments

    def _read_words(self, code: str) -> list[tuple[str, float, str]]:
        if "E" not in code and _WORDS_RE.fullmatch(code) is not None:
            return [(m[0], float(m[1]), m[1]) for m in _WORD_RE.findall(code)]
        # Find the first offending character and say exactly what is wrong.
        pos = 0
        words = []
        while pos < len(code):
            letter = code[pos]
            if not ("A" <= letter <= "Z"):
                raise _syntax(
                    ErrorCode.EXPECTED_COMMAND_LETTER,
                    f"expected a word letter, found {letter!r} at column {pos + 1}",
                )
            m = _NUM_RE.match(code, pos + 1)
            if m is None:
                raise _syntax(ErrorCode.BAD_NUMBER_FORMAT, f"letter {letter!r} has no number")
            end = m.end()
            if end < len(code) and code[end] == "E":
                raise _syntax(
                    ErrorCode.BAD_NUMBER_FORMAT,
                    f"exponent in {code[pos : end + 3]!r}: numbers must be fixed point",
                )
            words.append((letter, float(m.group()), m.group()))
            pos = end
        return words

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
        code_text, comments = self._split_comments(text)
        code = "".join(code_text.split()).upper()
        limit = d.max_line_length
        if limit is not None and len(code) > limit:
            raise _syntax(
                ErrorCode.LINE_OVERFLOW,
                f"{len(code)} characters exceed the {d.name} limit of {limit}",
            )
        words = self._read_words(code)

        # -- collect and check words (no state touched yet)
        values: dict[str, float] = {}
        texts: dict[str, str] = {}
        g_words: dict[ModalGroup, int] = {}
        m_words: dict[ModalGroup, int] = {}
        for letter, value, raw in words:
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
            if feed_mode is not st.feed_mode:
                feed = None
            blocks.append(SetFeedMode(feed_mode))
        units = st.units
        if ModalGroup.UNITS in g_words:
            units = Units(g_words[ModalGroup.UNITS])
        inch = units is Units.INCH
        if "F" in values:
            f = values["F"]
            feed = f * MM_PER_INCH if inch and feed_mode is FeedMode.UNITS_PER_MINUTE else f
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
                axis_vals[letter.lower()] = v * scale if inch and letter in "XYZ" else v
        arc_words = [w for w in ("I", "J", "K", "R") if w in values]
        position = st.position
        motion_seen = self.motion_seen
        if axis_vals:
            position = self._target(position, axis_vals, distance)
            motion_seen = True
            if motion is MotionMode.RAPID:
                blocks.append(Rapid(**axis_vals))
            else:
                this_feed = self._feed_for_move(feed_mode, feed, "F" in values)
                if motion is MotionMode.LINEAR:
                    blocks.append(Linear(**axis_vals, feed=this_feed))
                else:
                    blocks.append(
                        self._arc(
                            motion,
                            plane,
                            axis_vals,
                            values,
                            st.position,
                            position,
                            this_feed,
                            scale if inch else 1.0,
                        )
                    )
                    arc_words = []
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
            raise DialectError(ErrorCode.UNSUPPORTED_COMMAND, f"{d.name} has no inverse time G93")
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
        return tuple(out)  # type: ignore[return-value]

    @staticmethod
    def _feed_for_move(feed_mode: FeedMode, feed: float | None, has_f: bool) -> float:
        if feed_mode is FeedMode.INVERSE_TIME:
            if not has_f:
                raise FeedError(
                    ErrorCode.UNDEFINED_FEED_RATE, "feed move in inverse time (G93) without F"
                )
            if not feed:
                raise FeedError(ErrorCode.UNDEFINED_FEED_RATE, "inverse-time F must be > 0")
            return feed
        if not feed:
            raise FeedError(
                ErrorCode.UNDEFINED_FEED_RATE,
                f"feed move with no feed rate defined (F is {feed!r})",
            )
        return feed

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
            chord = math.hypot(eu - su, ev - sv)
            if chord == 0.0:
                raise ArcError(ErrorCode.INVALID_TARGET, "R arc with end point equal to start")
            if chord / 2.0 - abs(r) > ARC_RADIUS_ABS_TOLERANCE_MM:
                raise ArcError(
                    ErrorCode.ARC_RADIUS_ERROR,
                    f"radius {abs(r)!r} mm is shorter than half the chord {chord / 2!r} mm",
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
