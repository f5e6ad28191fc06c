"""A one-line progress bar on stderr for long commands (no dependency)."""

from __future__ import annotations

import sys
import time
from typing import TextIO

__all__ = ["ProgressBar"]


class ProgressBar:
    """Callable as ``bar(done, total)``; redraws ``label [####....]  45%  done/total`` in place.

    Redraws at most every ``interval_s`` seconds and when ``done == total``; does nothing when
    disabled. Call :meth:`close` to end the line.
    """

    def __init__(self, label: str, enabled: bool, stream: TextIO | None = None, interval_s: float = 0.2) -> None:
        self.label = label
        self.enabled = enabled
        self.stream = sys.stderr if stream is None else stream
        self.interval_s = interval_s
        self._last_s = 0.0
        self._drawn = False

    def __call__(self, done: int, total: int) -> None:
        now = time.monotonic()
        if not self.enabled or (done < total and now - self._last_s < self.interval_s):
            return
        self._last_s = now
        fraction = done / total if total else 1.0
        filled = int(30 * fraction)
        self.stream.write(f"\r{self.label:<9} [{'#' * filled}{'.' * (30 - filled)}] {fraction:4.0%}  {done}/{total}")
        self.stream.flush()
        self._drawn = True

    def close(self) -> None:
        """End the bar's line (if anything was drawn)."""
        if self._drawn:
            self.stream.write("\n")
            self.stream.flush()
            self._drawn = False
