"""Files the ``toolpath`` command writes and reads: one clear line when a path will not do.

Every command checks its output paths *before* its work (a plan can take minutes; a bad
``-o`` should not cost them), with :func:`output_file` for a single file (``-o``,
``--plot``: its folder must exist, as for ``cp``) and :func:`output_folder` for a folder
the command fills (``run``'s folder, ``demo --out``, ``serve --data-dir``: created if
missing, but no part of it may be a file). Input files are read by :func:`read_text` and
:func:`load_surface`, which name the file in every message. What still fails later (a full
disk, a permission changed meanwhile) is an ``OSError`` that ``main`` prints as one line
with :func:`describe_os_error`. Each problem is a :class:`CommandLineError` or a library
error: ``main`` prints ``toolpath: error: ...`` and exits with status 2.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import TYPE_CHECKING

from toolpath.errors import DataFileError, ToolpathError

if TYPE_CHECKING:
    from toolpath.surface import ParametricSurface

__all__ = ["CommandLineError", "describe_os_error", "load_surface", "output_file",
           "output_folder", "read_text"]


class CommandLineError(Exception):
    """A command-line argument that cannot be used; ``main`` prints it and exits with 2."""


def _nearest_existing(path: Path) -> Path:
    """``path`` or its closest ancestor that exists (``.`` at worst)."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            return candidate
        if candidate.is_symlink():  # a dangling link: stop here, it is what blocks
            return candidate
    return Path(".")


def _folder_problem(folder: Path) -> str | None:
    """Why files cannot be written in ``folder`` (which must exist), or ``None``."""
    if not folder.is_dir():
        return f"{folder} is not a folder"
    if not os.access(folder, os.W_OK | os.X_OK):
        return f"no permission to write in {folder}"
    return None


def output_file(text: str | None, flag: str) -> Path | None:
    """The path given to ``flag`` if a file can be written there, else an error naming it.

    Parameters
    ----------
    text : str or None
        The argument (``None`` or empty: no output asked for).
    flag : str
        The option as the user typed it (``-o``, ``--plot``), named in the message.

    Raises
    ------
    CommandLineError
        ``-o out/x.nc: cannot write: folder out does not exist`` and the like.
    """
    if not text:
        return None
    path = Path(text)
    folder = path.parent
    if path.is_dir():
        problem = "it is a folder"
    elif not folder.exists():
        blocker = _nearest_existing(folder)
        problem = (f"{blocker} is a file, not a folder" if blocker.exists()
                   and not blocker.is_dir() else f"folder {folder} does not exist")
    elif path.exists():
        problem = (None if os.access(path, os.W_OK) else "no permission to write it")
        problem = problem or _folder_problem(folder)
    else:
        problem = _folder_problem(folder)
    if problem is not None:
        raise CommandLineError(f"{flag} {text}: cannot write: {problem}")
    return path


def output_folder(text: str | Path, flag: str, *, shown: str | None = None) -> Path:
    """A folder the command will create (if missing) and write into, checked now.

    ``shown`` is the argument as typed when it is not the folder itself (``run -o
    out/part.nc`` fills ``out``).

    Raises
    ------
    CommandLineError
        When it, or an ancestor it would be created under, is a file, or is not writable.
    """
    folder = Path(text)
    shown = str(text) if shown is None else shown
    blocker = _nearest_existing(folder)
    if blocker.exists() and not blocker.is_dir():
        what = ("it is a file" if str(blocker) == shown
                else f"{blocker} is a file, not a folder")
        raise CommandLineError(f"{flag} {shown}: cannot write there: {what}")
    problem = _folder_problem(blocker) if blocker.exists() else f"{blocker} cannot be read"
    if problem is not None:
        raise CommandLineError(f"{flag} {shown}: cannot write there: {problem}")
    return folder


def describe_os_error(exc: OSError) -> str:
    """``PATH: reason`` for an ``OSError`` (no Python class names, no traceback)."""
    reason = exc.strerror or str(exc) or type(exc).__name__
    names = [str(n) for n in (exc.filename, exc.filename2) if n is not None]
    return f"{' -> '.join(names)}: {reason}" if names else reason


def read_text(path: str | Path, what: str) -> str:
    """The UTF-8 text of ``path``; ``DataFileError`` naming it if it cannot be read as such.

    ``what`` says what the file should hold (``"a G-code program"``).
    """
    try:
        return Path(path).read_text(encoding="utf-8")
    except OSError as exc:
        raise DataFileError(f"cannot read {what}: {exc.strerror or exc}",
                            path=str(path)) from None
    except UnicodeDecodeError as exc:
        raise DataFileError(f"not {what}: byte {exc.start} is not UTF-8 text "
                            f"({exc.object[exc.start:exc.start + 1]!r})", path=str(path)) from None


def load_surface(path: str | Path) -> ParametricSurface:
    """Read a surface JSON: a fitted surface, or one of the analytic test surfaces.

    Raises
    ------
    DataFileError
        Naming the file: missing, not text, not JSON, not a surface, or another format
        version.
    """
    from toolpath import surface_from_dict
    from toolpath.planning import analytic_surface_from_dict

    text = read_text(path, "a surface (JSON)")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise DataFileError(f"not JSON: {exc.msg}", path=str(path), line=exc.lineno) from None
    except RecursionError:
        raise DataFileError("not a surface: JSON nested too deeply", path=str(path)) from None
    kind = data.get("kind") if isinstance(data, dict) else None
    try:
        if isinstance(kind, str) and kind.startswith("analytic_"):
            return analytic_surface_from_dict(data)
        return surface_from_dict(data)
    except ToolpathError as exc:
        raise DataFileError(str(exc), path=str(path)) from None
