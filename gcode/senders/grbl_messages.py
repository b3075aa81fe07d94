r"""GRBL 1.1 messages from the controller, parsed into small frozen records (sans-IO).

Everything a GRBL 1.1 controller sends is one line ended by ``\r\n``. Responses answer a
line the host sent (exactly one per line): ``ok`` and ``error:N``. Everything else is a
push and is never counted against a sent line: ``<...>`` status reports, ``ALARM:N``,
the welcome banner ``Grbl 1.1h ['$' for help]`` (a reset happened), ``[MSG:...]`` and
other bracketed feedback, ``$n=v`` settings, ``>...:ok`` start-up line echoes.

:func:`parse_message` turns one line (without its line end) into one of
:class:`Ok`, :class:`ErrorResponse`, :class:`AlarmPush`, :class:`StatusReport`,
:class:`Welcome`, :class:`Feedback`, :class:`SettingLine`, :class:`StartupLine` or
:class:`Unknown`. :data:`ERROR_MEANINGS` and :data:`ALARM_MEANINGS` give the firmware's
short texts (grbl 1.1h ``doc/csv/error_codes_en_US.csv`` and ``alarm_codes_en_US.csv``),
so a report can say what ``error:20`` means.

Examples
--------
>>> parse_message("error:20")
ErrorResponse(code=20)
>>> r = parse_message("<Hold:0|MPos:1.000,2.000,-3.500|Bf:15,128|FS:0,0>")
>>> r.state, r.sub_state, r.machine_position, r.planner_free, r.rx_free
('Hold', 0, (1.0, 2.0, -3.5), 15, 128)
>>> parse_message("Grbl 1.1h ['$' for help]")
Welcome(version='1.1h')
"""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = [
    "ALARM_MEANINGS",
    "ERROR_MEANINGS",
    "AlarmPush",
    "ErrorResponse",
    "Feedback",
    "Message",
    "Ok",
    "SettingLine",
    "StartupLine",
    "StatusReport",
    "Unknown",
    "Welcome",
    "alarm_text",
    "error_text",
    "parse_message",
]

#: GRBL 1.1 ``error:N`` meanings (short form of grbl's error_codes_en_US.csv).
ERROR_MEANINGS: dict[int, str] = {
    1: "G-code words consist of a letter and a value; letter was not found",
    2: "missing the expected G-code word value or numeric value format is not valid",
    3: "'$' system command was not recognized or supported",
    4: "negative value received for an expected positive value",
    5: "homing cycle failure: homing is not enabled via settings",
    6: "minimum step pulse time must be greater than 3 usec",
    7: "an EEPROM read failed; auto-restoring affected EEPROM to default values",
    8: "'$' command cannot be used unless Grbl is IDLE",
    9: "G-code commands are locked out during alarm or jog state",
    10: "soft limits cannot be enabled without homing also enabled",
    11: "max characters per line exceeded; line was not processed and executed",
    12: "'$' setting value causes the step rate to exceed the maximum supported",
    13: "safety door detected as opened and door state initiated",
    14: "build info or startup line exceeded EEPROM line length limit",
    15: "jog target exceeds machine travel; jog command has been ignored",
    16: "jog command has no '=' or contains prohibited g-code",
    17: "laser mode requires PWM output",
    20: "unsupported or invalid g-code command found in block",
    21: "more than one g-code command from same modal group found in block",
    22: "feed rate has not yet been set or is undefined",
    23: "g-code command in block requires an integer value",
    24: "more than one g-code command that requires axis words found in block",
    25: "repeated g-code word found in block",
    26: "no axis words found in block for g-code command or current modal state",
    27: "line number value is invalid",
    28: "g-code command is missing a required value word",
    29: "G59.x work coordinate systems are not supported",
    30: "G53 only allowed with G0 and G1 motion modes",
    31: "axis words found in block when no command or current modal state uses them",
    32: "G2 and G3 arcs require at least one in-plane axis word",
    33: "motion command target is invalid",
    34: "arc radius value is invalid",
    35: "G2 and G3 arcs require at least one in-plane offset word",
    36: "unused value words found in block",
    37: "G43.1 dynamic tool length offset is not assigned to configured tool length axis",
    38: "tool number greater than max supported value",
}

#: GRBL 1.1 ``ALARM:N`` meanings (short form of grbl's alarm_codes_en_US.csv).
ALARM_MEANINGS: dict[int, str] = {
    1: "hard limit triggered; machine position is likely lost, re-homing is recommended",
    2: "soft limit: the motion target exceeds machine travel; machine position retained",
    3: "reset while in motion; machine position is likely lost, re-homing is recommended",
    4: "probe fail: the probe is not in the expected initial state",
    5: "probe fail: the probe did not contact the workpiece",
    6: "homing fail: reset during active homing cycle",
    7: "homing fail: safety door was opened during homing cycle",
    8: "homing fail: cycle failed to clear limit switch when pulling off",
    9: "homing fail: could not find limit switch within search distance",
}


def error_text(code: int) -> str:
    """The meaning of ``error:code`` (``"unknown error"`` for numbers grbl does not use)."""
    return ERROR_MEANINGS.get(code, "unknown error")


def alarm_text(code: int) -> str:
    """The meaning of ``ALARM:code`` (``"unknown alarm"`` for numbers grbl does not use)."""
    return ALARM_MEANINGS.get(code, "unknown alarm")


@dataclass(frozen=True, slots=True)
class Ok:
    """``ok``: the oldest outstanding line was accepted."""


@dataclass(frozen=True, slots=True)
class ErrorResponse:
    """``error:N``: the oldest outstanding line was rejected with GRBL code ``code``."""

    code: int


