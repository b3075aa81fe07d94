"""Progress bars for the pipeline's stages on a terminal (tqdm, on stderr)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from tqdm import tqdm

__all__ = ["StageBars"]


class StageBars:
    """``progress(stage, fraction)`` drawing one bar per stage, closed when it completes.

    ``disable`` (``--quiet``): nothing is drawn, and tqdm is not even loaded: its import,
    and the lock and monitor thread its first bar starts, cost ~30 ms of CPU per command.
    """

    def __init__(self, *, disable: bool = False) -> None:
        self._bars: dict[str, tqdm] = {}
        self._disable = disable

    def __call__(self, stage: str, fraction: float) -> None:
        """Advance ``stage``'s bar to ``fraction`` (0 to 1)."""
        if self._disable:
            return
        bar = self._bars.get(stage)
        if bar is None:
            from tqdm import tqdm

            bar = tqdm(total=100, desc=f"{stage:<6}", unit="%", leave=True,
                       bar_format="{desc} {bar} {percentage:3.0f}% {elapsed}")
            self._bars[stage] = bar
        bar.update(max(0, round(100 * fraction) - bar.n))
        if fraction >= 1.0:
            bar.close()

    def close(self) -> None:
        """Close every bar still open (after an error)."""
        for bar in self._bars.values():
            bar.close()
