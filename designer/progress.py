"""A one-line progress bar for long runs (on stderr, so --json output stays clean)."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TextIO

#: A bar appears only once a task has run this long [s]: short runs stay quiet.
SHOW_AFTER = 0.5
REDRAW_EVERY = 0.1
WIDTH = 30


@dataclass(frozen=True)
class Progress:
    """Where progress bars go: ``stream`` (None = nowhere); ``show_after`` [s]."""

    stream: TextIO | None = None
    show_after: float = SHOW_AFTER

    def bar(self, total: int, label: str) -> Bar:
        return Bar(self, total, label)


class Bar:
    """``label [#####.....] done/total  elapsed s``, redrawn in place; use as a context
    manager, ``update(n)`` as work completes."""

    def __init__(self, progress: Progress | None, total: int, label: str):
        self.stream = progress.stream if progress is not None else None
        self.show_after = progress.show_after if progress is not None else SHOW_AFTER
        self.total, self.label, self.done = max(total, 1), label, 0
        self.start = self.last = time.perf_counter()
        self.drawn = False

    def __enter__(self) -> Bar:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def update(self, n: int = 1) -> None:
        self.done += n
        now = time.perf_counter()
        if (
            self.stream is not None
            and now - self.start >= self.show_after
            and (now - self.last >= REDRAW_EVERY or self.done >= self.total)
        ):
            self._draw(now)

    def _draw(self, now: float) -> None:
        filled = int(WIDTH * min(self.done / self.total, 1.0))
        self.stream.write(
            f"\r{self.label} [{'#' * filled}{'.' * (WIDTH - filled)}] "
            f"{self.done}/{self.total}  {now - self.start:.1f} s"
        )
        self.stream.flush()
        self.last, self.drawn = now, True

    def close(self) -> None:
        if self.drawn:
            self._draw(time.perf_counter())
            self.stream.write("\n")
            self.stream.flush()
