"""A still view's soft shadows settled to the exact visibility, a batch of pixels at a time.

A raster method's still view (game/soft/still_lookups.py) converges to the method's own limit:
its maps' texels and bias, and the blocks whose points agree although a pixel between them
differs. The ``analytic`` tracer gives each pixel's exact visibility of the segment, at a cost
per pixel that a frame cannot pay for all of them on a CPU rasteriser. So once a still view has
refined what it kept, each frame traces a batch of its pixels exactly and writes them into what
the view keeps, where the shading pass reads them; the picture reaches the exact one when every
pixel is settled.

- **Which pixels, in which order.** Every pixel that shows geometry, by the error it is likely
  to hold (:class:`Tier`): first those the view keeps partly lit (the penumbrae, where the
  maps' steps and texels show), then the rest of the blocks that look the light up or
  interpolate it, then those whose points agreed; within a tier, block by block in rows, so
  that a batch settles whole blocks and its neighbouring pixels trace alike. A block is read
  from what the view keeps once every pixel of it is settled, or earlier where it looked up
  anyway; one the composite looks up again (a thin caster against the sky, until it is
  settled whole) loses what it had settled.
- **Where from.** The scene drawn once more at the frame's size into a full G-buffer, when the
  settling starts: the positions and normals the tracer reads, as a full frame's trace reads
  them. They are kept on the CPU; the G-buffer is released.
- **How many.** As many as :data:`SETTLE_SHARE` of the frame's own time holds (more where
  nothing on screen moves: :data:`STATIC_SHARE`), at the pace of the last batch, a batch every
  :data:`SETTLE_EVERY` frames.
- **Walkers.** A block a walker changes (:meth:`StillLookups.kept`) loses its settled pixels:
  it looks the light up again, and is settled again at the walkers' new poses once a frame
  goes by in which no walker changes it (a walker that walks on would change it again, so
  the batches go to what stays). A block a walker crossed on screen may show another surface
  than the G-buffer did: it waits until nothing else is left, and the G-buffer is drawn
  again.

Everything starts again with the view.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from enum import IntEnum

import numpy as np

# Tracing a frame's batch may take this share of the rest of the frame (wall clock, around the
# trace), so the still window's frame rate drops by about a twentieth while it settles, whatever
# the device: a CPU rasteriser traces the exact visibility at tens of microseconds a pixel, a
# hundred or so pixels a frame at the window's size, and a GPU many times more. The window with
# soft shadows is held to half the frame rate it has without them, and a still view already
# pays most of that, so the settling takes a small share.
SETTLE_SHARE = 0.05
# ... and this share where nothing on screen moved (no walker changed a block): the picture
# does not change, so its frame rate shows nowhere but in how soon the window answers a key.
STATIC_SHARE = 0.5
# A batch runs every this many frames, with their shares together: each batch also pays a cost
# of its own (the walkers binned into the tracer's grid as they stand), which a batch a frame
# paid more for than for its pixels where walkers walk.
SETTLE_EVERY = 4
FIRST_BATCH = 256       # pixels of the first batch, before the pace is known
MAX_BATCH = 1 << 16     # pixels of any batch (a fast GPU's pace would ask for more)

# (positions (P, 3), normals (P, 3)) -> exact visibility (P,)
ExactTrace = Callable[[np.ndarray, np.ndarray], np.ndarray]


class Tier(IntEnum):
    """How soon a pixel is settled: by the error it is likely to hold."""

    PARTLY_LIT = 0   # kept strictly between lit and shadowed: a penumbra
    LOOKED_UP = 1    # in a block that looks the light up or interpolates it
    AGREED = 2       # in a block whose points agreed


def block_pixels(blocks: np.ndarray, divisor: int, size: tuple[int, int]) -> np.ndarray:
    """Per pixel ((H, W) in the rows of ``blocks``), its block's entry of ``blocks``."""
    w, h = size
    return np.repeat(np.repeat(blocks, divisor, axis=0), divisor, axis=1)[:h, :w]


