r"""The writer interface the emitter streams G-code text through.

The emitter never builds a whole program as one string: it hands the writer chunks of
complete lines (each ending in ``"\n"``). :class:`TextWriter` streams them to a text or
binary stream or a file; :class:`LineCollector` keeps the lines for tests (the collecting
twin of ezdxf's ``TagWriter``/``TagCollector``).

Examples
--------
>>> from gcode.writer import LineCollector
>>> w = LineCollector()
>>> w.write("G21\nG0X0Y0\n")
>>> w.lines
['G21', 'G0X0Y0']
"""

from __future__ import annotations

import io
from abc import ABC, abstractmethod
from pathlib import Path
from types import TracebackType
from typing import IO

__all__ = ["LineCollector", "TextWriter", "Writer"]


class Writer(ABC):
    r"""Receives G-code text as chunks of complete ``"\n"``-terminated lines."""

    @abstractmethod
    def write(self, text: str) -> None:
        r"""Write ``text``: zero or more complete lines, each ending in ``"\n"``."""

    def close(self) -> None:  # noqa: B027 - optional hook
        """Flush and release resources (no-op by default)."""

    def __enter__(self) -> Writer:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


class TextWriter(Writer):
    r"""Stream lines to a text stream, a binary stream (ASCII) or a file path.

    Parameters
    ----------
    target : str, Path, text stream or binary stream
        A path opens a file (ASCII, ``"\n"`` newlines) that :meth:`close` closes;
        a stream is written to and left open.
    """

    def __init__(self, target: str | Path | IO[str] | IO[bytes]) -> None:
        self._owned = isinstance(target, str | Path)
        if self._owned:
            stream: IO[str] | IO[bytes] = open(target, "w", encoding="ascii", newline="\n")
        else:
            stream = target  # type: ignore[assignment]
        self._binary = isinstance(stream, io.RawIOBase | io.BufferedIOBase) or (
            hasattr(stream, "mode") and "b" in str(getattr(stream, "mode", ""))
        )
        self._stream = stream
        self.lines_written = 0

    def write(self, text: str) -> None:
        """Write a chunk of complete lines."""
        self.lines_written += text.count("\n")
        if self._binary:
            self._stream.write(text.encode("ascii"))  # type: ignore[arg-type]
        else:
            self._stream.write(text)  # type: ignore[arg-type]

    def close(self) -> None:
        """Flush; close the file if this writer opened it."""
        self._stream.flush()
        if self._owned:
            self._stream.close()


class LineCollector(Writer):
    """Collect written lines in :attr:`lines` (without newlines), for tests."""

    def __init__(self) -> None:
        self.lines: list[str] = []

    def write(self, text: str) -> None:
        """Split a chunk of complete lines and keep them."""
        if not text:
            return
        if not text.endswith("\n"):
            raise ValueError(f"writer chunks must end with a newline, got {text[-20:]!r}")
        self.lines.extend(text[:-1].split("\n"))

    @property
    def text(self) -> str:
        r"""All lines joined, each ending in ``"\n"``."""
        return "".join(line + "\n" for line in self.lines)
