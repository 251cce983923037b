"""Whether the camera pass lays down its depth before it shades (docs/design/shading-variants.md).

The shading pass's fragment shader is dear: it finds and reads a fragment's maps. Drawn in the
scene's own order, a fragment that a nearer one later covers has paid for that work anyway. A
depth-only pass first (no colour, no shader work per fragment) makes the shading pass shade each
pixel once, at the price of running the vertices twice. It pays where the scene's order shades
more fragments than the picture has pixels, and costs where it does not, so the choice is made
from the frame itself: a samples-passed query counts the fragments that pass the depth test in
the first pass that tests depth (the depth pass when there is one, else the shading pass; both
run in the scene's order, so they count the same), and the next draw goes depth first where
that count exceeds the target's pixels. The window's frame reads the count of the frame before,
which is done by then; a draw made again within a frame (the counts of map records, each
light's visibility) waits for the one before it, outside the frame's timings.
"""

from __future__ import annotations

import contextlib
import enum

from game.gpu.queries import GLQuery


class DepthFirst(enum.Enum):
    """When the camera pass draws its depth before it shades."""

    AUTO = "auto"   # where the last frame shaded more fragments than the picture has pixels
    ON = "on"
    OFF = "off"


class DepthFirstChoice:
    """Chooses, frame by frame, whether to go depth first. Owns its samples-passed query."""

    def __init__(self, mode: DepthFirst = DepthFirst.AUTO):
        self.mode = mode
        self._query: GLQuery | None = None
        self._pending = False          # a count waits in the query, of a draw of ``_pixels``
        self._pixels = 0
        self.fragments_per_pixel: float | None = None  # the last count read, over the pixels
        self.on = False                # the last lit draw's choice

    def choose(self) -> bool:
        """Whether the coming draw goes depth first: reads the count of the draw before."""
        if self._pending:
            self.fragments_per_pixel = self._query.result / max(self._pixels, 1)
            self._pending = False
        if self.mode is DepthFirst.AUTO:
            self.on = self.fragments_per_pixel is not None and self.fragments_per_pixel > 1.0
        else:
            self.on = self.mode is DepthFirst.ON
        return self.on

    @contextlib.contextmanager
    def counting(self, pixels: int):
        """Counts the fragments that pass the depth test in the draws inside, for ``pixels``."""
        if self.mode is not DepthFirst.AUTO:
            yield
            return
        if self._query is None:
            self._query = GLQuery.samples_passed()
        with self._query.measuring():
            yield
        self._pending, self._pixels = True, pixels

    def gl_objects(self) -> int:
        return int(self._query is not None)

    def release(self) -> None:
        if self._query is not None:
            self._query.release()
            self._query = None
        self._pending = False
