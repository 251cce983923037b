"""A raster soft method in the window: the linear light added in the shading pass itself, and
looked up at each pixel only where the shadow changes within a few blocks.

A raster method (segment-maps, pcss) gives the same visibility every frame for the same view,
so the window neither accumulates nor filters it. Per frame, before the shading pass:

1. **Points**: the scene drawn unlit into a G-buffer of one pixel per block of ``divisor`` x
   ``divisor`` (the renderer draws it; the clip space spans the frame, so each point lies at
   its block's centre). The points stay put while the view does, and so do the maps' frusta
   planned around them (the statics' maps stay cached).
2. **The method** (game/soft/raster.py) plans its maps around the points, draws what changed
   and looks the visibility up at the points (a small pass, read back).
3. **Values** (game/soft/block_values.py): each block's visibility, agreed by its
   neighbourhood of points, interpolated between them, or looked up at each pixel.

Then the shading pass (shaders/shade.frag, the lean G-buffer) lights every pixel by the linear
light through its block's value, except where the block looks it up, and marks the blocks
whose point lies in the sky but some pixels do not (a thin caster against the sky, an image
store): they look it up too. The composite (game/soft/composite.py, ``draw_runs``) copies the
picture and adds the light over runs of the blocks that look it up, with the method's lookup at
each pixel. While the view stays, a block keeps what it looked up until a walker may have
changed it, and refines what it kept with maps from other points of the segment
(game/soft/still_lookups.py). So soft shadows cost a few texture reads a pixel in the
shading pass, a lean G-buffer of 8-bit targets, and the lookup only where the shadow changes.

A shadow narrower than the points' spacing that falls wholly between them is missed where the
blocks around agree; the soft shadows of a linear light are wide.
"""

from __future__ import annotations

import numpy as np

from game.gpu import blocks
from game.soft.block_values import (
    CACHED,
    INTERPOLATE,
    LOOKUP,
    REFINE_ADD,
    REFINE_START,
    SKIP,
    SKY,
    Runs,
    block_runs,
    block_values,
)
from game.soft.composite import LOOKUPS, SoftComposite
from game.soft.methods import TraceSettings
from game.soft.settle import ExactTrace, StillSettle, Tier, block_pixels
from game.soft.still_lookups import HISTORY_UNIT, StillLookups, refine_rounds
from game.soft.tracer import TraceResult
from game.soft.upsample import ReducedState, trace_size

BLOCKS_UNIT = blocks.TEXTURE_UNITS["soft_blocks"]
POINTS_UNIT = blocks.TEXTURE_UNITS["soft_points"]
MARKS_IMAGE = 0   # the image unit the shading pass marks the blocks on
# A kept visibility further than this from 0 and 1 is in a penumbra: settled first.
PARTLY_LIT = 0.01
# Still frames between two draws of the settling's G-buffer, where walkers crossed the screen.
REFRESH_FRAMES = 16