@dataclass(frozen=True, slots=True)
class AlarmPush:
    """``ALARM:N``: the controller entered the alarm state (a push, never a response)."""

    code: int


@dataclass(frozen=True, slots=True)
class StatusReport:
    """A ``<...>`` status report.

    Attributes
    ----------
    state : str
        ``Idle``, ``Run``, ``Hold``, ``Jog``, ``Alarm``, ``Door``, ``Check``, ``Home``,
        ``Sleep``.
    sub_state : int or None
        The ``:n`` after ``Hold`` (0 complete, 1 decelerating) or ``Door``.
    machine_position : tuple of float or None
        ``MPos`` (mm), or None when the report gives ``WPos``.
    work_position : tuple of float or None
        ``WPos`` (mm), or None when the report gives ``MPos``.
    work_offset : tuple of float or None
        ``WCO`` (mm) when the report carries it.
    planner_free, rx_free : int or None
        ``Bf:`` free planner blocks and free receive-buffer bytes.
    line_number : int or None
        ``Ln:`` (only with N words and a build that reports them).
    feed_mm_per_min, spindle_rpm : float or None
        ``FS:`` (or ``F:``) values.
    raw : str
        The report text.
    """

    state: str
    sub_state: int | None = None
    machine_position: tuple[float, ...] | None = None
    work_position: tuple[float, ...] | None = None
    work_offset: tuple[float, ...] | None = None
    planner_free: int | None = None
    rx_free: int | None = None
    line_number: int | None = None
    feed_mm_per_min: float | None = None
    spindle_rpm: float | None = None
    raw: str = ""

    @property
    def hold_complete(self) -> bool:
        """True for ``Hold:0``: the feed hold has finished decelerating."""
        return self.state == "Hold" and self.sub_state == 0

    @property
    def moving(self) -> bool:
        """True while axes may move (Run, Jog, Home, or a hold still decelerating)."""
        return self.state in ("Run", "Jog", "Home") or (
            self.state == "Hold" and self.sub_state != 0
        )


@dataclass(frozen=True, slots=True)
class Welcome:
    """The welcome banner: the controller was reset (all its buffers are empty)."""

    version: str


@dataclass(frozen=True, slots=True)
class Feedback:
    """A bracketed push such as ``[MSG:Reset to continue]``, ``[GC:...]``, ``[VER:...]``."""

    kind: str
    text: str


@dataclass(frozen=True, slots=True)
class SettingLine:
    """A ``$n=value`` line (``$$`` output)."""

    number: str
    value: str


@dataclass(frozen=True, slots=True)
class StartupLine:
    """A ``>line:ok`` start-up block echo."""

    text: str


@dataclass(frozen=True, slots=True)
class Unknown:
    """Anything else (kept so a log shows it)."""

    text: str


Message = (
    Ok
    | ErrorResponse
    | AlarmPush
    | StatusReport
    | Welcome
    | Feedback
    | SettingLine
    | StartupLine
    | Unknown
)

_OK = Ok()
_WELCOME = re.compile(r"Grbl\s+(\S+)")
_SETTING = re.compile(r"\$(N?\d+)=(.*)")


def _floats(text: str) -> tuple[float, ...] | None:
    try:
        return tuple(float(v) for v in text.split(","))
    except ValueError:
        return None


def _status(text: str) -> StatusReport | Unknown:
    fields = text[1:-1].split("|")
    name, _, sub = fields[0].partition(":")
    kw: dict[str, object] = {}
    try:
        for f in fields[1:]:
            key, _, value = f.partition(":")
            if key == "MPos":
                kw["machine_position"] = _floats(value)
            elif key == "WPos":
                kw["work_position"] = _floats(value)
            elif key == "WCO":
                kw["work_offset"] = _floats(value)
            elif key == "Bf":
                blocks, rx = value.split(",")
                kw["planner_free"], kw["rx_free"] = int(blocks), int(rx)
            elif key == "Ln":
                kw["line_number"] = int(value)
            elif key in ("FS", "F"):
                nums = _floats(value) or ()
                if nums:
                    kw["feed_mm_per_min"] = nums[0]
                if len(nums) > 1:
                    kw["spindle_rpm"] = nums[1]
        sub_state = int(sub) if sub else None
    except ValueError:
        return Unknown(text)
    return StatusReport(name, sub_state, raw=text, **kw)  # type: ignore[arg-type]


def parse_message(line: str) -> Message:
    """Parse one line from a GRBL 1.1 controller (line end already removed).

    Parameters
    ----------
    line : str
        The text, e.g. ``"ok"``, ``"error:9"``, ``"<Idle|MPos:0.000,0.000,0.000|FS:0,0>"``.

    Returns
    -------
    Message
        The record; :class:`Unknown` for text the protocol does not define.
    """
    text = line.strip()
    if text == "ok":
        return _OK
    if text.startswith("error:"):
        try:
            return ErrorResponse(int(text[6:]))
        except ValueError:
            return Unknown(text)
    if text.startswith("<") and text.endswith(">"):
        return _status(text)
    if text.startswith("ALARM:"):
        try:
            return AlarmPush(int(text[6:]))
        except ValueError:
            return Unknown(text)
    if text.startswith("[") and text.endswith("]"):
        kind, _, body = text[1:-1].partition(":")
        return Feedback(kind, body)
    m = _WELCOME.match(text)
    if m is not None:
        return Welcome(m.group(1))
    m = _SETTING.fullmatch(text)
    if m is not None:
        return SettingLine(m.group(1), m.group(2))
    if text.startswith(">") and text.endswith(":ok"):
        return StartupLine(text[1:-3])
    return Unknown(text)
