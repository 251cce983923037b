"""Per-pass timing with the clock that tells the truth on this renderer.

GPU timer queries read wrong values on Mesa llvmpipe (work of many milliseconds reads as a few
microseconds, or as a wrapped-around counter), so there the clock is the CPU's, around
``ctx.finish()``: ``cpu-finish``. On
real GPUs the passes are timed with GL_TIME_ELAPSED queries: ``gpu-query``. Stats files record
which clock was used (docs/reference.md, section 4).

``cpu-thread`` is for llvmpipe on a shared machine. With ``LP_NUM_THREADS=0`` llvmpipe
rasterises in the thread that calls GL, so the CPU time of that thread around ``ctx.finish()``
holds the frame's whole work, and other processes' load does not move it (a wall clock moves
by tens of percent there). It times one core's work: compare methods by it, not with a user's
multi-threaded frame rate. The command line sets ``LP_NUM_THREADS=0`` for it (game/cli).
"""

from __future__ import annotations

import os
import time
from contextlib import contextmanager

from game.errors import GameError
from game.gpu.context import is_software
from game.gpu.queries import GLQuery

CLOCKS = ("auto", "cpu-finish", "cpu-thread", "gpu-query")
THREAD_CLOCK = "cpu-thread"


class PassTimer:
    """Times named passes of one frame in milliseconds."""

    def __init__(self, ctx, clock: str = "auto"):
        if clock not in CLOCKS:
            raise ValueError(f"unknown clock {clock!r}; valid: {', '.join(CLOCKS)}")
        if clock == "auto":
            clock = "cpu-finish" if is_software(ctx) else "gpu-query"
        if clock == THREAD_CLOCK and not thread_clock_holds(ctx):
            raise GameError("--clock cpu-thread needs Mesa llvmpipe rasterising in the calling "
                            "thread (LP_NUM_THREADS=0 before the GL starts)")
        self._now = time.thread_time if clock == THREAD_CLOCK else time.perf_counter
        self.ctx = ctx
        self.clock = clock
        self.ms: dict[str, float] = {}
        self._queries: dict[str, GLQuery] = {}

    def begin_frame(self) -> None:
        self.ms = {}

    @contextmanager
    def measure(self, name: str, wall: bool = False):
        """Time the GL work issued inside the block and add it to ``name``.

        ``wall`` times with the CPU around ``ctx.finish()`` whatever the clock: for the frame's
        total, which holds the other passes (GL timer queries cannot nest) and the CPU work of
        planning, as a user waiting for the frame sees it.
        """
        if self.clock == "gpu-query" and not wall:
            query = self._queries.get(name)
            if query is None:
                query = self._queries[name] = GLQuery.time_elapsed()
            with query.measuring():
                yield
            self.ms[name] = self.ms.get(name, 0.0) + query.result / 1e6
            return
        self.ctx.finish()
        start = self._now()
        yield
        self.ctx.finish()
        self.ms[name] = self.ms.get(name, 0.0) + (self._now() - start) * 1e3

    def gl_objects(self) -> int:
        """The timer queries made so far (one per pass name, kept for later frames)."""
        return len(self._queries)

    def release(self) -> None:
        for query in self._queries.values():
            query.release()
        self._queries = {}


def thread_clock_holds(ctx) -> bool:
    """Whether the calling thread's CPU time holds the GL's work: llvmpipe without threads."""
    return "llvmpipe" in ctx.info["GL_RENDERER"].lower() and \
        os.environ.get("LP_NUM_THREADS") == "0"