class DirectRaster:
    """Owns the blocks' values, the points' visibility and the blocks the shading pass marks
    (one texel per block), made again when the frame's size changes, and what a still view
    keeps (:attr:`still`); released by :meth:`release`."""

    def __init__(self, ctx, divisor: int):
        self.ctx = ctx
        self.divisor = divisor
        self.still = StillLookups(ctx)
        self.settle = StillSettle(divisor)
        # Blocks whose surfaces the settling's G-buffer still shows (no walker crossed them on
        # screen since it was drawn); the still frame it was drawn in; whether the last batch
        # found nothing to settle.
        self._surfaces: np.ndarray | None = None
        self._drawn_at, self._dry = 0, False
        self.size = self.cells = None
        self._textures: list = []
        self._values = self._in_sky = None   # this frame's values and its points in the sky
        self.state: ReducedState | None = None
        self.runs: Runs | None = None

    def resize(self, size: tuple[int, int]) -> tuple[int, int]:
        """Hold blocks for frames of ``size``; returns the points' size, one per block."""
        cells = trace_size(size, self.divisor)
        if size == self.size and self._textures:
            return cells
        self._release_textures()
        self.size, self.cells = size, cells
        ctx = self.ctx
        self.values = ctx.texture(cells, 1, dtype="f4")
        self.points_visibility = ctx.texture(cells, 1, dtype="f4")
        self.points_visibility.repeat_x = self.points_visibility.repeat_y = False
        self.marks = ctx.texture(cells, 1)
        self._textures = [self.values, self.points_visibility, self.marks]
        return cells

    @property
    def covers(self) -> tuple[float, float]:
        """The points' pixels the frame's clip space spans: each point at its block's centre."""
        return (self.size[0] / self.divisor, self.size[1] / self.divisor)

    @property
    def point_at(self) -> tuple[float, float]:
        """The block's side, and where its point lies from its corner (pixel centres)."""
        return (float(self.divisor), self.divisor / 2 - 0.5)

    def classify(self, result: TraceResult, kept: np.ndarray, settings: TraceSettings) -> None:
        """The blocks' values of this frame, from the points' traced ``result``, for the
        shading pass: a block whose point is in the sky gains nothing there, and is marked
        where its pixels show geometry; one that looks up or interpolates reads what a still
        view ``kept`` (GL rows, :meth:`StillLookups.kept`) where that holds. The state's
        rounds are the sets of K maps the refined pixels hold (``settings``' method's)."""
        vis = np.ascontiguousarray(result.visibility[::-1])   # GL rows
        self._in_sky = np.isnan(vis)
        self._values = block_values(vis, np.zeros_like(self._in_sky))
        self._values[((self._values == LOOKUP) | (self._values == INTERPOLATE)) & kept] = CACHED
        self._forget_unsettled()
        # A settled block reads what the view keeps, its point in the sky or not: the shading
        # pass then neither marks it nor leaves it to the composite.
        self._values[self.settle.settled_blocks(self.cells) & kept] = CACHED
        sky = self._in_sky & (self._values != CACHED)
        self.values.write(np.where(sky, SKY, self._values).astype(np.float32).tobytes())
        self.points_visibility.write(np.nan_to_num(vis, nan=0.0).tobytes())
        self.marks.write(bytes(self.cells[0] * self.cells[1]))
        refines = settings.method == "segment-maps"
        self.state = ReducedState(
            size=self.cells, divisor=self.divisor, traced=True,
            round=self.still.sets_held(settings.maps) if refines else 1,
            rounds=refine_rounds(settings.maps) if refines else 1, phase=1, phases=1, full=True,
            settled=self.settle.share)

    def finish(self) -> Runs:
        """This frame's runs, once the shading pass marked the blocks whose point is in the sky
        but whose pixels are not all (a thin caster against the sky): they look the light up
        too."""
        self.ctx.memory_barrier()
        w, h = self.cells
        covered = np.frombuffer(self.marks.read(), np.uint8).reshape(h, w) > 0
        values = np.where(self._in_sky & covered & (self._values != CACHED), LOOKUP,
                          self._values).astype(np.float32)
        self._values = values
        self.runs = block_runs(values, self.divisor, self.size)
        looked_up = values == LOOKUP
        self.still.drawn(looked_up)
        self.settle.forget_drawn(looked_up)
        self.runs.points = self.points_visibility
        self.runs.point_at = self.point_at
        self.runs.history = self.still.history
        return self.runs

    def _forget_unsettled(self) -> None:
        """A new view settles nothing yet. A walker unsettles the blocks it changed (their
        visibility), and the blocks it crossed on screen lose the settling's surfaces too,
        until the settling draws its G-buffer again."""
        if self.still.frames == 0 or not self.settle.started:
            self.settle.reset()
            self._surfaces = None
            return
        self._surfaces &= ~self.still.seen
        self.settle.forget_changed(self._surfaces & ~self.still.changed)

    @property
    def settles(self) -> bool:
        """Whether this frame settles pixels to the exact visibility (game/soft/settle.py): a
        still view, once it has refined what it kept (this frame's :attr:`state` says how
        many rounds that takes), until every pixel is settled."""
        if not self.still.keeps_view or self.still.frames < self.state.rounds:
            return False
        return not self.settle.started or self.settle.share < 1.0

    @property
    def wants_gbuffer(self) -> bool:
        """Whether the settling needs the view's G-buffer drawn: to start, or to settle the
        blocks the walkers crossed on screen (once nothing else is left, at most every
        :data:`REFRESH_FRAMES` frames)."""
        return not self.settle.started or (
            self._dry and self.still.frames - self._drawn_at >= REFRESH_FRAMES)

    def start_settling(self, position: np.ndarray, normal: np.ndarray,
                       covered: np.ndarray) -> None:
        """Settle this view from its full G-buffer (GL rows: :meth:`StillSettle.start`): the
        pixels the view keeps partly lit first, then the rest of the blocks that look the
        light up or interpolate it, then the others. Drawn again, the G-buffer keeps what
        was settled where no walker crossed the screen."""
        looked_up = block_pixels(np.isin(self._values, (LOOKUP, INTERPOLATE, CACHED)),
                                 self.divisor, self.size)
        kept = self.still.read_kept()
        partly_lit = looked_up & (kept > PARTLY_LIT) & (kept < 1.0 - PARTLY_LIT)
        tiers = np.where(partly_lit, Tier.PARTLY_LIT,
                         np.where(looked_up, Tier.LOOKED_UP, Tier.AGREED))
        self.settle.start(position, normal, covered, tiers,
                          keep=self._surfaces if self.settle.started else None)
        self._surfaces = np.ones((self.cells[1], self.cells[0]), bool)
        self._drawn_at, self._dry = self.still.frames, False

    def settle_batch(self, trace: ExactTrace, frame_ms: float) -> None:
        """Trace this frame's batch of pixels exactly (its size by ``frame_ms``, the rest of
        the frame: :meth:`StillSettle.next_batch`), and keep what it gives. The blocks a
        walker changed this frame wait: a walker that walks on changes them again in the next,
        and a batch spent on them would settle nothing that stays."""
        changed = self.still.changed
        batch = self.settle.next_batch(self._surfaces & ~changed, frame_ms,
                                       static=not changed.any())
        if batch is None:   # between batches
            return
        # With nothing to settle now, the G-buffer is drawn again only where a block waits
        # that it no longer shows (a walker crossed it on screen).
        self._dry = not len(batch) and bool(
            (self.settle.waiting_blocks(self.cells) & ~self._surfaces).any())
        if not len(batch):
            return
        pixels, visibility = self.settle.settle(batch, trace)
        self.still.write_pixels(pixels, visibility)
        self.still.drawn(self.settle.settled_blocks(self.cells))

    def bind_shading(self, program, soft_light: np.ndarray, radiance: np.ndarray) -> None:
        """Set the shading pass's lean variant to light the frame through the blocks."""
        self.values.use(BLOCKS_UNIT)
        self.points_visibility.use(POINTS_UNIT)
        self.marks.bind_to_image(MARKS_IMAGE, read=False, write=True)
        program["u_soft_marks"].value = MARKS_IMAGE
        program["u_soft_blocks"].value = BLOCKS_UNIT
        program["u_soft_points"].value = POINTS_UNIT
        self.still.history.use(HISTORY_UNIT)
        program["u_soft_history"].value = HISTORY_UNIT
        program["u_point_at"].value = self.point_at
        program["u_soft_light"].value = tuple(float(x) for x in soft_light)
        program["u_soft_radiance"].value = tuple(float(x) for x in radiance)

    def composite(self, composite: SoftComposite, raster, target, clip_to_world: np.ndarray,
                  settings: TraceSettings, radiance: np.ndarray,
                  out_visibility: bool = False) -> None:
        """The frame's picture (``target``'s colour) copied into ``composite``'s target, then
        the blocks that look the light up drawn over it with ``raster``'s maps (or,
        ``out_visibility``, every block's visibility, to measure). ``target`` holds the lean
        G-buffer; ``clip_to_world`` is its clip space to world."""
        composite.prepare(self.size)
        if not out_visibility:
            composite.copy_picture(target.colour)
        method = settings.method

        def bind_lookup(prog) -> None:
            raster.bind_lookup(prog, method)
            if "u_soft_kept" in prog:
                self.still.bind_images(prog, refine=False)

        lookup = (LOOKUPS[method], raster.defines())
        composite.draw_runs(target, self.runs, clip_to_world, lookup, bind_lookup, radiance,
                            out_visibility)
        if method == "segment-maps":
            composite.compile_refining(lookup)   # with the frame's own programs
        raster.unbind_lookup()
        self.ctx.memory_barrier()   # the next frame's shading pass reads what it kept

    def refining(self, settings: TraceSettings) -> tuple[int, Runs] | None:
        """This frame's refining round and its runs (:data:`REFINE_ADD` over the blocks it
        kept, :data:`REFINE_START` over those that interpolate), None where it refines nothing:
        segment-maps only, whose K points stay put (pcss has one map)."""
        round_ = self.still.refine_round(settings.maps)
        if settings.method != "segment-maps" or not round_:
            return None
        values = self._values
        refine = np.where(values == INTERPOLATE, REFINE_START,
                          np.where(values == CACHED, REFINE_ADD, SKIP)).astype(np.float32)
        self.still.drawn(refine == REFINE_START)
        runs = block_runs(refine, self.divisor, self.size)
        runs.points, runs.point_at = self.points_visibility, self.point_at
        runs.history = self.still.history
        return round_, runs

    def refine(self, composite: SoftComposite, raster, target, clip_to_world: np.ndarray,
               settings: TraceSettings, maps: tuple, runs: Runs) -> None:
        """Add the lookups with ``maps`` (:meth:`RasterSoft.refine_maps`) to what the pixels of
        the refining ``runs`` kept; the picture stays as the composite left it."""

        def bind_lookup(prog) -> None:
            raster.bind_lookup(prog, settings.method, maps)
            self.still.bind_images(prog, refine=True)

        composite.draw_runs(target, runs, clip_to_world,
                            (LOOKUPS[settings.method], raster.defines()), bind_lookup,
                            np.zeros(3), refine=True)
        raster.unbind_lookup()
        self.ctx.memory_barrier()

    def gl_objects(self) -> int:
        return len(self._textures) + self.still.gl_objects()

    def _release_textures(self) -> None:
        for tex in self._textures:
            tex.release()
        self._textures = []
        self.size = self.cells = None

    def release(self) -> None:
        self._release_textures()
        self.still.release()
