r"""Pre-flight: check a program against the machine before a single byte is sent.

:func:`preflight` runs :func:`gcode.check.check_program` (soft limits, words and commands
the controller lacks, lines over its line buffer, missing feeds) and refuses the program
with :class:`~gcode.senders.errors.PreflightError` when any issue is an error; warnings
(feeds above an axis's rate, which the controller clamps) are returned for the report.
It also refuses lines too long for grbl's 80-byte line buffer after compaction.

Examples
--------
>>> from machines import load_machine
>>> from gcode.senders.job import Job
>>> job = Job.from_text("G21 G90\nG0 X500 Y0\n", "part.nc")
>>> try:
...     preflight(job, load_machine("grbl-router"))
... except PreflightError as err:
...     print(err.line, err.issues[0].code.value)
2 soft-limit
"""

from __future__ import annotations

from gcode.check import Issue, IssueCode, Severity, check_text
from gcode.dialects import Dialect
from gcode.senders.errors import PreflightError
from gcode.senders.job import MAX_LINE_CHARS, Job
from machines import Machine

__all__ = ["preflight"]


def preflight(job: Job, machine: Machine, dialect: Dialect | None = None) -> list[Issue]:
    """Refuse a program the controller would reject or that leaves the machine's travel.

    Parameters
    ----------
    job : Job
        The program.
    machine : Machine
        The machine it will run on (travel, axes, rates, dialect).
    dialect : Dialect or None
        The controller's dialect (``machine.dialect`` when None).

    Returns
    -------
    list of Issue
        The warnings (nothing that refuses the program).

    Raises
    ------
    PreflightError
        Listing every error issue, the first one in the message.
    """
    issues = check_text(job.source, machine, dialect)
    issues += [
        Issue(
            ln.number,
            IssueCode.LINE_TOO_LONG,
            f"{len(ln.text)} characters after removing spaces and comments; the "
            f"controller's line buffer holds {MAX_LINE_CHARS}",
        )
        for ln in job.too_long()
    ]
    errors = [i for i in issues if i.severity is Severity.ERROR]
    if errors:
        errors.sort(key=lambda i: i.line if i.line is not None else 0)
        raise PreflightError(errors, name=job.name)
    return [i for i in issues if i.severity is not Severity.ERROR]
