"""Progress bars for the pipeline's stages on a terminal (tqdm, on stderr)."""

from __future__ import annotations

from tqdm import tqdm

__all__ = ["StageBars"]


class StageBars:
    """``progress(stage, fraction)`` drawing one bar per stage, closed when it completes."""

    def __init__(self, *, disable: bool = False) -> None:
        self._bars: dict[str, tqdm] = {}
        self._disable = disable

    def __call__(self, stage: str, fraction: float) -> None:
        """Advance ``stage``'s bar to ``fraction`` (0 to 1)."""
        bar = self._bars.get(stage)
        if bar is None:
            bar = tqdm(total=100, desc=f"{stage:<6}", unit="%", leave=True, disable=self._disable,
                       bar_format="{desc} {bar} {percentage:3.0f}% {elapsed}")
            self._bars[stage] = bar
        bar.update(max(0, round(100 * fraction) - bar.n))
        if fraction >= 1.0:
            bar.close()

    def close(self) -> None:
        """Close every bar still open (after an error)."""
        for bar in self._bars.values():
            bar.close()
