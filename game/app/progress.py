"""Progress of a long headless run (``trace``, ``capture``) on standard error.

One line, redrawn in place: the frame, how much of it is done, the time so far. It appears only
on a terminal (scripts read standard output, and logs and tests want standard error quiet), only
once the run has taken :data:`SHOW_AFTER_S`, and is redrawn at most every :data:`REDRAW_S`.
Within a frame the share done comes from the traced lighting, which traces in bands of rows
when a trace is long (game/render/traced_lighting.py).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO

SHOW_AFTER_S = 2.0     # a run shorter than this shows nothing
REDRAW_S = 0.25        # the line is redrawn at most this often
CLEAR_TO_END = "\x1b[K"  # ANSI: erase the rest of the line


class Progress:
    """``label: frame k/n  p%  t s`` on ``stream`` (standard error), redrawn in place.

    Call :meth:`frame` as each frame starts, :meth:`part` with the share of the frame done, and
    :meth:`close` at the end (it finishes the line, if one was shown). Where standard error is
    not a terminal it writes nothing (:attr:`enabled` is False)."""

    def __init__(self, label: str, frames: int, stream: TextIO | None = None,
                 clock: Callable[[], float] = time.monotonic):
        self.label = label
        self.frames = frames
        self.stream = stream if stream is not None else sys.stderr
        self.clock = clock
        isatty = getattr(self.stream, "isatty", None)
        self.enabled = bool(isatty and isatty())
        self.start = clock()
        self.index = -1          # the frame under way
        self.share = 0.0         # of it, done
        self.shown = False
        self._last_draw = -REDRAW_S

    def frame(self) -> None:
        """The next frame starts."""
        self.index += 1
        self.share = 0.0
        self._draw()

    def part(self, share: float) -> None:
        """This share (0 to 1) of the frame under way is done."""
        self.share = min(max(share, 0.0), 1.0)
        self._draw()

    def close(self, done: bool) -> None:
        """Finish the line, if one was shown: at 100% when ``done`` (every frame made), else
        where the run stopped."""
        if done:
            self.index, self.share = self.frames - 1, 1.0
        if self.shown:
            self._draw(force=True)
            self.stream.write("\n")
            self.stream.flush()
            self.shown = False

    def text(self) -> str:
        """The line as it reads now."""
        k = max(self.index, 0)
        done = min(k + (self.share if self.index >= 0 else 0.0), self.frames)
        percent = 100.0 * done / self.frames if self.frames else 100.0
        return (f"{self.label}: frame {min(k + 1, self.frames)}/{self.frames}  "
                f"{percent:3.0f}%  {self.clock() - self.start:.1f} s")

    def _draw(self, force: bool = False) -> None:
        if not self.enabled:
            return
        now = self.clock()
        if not force and (now - self.start < SHOW_AFTER_S or now - self._last_draw < REDRAW_S):
            return
        self._last_draw = now
        self.shown = True
        self.stream.write("\r" + self.text() + CLEAR_TO_END)
        self.stream.flush()
