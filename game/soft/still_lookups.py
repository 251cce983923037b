"""What a still view keeps of the window's per-pixel soft lookups (game/soft/direct.py).

While the view stays, the pixels of a block that looks the linear light up get the same
visibility frame after frame, unless a walker changed it: by crossing the light triangle of one
of them (its shadow moved) or by stepping in front of one (the surface changed). The composite
keeps the visibility it looks up at each pixel (an image store, shaders/composite.frag). A block
that looked up since the view became still, and that no walker can have changed since, is
:data:`~game.soft.block_values.CACHED`: the shading pass reads its pixels' kept visibility back
(shaders/soft_blocks.glsl), and the composite does not draw it.

A block counts as changed in a frame where

- a moved walker's box, seen from the camera, covers it (grown by a block); or
- the light triangle of a point within :data:`REACH` blocks of it may cross a moved walker's box
  (shaders/soft_moved.frag): a pixel of the block may lie on another surface than its own
  point, so its neighbours' points speak for it too.

Everything starts again when the view, the frame's size or the method's settings change.

**Refining.** segment-maps' K points sit at the centres of the segment's K parts, the same for
every pixel, so its penumbrae show K steps however long the view stays. In the frames that follow
a view's first (:meth:`StillLookups.refine_round`), a still view draws K maps from other points
of the same parts (at the phase :func:`refine_phase` gives), and every block it kept adds their
lookup at each of its pixels to the pixel's kept mean; a block that interpolated its points
starts its own mean with them and is kept from then on. After :data:`REFINE_POINTS` points in
all, the view stops refining: the mean over that many points stands for the whole segment as
closely as the maps' texels allow. A block a walker changes later looks the light up again from
the K points alone, until the view changes.

**Settling.** After refining, a still view writes the exact visibility of its pixels over what
it kept, a batch at a time (game/soft/settle.py, :meth:`StillLookups.write_pixels`).
"""

from __future__ import annotations

import moderngl
import numpy as np

from game.gpu import blocks, resources
from game.gpu.fullscreen import fullscreen_pass
from game.soft.accumulate import MAX_BOXES, write_boxes
from game.soft.map_frusta import box_corners
from game.soft.upsample import window_extremes

REACH = 2   # blocks around a block whose points' light triangles speak for its pixels
# The points of the segment a still view's refined pixels hold in all, the K the frame's own
# maps hold included.
REFINE_POINTS = 32
GOLDEN = (5 ** 0.5 - 1) / 2   # each refining round's phase turns by this share of a part
HISTORY_UNIT = blocks.TEXTURE_UNITS["soft_history"]
HISTORY_IMAGE = 1   # the composite keeps the looked-up visibility on this image unit
SETS_IMAGE = 2      # ... and how many sets of maps each kept pixel's mean holds on this one


def refine_phase(round_: int) -> float:
    """Where in each part of the segment round ``round_``'s points lie (round 0, the frame's own
    maps: the centre); successive rounds spread over the part (the golden ratio's sequence)."""
    return (0.5 + round_ * GOLDEN) % 1.0


