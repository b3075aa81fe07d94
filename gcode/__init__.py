"""G-code: the canonical program model, dialects, emitter, strict parser, interpreter.

Units inside: mm, degrees (A/B/C), mm/min (1/min in inverse time), s, rev/min. Inches
exist only in G-code text (G20), converted with ``MM_PER_INCH = 25.4`` exactly.

Modules
-------
program
    Frozen IR blocks (``Rapid``, ``Linear``, ``Arc``, ``Dwell``, ``Spindle``, ``Coolant``,
    ``ToolChange``, ``SetUnits``, ``SetDistanceMode``, ``SetPlane``, ``SetFeedMode``,
    ``SetWorkOffset``, ``Comment``, ``ProgramEnd``) and ``Program``.
modal
    Modal groups, frozen ``ModalState`` and its transition rules.
numbers
    The one number formatter (scalar and vectorized) and the strict number reader.
decimals
    ``Decimals`` per ``NumberKind``: the number grid a dialect writes (no numpy).
dialects
    ``Dialect`` data and the ``GRBL``, ``LINUXCNC``, ``FANUC``, ``GENERIC`` presets.
writer
    ``Writer`` interface, streaming ``TextWriter``, ``LineCollector`` for tests.
emitter
    ``emit(program, dialect, writer)``: streaming text output.
blockparser
    ``BlockParser``: strict, atomic one-block parser carrying the modal state.
parser
    ``parse``, ``parse_with_errors``, ``parse_file``: text -> ``Program`` with line map.
interpreter
    ``interpret``: ``Program`` -> absolute motion ``Segments`` (arcs kept, linearizable).
machine_frame
    Machine joints <-> program words (work origin as G54, controller rotary values).
arcfit
    ``fit_arcs``: circular arcs through runs of planar points, verified within a tolerance.
post_defaults
    The post's default clearance and arc tolerance (no numpy: ``toolpath post --help``).
post
    ``post(toolpath, machine, dialect, options=PostOptions())``: ``Toolpath`` -> ``Program``
    (kinematics, G93 for 5-axis moves, rate limits, arcs, safe start and end).
check
    ``check_program(program_or_path, machine, dialect)`` -> list of ``Issue``: soft limits,
    rotary travel, unsupported words, long lines, missing feed, feeds above axis rates.
summary
    ``summarize``: blocks, bounds, lengths and estimated time of a program.
errors
    ``GCodeError`` (``code``, ``line``, ``text``), subclasses, ``ErrorCode`` table.

Senders (serial GRBL, Modbus) live in ``gcode.senders``.

Examples
--------
>>> import gcode
>>> p = gcode.Program((gcode.Rapid(x=0.0, y=0.0), gcode.Linear(x=1.0, feed=100.0)))
>>> gcode.parse(gcode.emit_text(p, gcode.GRBL), gcode.GRBL).blocks[3:] == p.blocks
True
"""

from gcode.errors import (
    ArcError,
    DialectError,
    ErrorCode,
    FeedError,
    GCodeError,
    ModalError,
    PostError,
    SyntaxGCodeError,
)
from toolpath.lazy import lazy_exports

#: Exported names -> defining module, imported on first use: reading a program or its
#: errors does not load the post (and through it the planner).
_EXPORTS = {
    "ArcSpan": "gcode.arcfit",
    "fit_arcs": "gcode.arcfit",
    "BlockParser": "gcode.blockparser",
    "Issue": "gcode.check",
    "IssueCode": "gcode.check",
    "Severity": "gcode.check",
    "check_file": "gcode.check",
    "check_program": "gcode.check",
    "check_text": "gcode.check",
    "FANUC": "gcode.dialects",
    "GENERIC": "gcode.dialects",
    "GRBL": "gcode.dialects",
    "LINUXCNC": "gcode.dialects",
    "CommentStyle": "gcode.dialects",
    "Dialect": "gcode.dialects",
    "dialect_by_name": "gcode.dialects",
    "dialect_names": "gcode.dialects",
    "emit": "gcode.emitter",
    "emit_file": "gcode.emitter",
    "emit_lines": "gcode.emitter",
    "emit_text": "gcode.emitter",
    "Segments": "gcode.interpreter",
    "interpret": "gcode.interpreter",
    "ModalGroup": "gcode.modal",
    "ModalState": "gcode.modal",
    "MotionMode": "gcode.modal",
    "MM_PER_INCH": "gcode.numbers",
    "Decimals": "gcode.decimals",
    "NumberKind": "gcode.decimals",
    "format_array": "gcode.numbers",
    "format_number": "gcode.numbers",
    "read_number": "gcode.numbers",
    "parse": "gcode.parser",
    "parse_file": "gcode.parser",
    "parse_with_errors": "gcode.parser",
    "PostOptions": "gcode.post",
    "post": "gcode.post",
    "Arc": "gcode.program",
    "Block": "gcode.program",
    "Comment": "gcode.program",
    "Coolant": "gcode.program",
    "CoolantMode": "gcode.program",
    "DistanceMode": "gcode.program",
    "Dwell": "gcode.program",
    "FeedMode": "gcode.program",
    "Linear": "gcode.program",
    "Plane": "gcode.program",
    "Program": "gcode.program",
    "ProgramEnd": "gcode.program",
    "Rapid": "gcode.program",
    "SetDistanceMode": "gcode.program",
    "SetFeedMode": "gcode.program",
    "SetPlane": "gcode.program",
    "SetUnits": "gcode.program",
    "SetWorkOffset": "gcode.program",
    "Spindle": "gcode.program",
    "SpindleDirection": "gcode.program",
    "ToolChange": "gcode.program",
    "Units": "gcode.program",
    "ProgramSummary": "gcode.summary",
    "summarize": "gcode.summary",
    "LineCollector": "gcode.writer",
    "TextWriter": "gcode.writer",
    "Writer": "gcode.writer",
}

__all__ = [
    "FANUC",
    "GENERIC",
    "GRBL",
    "LINUXCNC",
    "MM_PER_INCH",
    "Arc",
    "ArcError",
    "ArcSpan",
    "Block",
    "BlockParser",
    "Comment",
    "CommentStyle",
    "Coolant",
    "CoolantMode",
    "Decimals",
    "Dialect",
    "DialectError",
    "DistanceMode",
    "Dwell",
    "ErrorCode",
    "FeedError",
    "FeedMode",
    "GCodeError",
    "Issue",
    "IssueCode",
    "LineCollector",
    "Linear",
    "ModalError",
    "ModalGroup",
    "ModalState",
    "MotionMode",
    "NumberKind",
    "Plane",
    "PostError",
    "PostOptions",
    "Program",
    "ProgramEnd",
    "ProgramSummary",
    "Rapid",
    "Segments",
    "SetDistanceMode",
    "SetFeedMode",
    "SetPlane",
    "SetUnits",
    "SetWorkOffset",
    "Severity",
    "Spindle",
    "SpindleDirection",
    "SyntaxGCodeError",
    "TextWriter",
    "ToolChange",
    "Units",
    "Writer",
    "check_file",
    "check_program",
    "check_text",
    "dialect_by_name",
    "dialect_names",
    "emit",
    "emit_file",
    "emit_lines",
    "emit_text",
    "fit_arcs",
    "format_array",
    "format_number",
    "interpret",
    "parse",
    "parse_file",
    "parse_with_errors",
    "post",
    "read_number",
    "summarize",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
