"""Soft shadows traced at a reduced resolution and upsampled to the frame's (the window's).

The frame and its G-buffer stay at full resolution. :class:`ReducedTrace` picks one G-buffer
pixel per block of ``divisor`` x ``divisor`` (shaders/subsample.frag), has the tracer trace only
those, and spreads their visibility back over every pixel with a joint bilateral filter guided
by the full-resolution G-buffer (shaders/upsample.frag): a pixel averages the traced samples near
it that lie on its own surface, so a shadow's edge along the geometry stays as sharp as the
frame. The soft composite then lights the frame at full resolution through the result.

While the view stays (the same camera, size and settings), successive frames trace the other
pixels of each block, then further rounds with other sample jitters, and every traced value
joins its pixel's running mean on the GPU (game/soft/accumulate.py), which also starts again
the pixels a moving walker may shadow. After :attr:`Upsampling.rounds` rounds with no walker
moving, nothing is traced until something moves.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass

import moderngl
import numpy as np

from game.gpu import blocks, resources
from game.gpu.fullscreen import fullscreen_pass
from game.soft.accumulate import OWN_ENOUGH, Accumulation
from game.soft.tracer import TraceResult

# The joint bilateral filter's weights (shaders/upsample.frag): a sample counts fully on the
# pixel's own plane, and falls to 1/e at PLANE_SIGMA, the sine of the angle between the step to
# it and that plane (0.1: about 6 degrees); normals agree by their cosine to this power; the
# screen distance is a Gaussian of SPATIAL_SIGMA_CELLS blocks. Below MIN_WEIGHT in all, the pixel
# takes the sample that continues its surface best.
PLANE_SIGMA = 0.1
NORMAL_POWER = 8.0
SPATIAL_SIGMA_CELLS = 0.6
MIN_WEIGHT = 1e-4
GATHER = 3                 # blocks per side whose samples a pixel weighs, around its nearest
NO_SAMPLE = -1.0           # visibility texel where nothing was traced (no geometry)
UNITS = {"u_position": blocks.TEXTURE_UNITS["trace_position"],
         "u_normal": blocks.TEXTURE_UNITS["trace_normal"],
         "u_colour": blocks.TEXTURE_UNITS["trace_colour"],
         "u_samples": blocks.TEXTURE_UNITS["upsample_samples"],
         "u_sample_normals": blocks.TEXTURE_UNITS["upsample_sample_normals"],
         "u_agreed": blocks.TEXTURE_UNITS["upsample_agreed"],
         "u_history": blocks.TEXTURE_UNITS["upsample_accumulated"]}


@dataclass(frozen=True)
class Upsampling:
    """How a reduced soft trace runs: one traced pixel per ``divisor`` x ``divisor``; while
    the view stays (``accumulate``), ``rounds`` rounds of every pixel with no walker moving,
    then none."""

    divisor: int = 4
    accumulate: bool = True
    rounds: int = 4

    def __post_init__(self) -> None:
        if self.divisor < 1:
            raise ValueError(f"divisor must be at least 1, got {self.divisor}")
        if self.rounds < 1:
            raise ValueError(f"rounds must be at least 1, got {self.rounds}")


def trace_size(size: tuple[int, int], divisor: int) -> tuple[int, int]:
    """The reduced trace's size for a frame of ``size``: one pixel per (started) block."""
    return (-(-size[0] // divisor), -(-size[1] // divisor))


def phases(divisor: int) -> list[tuple[int, int]]:
    """The pixels of a block in the order the frames trace them, from the block's bottom-left
    corner: the middle one first (the one a moving view always traces), then the rest."""
    middle = (divisor // 2, divisor // 2)
    rest = [(x, y) for y in range(divisor) for x in range(divisor) if (x, y) != middle]
    return [middle, *rest]


def window_extremes(values: np.ndarray, before: int, after: int) -> tuple[np.ndarray, np.ndarray]:
    """The least and the most of ``values`` (h, w; NaN counts as none) over each element's
    window, from ``before`` rows and columns before it to ``after`` after it (beyond the array:
    none); inf and -inf where a window holds none."""
    h, w = values.shape
    pad = ((before, after),) * 2
    low = np.pad(np.where(np.isnan(values), np.inf, values), pad, constant_values=np.inf)
    high = np.pad(np.where(np.isnan(values), -np.inf, values), pad, constant_values=-np.inf)
    least = np.full((h, w), np.inf, np.float32)
    most = np.full((h, w), -np.inf, np.float32)
    for dy in range(before + after + 1):
        for dx in range(before + after + 1):
            least = np.minimum(least, low[dy:dy + h, dx:dx + w])
            most = np.maximum(most, high[dy:dy + h, dx:dx + w])
    return least, most


def agreed_values(visibility: np.ndarray, shift: int) -> np.ndarray:
    """For each texel of the reduced trace, (H, W) float32 in GL rows: the one value that every
    sample the filter weighs has where that texel's block is the first of the filter's
    (``first_cell`` in shaders/upsample.frag), or :data:`NO_SAMPLE` where they differ (1 where
    there is none, as the filter itself gives).

    ``visibility`` is the trace, row 0 at the top, NaN where no geometry; texel x of a row holds
    block ``(x + shift) mod W`` (shaders/subsample.frag)."""
    by_block = np.roll(visibility[::-1], shift, axis=1)
    # The window starts at the block itself: GATHER - 1 more after it.
    least, most = window_extremes(by_block, 0, GATHER - 1)
    same = np.where(least == most, least, NO_SAMPLE)
    same = np.where(np.isinf(least), 1.0, same)     # no sample at all
    return np.ascontiguousarray(np.roll(same, -shift, axis=1), np.float32)


@dataclass
class ReducedState:
    """Where the reduced trace stands after a frame, for the overlay."""

    size: tuple[int, int]         # the trace's pixels
    divisor: int
    traced: bool                  # whether this frame traced (False: converged, nothing moved)
    round: int                    # completed rounds of every pixel with nothing moving
    rounds: int
    phase: int                    # pixels of each block traced so far in this round
    phases: int
    full: bool                    # every pixel has samples of its own
    settled: float = 0.0          # share of the pixels traced exactly (game/soft/settle.py)

    @property
    def converged(self) -> bool:
        return self.round >= self.rounds


# ``trace(textures, size)``: the tracer run over a G-buffer of (position, normal, colour).
TraceFn = Callable[[tuple, tuple[int, int]], TraceResult]


@dataclass
class FrameMotion:
    """What moved for a frame of the reduced trace: ``key`` says what the whole picture
    depends on (view, size, settings; a new key starts every pixel again), ``boxes`` the
    walkers that moved (game/soft/accumulate.py's ``walker_boxes``), ``camera`` the eye and
    ``light`` the segment's tracer tuple."""

    key: bytes
    boxes: np.ndarray
    camera: np.ndarray
    light: tuple


class ReducedTrace:
    """Owns the subsample and upsample programs, the reduced G-buffer (with the samples' normals
    and where they agree) and its framebuffer, this frame's upsampled trace (:attr:`current`),
    the accumulation (game/soft/accumulate.py) and the picture's target
    (:attr:`visibility`), all released by :meth:`release`. The targets are made on the first
    frame and again when the frame's size or the divisor changes (as many objects again)."""

    def __init__(self, ctx, upsampling: Upsampling | None = None):
        self.ctx = ctx
        self.upsampling = upsampling or Upsampling()
        self.size: tuple[int, int] | None = None     # the frame's
        self.cells: tuple[int, int] | None = None    # the trace's
        self._objects: list = []
        self._subsample = self._subsample_vao = None
        self.accumulation: Accumulation | None = None
        # The upsample's programs by PART: shaders/upsample.frag. All made here, so that a
        # still view that starts accumulating makes no GL objects.
        self._upsample: dict[int, object] = {}
        self._upsample_vao: dict[int, object] = {}
        try:  # a program that fails to build leaves none behind
            self._subsample, self._subsample_vao = fullscreen_pass(ctx, "subsample.frag")
            for part in (0, 1):
                self._program(part)
            self.accumulation = Accumulation(ctx, PLANE_SIGMA, NORMAL_POWER)
        except BaseException:
            self.release()
            raise
        self.state: ReducedState | None = None
        self._key: bytes | None = None
        self._frame = 0          # frames traced since the view changed
        self._still = 0          # of them, since a walker last moved
        self._last: TraceResult | None = None

    # -- what it holds ----------------------------------------------------------------------------
    def _program(self, part: int):
        if part not in self._upsample:
            defines = {"PART": part, "PLANE_SIGMA": PLANE_SIGMA,
                       "NORMAL_POWER": NORMAL_POWER, "SPATIAL_SIGMA_CELLS": SPATIAL_SIGMA_CELLS,
                       "MIN_WEIGHT": MIN_WEIGHT, "GATHER": GATHER, "NO_SAMPLE": NO_SAMPLE,
                       "OWN_ENOUGH": OWN_ENOUGH}
            self._upsample[part], self._upsample_vao[part] = fullscreen_pass(
                self.ctx, "upsample.frag", defines)
        return self._upsample[part], self._upsample_vao[part]

    def _resize(self, size: tuple[int, int]) -> None:
        cells = trace_size(size, self.upsampling.divisor)
        if (size, cells) == (self.size, self.cells):
            return
        self._release_targets()
        ctx = self.ctx
        self.size, self.cells = size, cells
        # The reduced G-buffer the tracer reads (samples: position, its w replaced by the
        # traced visibility once known), and the samples' normals for the filter, in 8 bits:
        # llvmpipe's fetches cost by the byte, and the filter reads many.
        self.samples = ctx.texture(cells, 4, dtype="f4")
        self.normal = ctx.texture(cells, 4, dtype="f4")
        self.colour = ctx.texture(cells, 4)
        self.sample_normals = ctx.texture(cells, 4)
        self.gbuffer = ctx.framebuffer([self.samples, self.normal, self.colour,
                                        self.sample_normals])
        self.agreed = ctx.texture(cells, 1, dtype="f4")
        self.current = ctx.texture(size, 1, dtype="f2")
        self.current_framebuffer = ctx.framebuffer([self.current])
        self.visibility = ctx.texture(size, 1, dtype="f2")
        self.framebuffer = ctx.framebuffer([self.visibility])
        textures = [self.samples, self.normal, self.colour, self.sample_normals, self.agreed,
                    self.current, self.visibility]
        for tex in textures:
            tex.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self._objects = [self.gbuffer, self.current_framebuffer, self.framebuffer, *textures]
        self.accumulation.resize(size)
        self._key = None

    def gl_objects(self) -> int:
        programs = [self._subsample, *self._upsample.values()]
        return (len(programs) + resources.attached_shaders(programs) + 1
                + len(self._upsample_vao) + len(self._objects)
                + self.accumulation.gl_objects())

    def _release_targets(self) -> None:
        resources.release_targets(self.ctx, self._objects)
        self._objects = []
        self.size = self.cells = None

    def release(self) -> None:
        self._release_targets()
        if self.accumulation is not None:
            self.accumulation.release()
            self.accumulation = None
        for obj in (*self._upsample_vao.values(), *self._upsample.values(),
                    self._subsample_vao, self._subsample):
            if obj is not None:
                obj.release()
        self._upsample, self._upsample_vao = {}, {}
        self._subsample = self._subsample_vao = None

    # -- a frame ----------------------------------------------------------------------------------
    def set_upsampling(self, upsampling: Upsampling) -> None:
        """Change the divisor or the accumulation; a new divisor re-makes the targets."""
        if upsampling != self.upsampling:
            self.upsampling = upsampling
            self._key = None

    def restart(self) -> None:
        """Accumulate anew from the next frame (the scene's geometry changed)."""
        self._key = None
        self._last = None

    def run(self, textures, size: tuple[int, int], motion: FrameMotion, trace: TraceFn,
            timer) -> TraceResult:
        """Trace this frame's share of the pixels, add it to the running means and resolve
        the picture into :attr:`visibility`.

        ``textures`` are the frame's (position, normal, colour); ``motion`` says what moved.
        ``trace`` runs the tracer over a G-buffer; the subsample, upsample, accumulation and
        resolve are timed as ``soft_upsample`` by ``timer``. Returns the trace (the last one,
        with no times, when nothing was left to trace)."""
        up = self.upsampling
        self._resize(size)
        order = phases(up.divisor)
        reset = motion.key != self._key or not up.accumulate
        if reset:
            self._key, self._frame, self._still = motion.key, 0, 0
        if len(motion.boxes):
            self._still = 0
        traced = self._still < len(order) * up.rounds or self._last is None or reset
        if traced:
            result = self._trace_frame(textures, order, motion, reset, trace, timer)
            self._frame += 1
            self._still += 1
        else:
            result = dataclasses.replace(self._last, ms={k: 0.0 for k in self._last.ms})
        rounds_done, phase = divmod(self._still - 1, len(order))
        if not traced:
            rounds_done, phase = up.rounds, len(order) - 1
        self.state = ReducedState(size=self.cells, divisor=up.divisor, traced=traced,
                                  round=rounds_done, rounds=up.rounds, phase=phase + 1,
                                  phases=len(order),
                                  full=up.accumulate and self._frame >= len(order))
        return result

    def _trace_frame(self, textures, order, motion: FrameMotion, reset: bool, trace: TraceFn,
                     timer) -> TraceResult:
        """This frame's pixels traced, upsampled, accumulated and resolved."""
        d = self.upsampling.divisor
        phase = order[self._frame % len(order)]
        shift = (self._frame // len(order)) % self.cells[0]
        with timer.measure("soft_upsample"):
            self._draw_subsample(textures, d, phase, shift)
        result = trace((self.samples, self.normal, self.colour), self.cells)
        self._last = result
        with timer.measure("soft_upsample"):
            self._write_samples(result.visibility, shift)
            mapping = {"divisor": d, "phase": phase, "shift": shift, "cells": self.cells,
                       "traced": self.upsampling.accumulate}
            self.accumulation.accumulate(textures, self.samples, mapping, reset, motion.boxes,
                                         motion.camera, motion.light)
            self._draw_upsample(textures, d, phase, shift)
            self.accumulation.resolve(textures, self.current, self.framebuffer)
        return result

    def _write_samples(self, visibility: np.ndarray, shift: int) -> None:
        """Put the trace's visibility (row 0 at the top) beside each sample's position, and
        where the samples agree."""
        w, h = self.cells
        samples = np.frombuffer(self.samples.read(), np.float32).reshape(h, w, 4).copy()
        samples[..., 3] = np.nan_to_num(visibility[::-1], nan=NO_SAMPLE)
        self.samples.write(samples.tobytes())
        self.agreed.write(agreed_values(visibility, shift).tobytes())

    def _bind(self, prog, textures) -> None:
        for tex, name in zip(textures, ("u_position", "u_normal", "u_colour"), strict=True):
            if name in prog:   # the compiler drops what a program does not read
                tex.use(UNITS[name])
                prog[name].value = UNITS[name]

    def _draw_subsample(self, textures, divisor: int, phase: tuple[int, int],
                        shift: int) -> None:
        prog = self._subsample
        self._bind(prog, textures)
        prog["u_divisor"].value = divisor
        prog["u_phase"].value = phase
        prog["u_shift"].value = shift
        prog["u_cells"].value = self.cells
        self._draw(self.gbuffer, self.cells, self._subsample_vao)

    def _draw_upsample(self, textures, divisor: int, phase: tuple[int, int],
                       shift: int) -> None:
        """This frame's trace upsampled into :attr:`current`, in two draws: where its samples
        agree, and the filter elsewhere (shaders/upsample.frag, PART)."""
        for part in (0, 1):
            prog, vao = self._program(part)
            self._bind(prog, textures)
            for name, tex in (("u_samples", self.samples),
                              ("u_sample_normals", self.sample_normals),
                              ("u_agreed", self.agreed),
                              ("u_history", self.accumulation.latest)):
                if name in prog:   # the first part reads no samples
                    tex.use(UNITS[name])
                    prog[name].value = UNITS[name]
            prog["u_divisor"].value = divisor
            prog["u_phase"].value = phase
            prog["u_shift"].value = shift
            prog["u_cells"].value = self.cells
            self._draw(self.current_framebuffer, self.size, vao)

    def _draw(self, framebuffer, size: tuple[int, int], vao) -> None:
        framebuffer.use()
        framebuffer.viewport = (0, 0, *size)
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)
        vao.render(moderngl.TRIANGLES, vertices=3)