class StillSettle:
    """What a still view has settled: per pixel (GL rows), whether what it keeps is the exact
    visibility; and the queue of the pixels that show geometry, with their positions and
    normals. No GL objects: the caller draws the G-buffer and owns the texture the results go
    into."""

    def __init__(self, divisor: int):
        self.divisor = divisor
        self.size: tuple[int, int] | None = None
        self.settled: np.ndarray | None = None   # (H, W): what the view keeps here is exact
        self._queue = self._block = None         # flat pixels in settling order; their blocks
        self._points = self._normals = None      # (P, 3) each, in the queue's order
        self._cursor = 0                         # no pixel before it in the queue waits
        self._total = self._done = None          # per block: pixels in the queue, settled
        self.pace_ms: float | None = None        # ms a pixel, by the last batch
        self._saved = 0                          # frames since the last batch

    @property
    def started(self) -> bool:
        return self.settled is not None

    @property
    def queue(self) -> np.ndarray | None:
        """The flat pixels (GL rows) that show geometry, in the order they are settled."""
        return self._queue

    def reset(self) -> None:
        """Nothing settled: a new view, size or setting."""
        self.size = self.settled = self._queue = self._block = None
        self._points = self._normals = self._total = self._done = None
        self._cursor = self._saved = 0

    def start(self, position: np.ndarray, normal: np.ndarray, covered: np.ndarray,
              tiers: np.ndarray, keep: np.ndarray | None = None) -> None:
        """Settle the view whose G-buffer gives ``position`` and ``normal`` (H, W, 3) where
        ``covered`` (H, W), each pixel in its :class:`Tier` (``tiers``, (H, W)); all in GL
        rows. ``keep``: the blocks whose settled pixels stay settled (the G-buffer drawn
        again, where it shows what it showed), else none."""
        h, w = covered.shape
        self.size = (w, h)
        kept = np.zeros((h, w), bool)
        if keep is not None and self.settled is not None:
            kept = self.settled & covered & block_pixels(keep, self.divisor, self.size)
        self.settled = kept
        flat = np.flatnonzero(covered)
        cells_w = -(-w // self.divisor)
        rows, cols = np.divmod(flat, w)
        block = (rows // self.divisor) * cells_w + cols // self.divisor
        order = np.lexsort((flat, block, tiers.reshape(-1)[flat]))
        self._queue, self._block = flat[order], block[order]
        cells = cells_w * -(-h // self.divisor)
        self._total = np.bincount(self._block, minlength=cells)
        self._done = np.bincount(self._block, weights=kept.reshape(-1)[self._queue],
                                 minlength=cells).astype(np.int64)
        self._points = np.ascontiguousarray(position.reshape(-1, 3)[self._queue], np.float32)
        self._normals = np.ascontiguousarray(normal.reshape(-1, 3)[self._queue], np.float32)
        self._cursor = 0

    def forget_changed(self, kept: np.ndarray) -> None:
        """Drop the settled pixels of the blocks not ``kept`` (GL rows): a walker changed
        them, or they were never kept."""
        if not self.started or kept.all():
            return
        lost = ~kept.reshape(-1) & (self._done > 0)
        if lost.any():
            self.settled &= ~block_pixels(lost.reshape(kept.shape), self.divisor, self.size)
            self._done[lost] = 0
            self._cursor = 0

    def forget_drawn(self, drawn: np.ndarray) -> None:
        """Drop the settled pixels of the blocks ``drawn`` (GL rows): the composite looked
        them up and kept that over what was settled."""
        if self.started and drawn.any():
            self.forget_changed(~drawn)

    def next_batch(self, kept: np.ndarray, frame_ms: float, static: bool = False
                   ) -> np.ndarray | None:
        """Positions in the queue of the pixels to settle this frame: unsettled ones of
        ``kept`` blocks (GL rows), in the queue's order, as many as :data:`SETTLE_SHARE` of
        ``frame_ms`` (the rest of the frame) holds over the frames since the last batch
        (:data:`STATIC_SHARE` where nothing on screen moved, ``static``); None in the frames
        between batches (:data:`SETTLE_EVERY`)."""
        self._saved += 1
        if self.pace_ms is not None and self._saved < SETTLE_EVERY:
            return None
        budget = (STATIC_SHARE if static else SETTLE_SHARE) * frame_ms * self._saved
        self._saved = 0
        count = (FIRST_BATCH if self.pace_ms is None
                 else int(np.clip(budget / max(self.pace_ms, 1e-6), 1, MAX_BATCH)))
        at = self._cursor
        waiting = ~self.settled.reshape(-1)[self._queue[at:]]
        if not waiting.any():
            self._cursor = len(self._queue)
            return np.zeros(0, np.int64)
        self._cursor = at + int(np.argmax(waiting))   # past the settled head of the queue
        ready = waiting & kept.reshape(-1)[self._block[at:]]
        return at + np.flatnonzero(ready)[:count]

    def settle(self, batch: np.ndarray, trace: ExactTrace) -> tuple[np.ndarray, np.ndarray]:
        """The flat pixels (GL rows) of ``batch`` (:meth:`next_batch`) and their exact
        visibility, traced by ``trace``; they count as settled from here."""
        start = time.perf_counter()
        visibility = np.asarray(trace(self._points[batch], self._normals[batch]), np.float32)
        if len(batch):
            self.pace_ms = (time.perf_counter() - start) * 1e3 / len(batch)
        pixels = self._queue[batch]
        self.settled.reshape(-1)[pixels] = True
        self._done += np.bincount(self._block[batch], minlength=len(self._done))
        return pixels, visibility

    def waiting_blocks(self, cells: tuple[int, int]) -> np.ndarray:
        """Per block (GL rows), whether it shows geometry and some pixel of it that does is
        not settled."""
        w, h = cells
        if not self.started:
            return np.zeros((h, w), bool)
        return ((self._total > 0) & (self._done < self._total)).reshape(h, w)

    def settled_blocks(self, cells: tuple[int, int]) -> np.ndarray:
        """Per block (GL rows), whether it shows geometry and every pixel of it that does is
        settled."""
        w, h = cells
        if not self.started:
            return np.zeros((h, w), bool)
        return ((self._total > 0) & (self._done >= self._total)).reshape(h, w)

    @property
    def share(self) -> float:
        """The share of the pixels that show geometry settled (0 before it starts)."""
        if not self.started or not len(self._queue):
            return 0.0
        return float(self._done.sum() / len(self._queue))
