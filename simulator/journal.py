"""The journal: one record per executed line, so tests can prove exactly-once execution.

A line is journaled when everything it asked for is done: its last motion block has
reached its end, or (for lines without motion) every line before it is done. Lines
rejected with an error, lines discarded by a reset and lines parsed in check mode are not
journaled, nor are lines that make no block (a lone ``G1F1200`` or ``G94``: only modal
state changes). Records are kept in columns (numpy chunks for whole-program runs, Python
lists for streamed lines) and read back as :class:`JournalEntry` or as arrays.

Examples
--------
>>> j = Journal(axes="XYZ")
>>> j.record(seq=1, line=1, n_word=None, text="G1X1F100", position=(1.0, 0.0, 0.0), time_s=0.6)
>>> len(j), j[0].seq, j[0].position
(1, 1, (1.0, 0.0, 0.0))
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["Journal", "JournalEntry"]


@dataclass(frozen=True, slots=True)
class JournalEntry:
    """One executed line.

    Attributes
    ----------
    seq : int
        Controller sequence number: 1, 2, ... over the simulator's life (never reset),
        one per accepted line; a Modbus block keeps the host's SEQ here.
    line : int
        Source line as the front end knows it: the count of lines the GRBL front end has
        received (1-based, every line counted, never reset) or the Modbus block SEQ.
    n_word : int or None
        The line's ``N`` word, if it had one.
    text : str
        The line as executed (upper case, no spaces or comments).
    position : tuple of float
        Machine position after the line, one value per machine axis (mm, deg).
    time_s : float
        Virtual time at which the line completed, s.
    """

    seq: int
    line: int
    n_word: int | None
    text: str
    position: tuple[float, ...]
    time_s: float


class Journal:
    """Append-only record of executed lines.

    Parameters
    ----------
    axes : str
        Machine axis letters, the order of each position.
    """

    def __init__(self, axes: str) -> None:
        self.axes = axes
        self._chunks: list[dict[str, np.ndarray]] = []
        self._seq: list[int] = []
        self._line: list[int] = []
        self._n: list[int | None] = []
        self._text: list[str] = []
        self._pos: list[tuple[float, ...]] = []
        self._t: list[float] = []
        self._count = 0

    def __len__(self) -> int:
        return self._count

    def record(
        self,
        *,
        seq: int,
        line: int,
        n_word: int | None,
        text: str,
        position: tuple[float, ...],
        time_s: float,
    ) -> None:
        """Append one executed line (see :class:`JournalEntry` for the fields)."""
        self._seq.append(seq)
        self._line.append(line)
        self._n.append(n_word)
        self._text.append(text)
        self._pos.append(position)
        self._t.append(time_s)
        self._count += 1

    def record_arrays(
        self,
        *,
        seq: npt.NDArray[np.int64],
        line: npt.NDArray[np.int64],
        position: npt.NDArray[np.float64],
        time_s: npt.NDArray[np.float64],
    ) -> None:
        """Append many executed lines at once (whole-program runs; no text kept)."""
        self._flush()
        self._chunks.append(
            {"seq": seq, "line": line, "position": position, "time_s": time_s, "text": None}
        )
        self._count += int(seq.shape[0])

    def _flush(self) -> None:
        if not self._seq:
            return
        k = len(self.axes)
        pos = np.array(self._pos, dtype=np.float64).reshape(len(self._pos), k)
        self._chunks.append(
            {
                "seq": np.array(self._seq, dtype=np.int64),
                "line": np.array(self._line, dtype=np.int64),
                "position": pos,
                "time_s": np.array(self._t, dtype=np.float64),
                "text": (list(self._text), list(self._n)),
            }
        )
        self._seq, self._line, self._n, self._text, self._pos, self._t = [], [], [], [], [], []

    def _column(self, name: str) -> np.ndarray:
        self._flush()
        if not self._chunks:
            shape = (0, len(self.axes)) if name == "position" else (0,)
            return np.zeros(shape, dtype=np.int64 if name in ("seq", "line") else np.float64)
        return np.concatenate([c[name] for c in self._chunks])

    def seqs(self) -> npt.NDArray[np.int64]:
        """Sequence numbers in execution order."""
        return self._column("seq")

    def lines(self) -> npt.NDArray[np.int64]:
        """Source lines in execution order."""
        return self._column("line")

    def positions(self) -> npt.NDArray[np.float64]:
        """End positions, shape (n, n_axes), mm and deg."""
        return self._column("position")

    def times_s(self) -> npt.NDArray[np.float64]:
        """Completion times, s."""
        return self._column("time_s")

    def __getitem__(self, i: int) -> JournalEntry:
        self._flush()
        if i < 0:
            i += self._count
        if not 0 <= i < self._count:
            raise IndexError(f"journal index {i} out of range for {self._count} entries")
        for c in self._chunks:
            n = int(c["seq"].shape[0])
            if i < n:
                texts = c["text"]
                text, n_word = (texts[0][i], texts[1][i]) if texts is not None else ("", None)
                return JournalEntry(
                    seq=int(c["seq"][i]),
                    line=int(c["line"][i]),
                    n_word=n_word,
                    text=text,
                    position=tuple(float(v) for v in c["position"][i]),
                    time_s=float(c["time_s"][i]),
                )
            i -= n
        raise AssertionError("unreachable")

    def entries(self) -> list[JournalEntry]:
        """Every record as a :class:`JournalEntry` (small journals; use arrays for big ones)."""
        return [self[i] for i in range(self._count)]

    def duplicates(self) -> dict[int, int]:
        """Sequence numbers journaled more than once, with their counts (empty is good)."""
        counts = Counter(self.seqs().tolist())
        return {s: n for s, n in counts.items() if n > 1}
