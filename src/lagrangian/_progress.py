"""A small terminal progress bar on stderr.

Shown only when stderr is a terminal and the work has taken more than `delay` seconds (1 s by
default); otherwise nothing is printed. No dependency::

    from lagrangian._progress import progress

    with progress(total, "simulating") as bar:
        for chunk in chunks:
            ...
            bar.update(len(chunk))      # add to the count
    # bar.set(k) sets the count instead of adding to it

Work of unknown length before the count starts (compiling the integrators on a machine's first
run) is said instead of the bar: ``bar.wait("compiling the integrators, once per machine")``
shows that text and the seconds spent, until the count first moves.
"""

from __future__ import annotations

import os
import shutil
import sys
import time
from typing import TextIO

__all__ = ["progress", "Progress"]


class Progress:
    """The state of one progress bar (use :func:`progress`)."""

    def __init__(self, total: int, label: str = "", *, stream: TextIO | None = None, delay: float = 1.0,
                 enabled: bool | None = None, interval: float = 0.1):
        self.total = max(0, int(total))
        self.label = label
        self.count = 0
        self.stream = sys.stderr if stream is None else stream
        if enabled is None:
            enabled = _is_terminal(self.stream) and os.environ.get("TERM") != "dumb"
        self.enabled = bool(enabled)
        self.delay = delay
        self.interval = interval
        self.start = time.monotonic()
        self._last = 0.0
        self._shown = False
        self.waiting: str | None = None

    def wait(self, text: str) -> None:
        """Say `text` (what is being done, with the seconds spent) instead of the bar, until the count
        first moves: work of unknown length before the counted work starts."""
        self.waiting = text

    def update(self, k: int = 1) -> None:
        """Add `k` to the count."""
        self.set(self.count + k)

    def set(self, count: int) -> None:
        """Set the count."""
        count = min(max(0, int(count)), self.total) if self.total else int(count)
        if count != self.count:
            self.waiting = None  # the counted work has begun
        self.count = count
        if not self.enabled:
            return
        now = time.monotonic()
        if now - self.start < self.delay or (now - self._last < self.interval and self.count < self.total):
            return
        self._last = now
        self._draw(now)

    def _draw(self, now: float) -> None:
        elapsed = now - self.start
        width = shutil.get_terminal_size((80, 20)).columns
        if self.waiting is not None:
            line = f"{self.waiting}... {elapsed:.0f} s"
            self.stream.write(("\r" + line.ljust(width - 1))[: width + 1])
            self.stream.flush()
            self._shown = True
            return
        frac = self.count / self.total if self.total else 0.0
        if 0 < frac < 1:
            eta = f"{elapsed * (1 - frac) / frac:5.0f} s left"
        else:
            eta = f"{elapsed:5.1f} s"
        head = f"{self.label} " if self.label else ""
        tail = f" {self.count}/{self.total} {eta}"
        bar_width = max(10, width - len(head) - len(tail) - 4)
        filled = int(round(bar_width * frac))
        line = f"\r{head}[{'#' * filled}{'.' * (bar_width - filled)}]{tail}"
        self.stream.write(line[: width + 1])
        self.stream.flush()
        self._shown = True

    def close(self) -> None:
        """Finish the line (only if the bar was shown)."""
        if self._shown:
            self._draw(time.monotonic())
            self.stream.write("\n")
            self.stream.flush()
            self._shown = False

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _is_terminal(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


def progress(total: int, label: str = "", *, stream: TextIO | None = None, delay: float = 1.0,
             enabled: bool | None = None) -> Progress:
    """A progress bar for `total` items, labelled `label`, on `stream` (default stderr).

    Parameters
    ----------
    total : int
        The count at completion.
    label : str
        Printed before the bar ("simulating").
    stream : file, optional
        Where to draw (default sys.stderr).
    delay : float
        Seconds before the bar appears: quick work prints nothing.
    enabled : bool, optional
        Force the bar on or off; by default it is on only when `stream` is a terminal.

    Returns
    -------
    Progress
        A context manager with ``update(k)`` (add k) and ``set(count)``.
    """
    return Progress(total, label, stream=stream, delay=delay, enabled=enabled)