def refine_rounds(maps: int) -> int:
    """The sets of ``maps`` points (the frame's own and the refining rounds') that hold
    :data:`REFINE_POINTS` points."""
    return -(-REFINE_POINTS // max(maps, 1))


def _grown(marked: np.ndarray, reach: int) -> np.ndarray:
    """``marked`` grown by ``reach`` blocks on every side (a square neighbourhood)."""
    return window_extremes(marked.astype(np.float32), reach, reach)[1] > 0.0


def seen_boxes(boxes: np.ndarray, view_proj: np.ndarray, size: tuple[int, int], divisor: int,
               cells: tuple[int, int]) -> np.ndarray:
    """The blocks (GL rows) that ``boxes`` (k, 2, 3 of centre and half size) cover seen through
    ``view_proj`` on a frame of ``size``, grown by a block; every block where a box reaches
    behind the camera."""
    w, h = cells
    out = np.zeros((h, w), bool)
    for centre, half in boxes:
        corners = np.concatenate([box_corners(centre - half, centre + half), np.ones((8, 1))],
                                 axis=1)
        clip = corners @ np.asarray(view_proj, np.float64).T
        if np.any(clip[:, 3] <= 1e-6):
            out[:] = True
            return out
        pixels = (clip[:, :2] / clip[:, 3:] * 0.5 + 0.5) * np.asarray(size)
        lo = np.floor(pixels.min(axis=0) / divisor).astype(int) - 1
        hi = np.ceil(pixels.max(axis=0) / divisor).astype(int) + 1
        out[max(lo[1], 0):max(hi[1], 0), max(lo[0], 0):max(hi[0], 0)] = True
    return out


class StillLookups:
    """Owns the kept visibility (one texel per pixel), the moved points' target (one per
    block) and its program, released by :meth:`release`; the targets are made again when the
    frame's size changes."""

    def __init__(self, ctx):
        self.ctx = ctx
        self._program, self._vao = fullscreen_pass(ctx, "soft_moved.frag",
                                                   {"MAX_BOXES": MAX_BOXES})
        self.size = self.cells = None
        self._targets: list = []
        self._key: bytes | None = None
        self.valid: np.ndarray | None = None   # blocks whose kept visibility holds
        self.changed: np.ndarray | None = None  # blocks a walker may have changed this frame
        self.seen: np.ndarray | None = None     # ... of them, those it covers on screen
        self.frames = 0   # frames of this view before the present one

    def _resize(self, size: tuple[int, int], cells: tuple[int, int]) -> None:
        if (size, cells) == (self.size, self.cells) and self._targets:
            return
        self._release_targets()
        self.size, self.cells = size, cells
        ctx = self.ctx
        self.history = ctx.texture(size, 1, dtype="f4")   # each pixel's kept mean
        self.history_framebuffer = ctx.framebuffer([self.history])   # to read rows of it
        self.sets = ctx.texture(size, 1, dtype="f4")      # the sets of maps the mean holds
        self.moved = ctx.texture(cells, 4)
        self.moved_framebuffer = ctx.framebuffer([self.moved])
        self._targets = [self.moved_framebuffer, self.moved, self.history_framebuffer,
                         self.history, self.sets]
        self._key = None

    def kept(self, key: bytes | None, size: tuple[int, int], divisor: int, points,
             boxes: np.ndarray, light: tuple, view_proj: np.ndarray) -> np.ndarray:
        """The blocks (GL rows) whose pixels may read their kept visibility this frame. ``key``
        names the view and the settings (None: keep nothing); ``points`` is the points'
        G-buffer target; ``boxes`` the walkers' moved boxes (game/soft/accumulate.py's
        ``walker_boxes``); ``light`` the segment's (mode, a, b)."""
        cells = points.size
        self._resize(size, cells)
        if key is None or key != self._key or len(boxes) > MAX_BOXES:
            self._key = key
            self.valid = np.zeros((cells[1], cells[0]), bool)
            self.changed = np.zeros_like(self.valid)
            self.seen = np.zeros_like(self.valid)
            self.frames = 0
            return self.valid
        self.frames += 1
        self.changed = np.zeros_like(self.valid)
        self.seen = np.zeros_like(self.valid)
        if len(boxes):
            self.seen = seen_boxes(boxes, view_proj, size, divisor, cells)
            self.changed = _grown(self._moved_points(points, boxes, light), REACH) | self.seen
            self.valid &= ~self.changed
        return self.valid

    @property
    def keeps_view(self) -> bool:
        """Whether the present frame's view keeps anything (a caller named it)."""
        return self._key is not None

    def read_kept(self) -> np.ndarray:
        """What the view keeps at each pixel, (H, W) in GL rows: meaningful only in the blocks
        it kept or looked up."""
        w, h = self.size
        return np.frombuffer(self.history.read(), np.float32).reshape(h, w).copy()

    def write_pixels(self, pixels: np.ndarray, visibility: np.ndarray) -> None:
        """Keep ``visibility`` at the flat ``pixels`` (GL rows) from here: the rows they span
        are read, changed there and written back."""
        w = self.size[0]
        rows = pixels // w
        y0, y1 = int(rows.min()), int(rows.max()) + 1
        viewport = (0, y0, w, y1 - y0)
        band = np.frombuffer(self.history_framebuffer.read(viewport, components=1, dtype="f4"),
                             np.float32).copy()
        band[pixels - y0 * w] = visibility
        self.history.write(band.tobytes(), viewport=viewport)

    def _moved_points(self, points, boxes: np.ndarray, light: tuple) -> np.ndarray:
        """The points (GL rows) whose light triangle a moved box may cross."""
        prog = self._program
        for unit, (name, tex) in enumerate((("u_position", points.position),
                                            ("u_colour", points.colour))):
            tex.use(unit)
            prog[name].value = unit
        prog["u_light_a"].value = tuple(float(x) for x in light[1])
        prog["u_light_b"].value = tuple(float(x) for x in light[2])
        write_boxes(prog, boxes)
        fb = self.moved_framebuffer
        fb.use()
        fb.viewport = (0, 0, *self.cells)
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)
        self._vao.render(moderngl.TRIANGLES, vertices=3)
        w, h = self.cells
        return np.frombuffer(fb.read(components=1), np.uint8).reshape(h, w) > 0

    def refine_round(self, maps: int) -> int:
        """The refining round of this frame for a method of ``maps`` points (K), 0 where it
        refines nothing: the view's first frame, and every frame once its kept pixels hold
        :data:`REFINE_POINTS` points."""
        rounds = refine_rounds(maps)
        return self.frames if self._key is not None and 0 < self.frames < rounds else 0

    def sets_held(self, maps: int) -> int:
        """The sets of K maps the view's refined pixels hold after this frame (1: the frame's
        own alone)."""
        held = self.frames + 1 if self._key is not None else 1
        return min(held, refine_rounds(maps))

    def forget(self) -> None:
        """Keep nothing: the scene changed, or frames went by without these lookups."""
        self._key = None

    def drawn(self, looked_up: np.ndarray) -> None:
        """The composite looked up (and kept) every pixel of the blocks ``looked_up``."""
        if self.valid is not None:
            self.valid |= looked_up

    def bind_images(self, program, refine: bool) -> None:
        """Bind the kept means and their sets as ``program``'s images (read too, to
        ``refine``)."""
        for tex, unit, name in ((self.history, HISTORY_IMAGE, "u_soft_kept"),
                                (self.sets, SETS_IMAGE, "u_soft_sets")):
            tex.bind_to_image(unit, read=refine, write=True)
            program[name].value = unit

    def gl_objects(self) -> int:
        return 2 + resources.attached_shaders([self._program]) + len(self._targets)

    def _release_targets(self) -> None:
        resources.release_targets(self.ctx, self._targets)
        self._targets = []
        self.size = self.cells = None
        self.valid = None

    def release(self) -> None:
        self._release_targets()
        for obj in (self._vao, self._program):
            if obj is not None:
                obj.release()
        self._vao = self._program = None
