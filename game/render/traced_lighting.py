"""Frames lit through traced visibility: the compute tracer over the G-buffer, then the soft
composite.

Two things use it: soft shadows of the scene's linear light, and the ``traced`` hard-shadow
method, whose exact visibility replaces the maps' (one ray per point toward the hard light).

Both trace every pixel of the frame, unless a caller asks for less: the window traces soft
shadows at a reduced resolution and upsamples them (:meth:`TracedLighting.reduce_soft`,
game/soft/upsample.py), or with a raster soft method lights them in the shading pass itself,
from one value per block, and looks them up in the composite only where the shadow changes
(:meth:`TracedLighting.before_shade`, game/soft/direct.py); a long headless run reports its
progress (:attr:`TracedLighting.progress`) and then traces in bands of rows, each the same
pixels with the same pixel indices, so the visibility is the same as in one pass.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import numpy as np

from game.errors import GameError
from game.gpu import blocks
from game.gpu.timing import PassTimer
from game.render import passes
from game.render.direct_frames import DirectFrames
from game.render.frame import Frame, View
from game.render.frame_blocks import light_radiance
from game.render.light_grids import stack_lights
from game.render.target import FrameTarget, GBuffer
from game.scene.geometry import PackedGeometry
from game.scene.model import Scene
from game.soft.accumulate import walker_boxes
from game.soft.composite import SoftComposite
from game.soft.methods import EXACT_HARD, EXACT_SOFT, TraceSettings, hard_light, is_raster
from game.soft.raster import RasterSoft
from game.soft.settle import ExactTrace
from game.soft.tracer import SoftTracer, TraceResult
from game.soft.upsample import FrameMotion, ReducedState, ReducedTrace, Upsampling

# A trace that reports progress first traces 1/PROGRESS_BANDS of the rows; if the whole would
# take PROGRESS_AFTER_S or more at that pace it goes on band by band, reporting after each,
# otherwise it traces the rest at once.
PROGRESS_BANDS = 16
PROGRESS_AFTER_S = 2.0
# The linear light shines in light 0's colour at this share of its radiance: a scene file gives
# it no intensity of its own, and beside the sun at full strength it washes the lit ground out
# to the tone map's ceiling.
LINEAR_LIGHT_SHARE = 0.5


class TracedLighting:
    """Owns the tracer (made on first use and kept, its static grid cached; a new
    ``cells_per_triangle`` makes a new one) and the composite. Times its passes with the
    renderer's ``timer``."""

    def __init__(self, ctx, defines: dict, scene: Scene, timer: PassTimer):
        self.ctx = ctx
        self.scene = scene
        self.timer = timer
        self.tracer: SoftTracer | None = None
        self.raster: RasterSoft | None = None  # the raster soft methods, made on first use
        self.composite = SoftComposite(ctx, defines)
        # The window's reduced soft trace (made on first use and kept) and what it is asked for.
        self.reduced: ReducedTrace | None = None
        self.direct: DirectFrames | None = None   # a raster method's blocks (made on first use)
        self._direct_frame = False   # whether the last soft frame went through :attr:`direct`
        self._upsampling: Upsampling | None = None
        self._view_key = b""
        self._camera = np.zeros(3)
        self._last_models: np.ndarray | None = None   # the walkers' poses at the last frame
        self._walker_bounds = self._bounds()
        self.last_soft: TraceSettings | None = None   # the last soft frame's settings
        # Whether a still view of a raster method settles its pixels to the exact visibility
        # (game/soft/settle.py).
        self.settle = True
        # Called with the share of the frame's trace done, when set (a long headless run).
        self.progress: Callable[[float], None] | None = None

    def reduce_soft(self, upsampling: Upsampling | None, view_key: bytes = b"",
                    camera: np.ndarray | None = None) -> None:
        """Trace soft shadows at a reduced resolution and upsample them (the window), or with
        None at every pixel (the default: captures, traces and their dumps). ``view_key`` is the
        caller's view (its matrices), ``camera`` its eye: while the view and the settings stay
        the same, frames accumulate, and the pixels a moving walker may shadow start again
        (:class:`~game.soft.upsample.ReducedTrace`)."""
        self._upsampling = upsampling
        self._view_key = view_key
        if camera is not None:
            self._camera = np.asarray(camera, np.float64)

    @property
    def reduced_state(self) -> ReducedState | None:
        """Where the reduced trace stood after the last soft frame (None: not reduced)."""
        if not self._upsampling:
            return None
        source = self.direct.blocks if self._direct_frame else self.reduced
        return source.state if source is not None else None

    def segment(self) -> tuple[int, np.ndarray, np.ndarray]:
        """The tracer's light tuple for the scene's linear light."""
        segment = self.scene.linear_light
        if segment is None:
            raise GameError("the scene has no [linear_light] to trace")
        return (blocks.TRACE_LIGHT_SEGMENT, segment.a, segment.b)

    def trace(self, target: FrameTarget, geom: PackedGeometry, models: np.ndarray,
              settings: TraceSettings, light: tuple | None = None) -> TraceResult:
        """Trace ``light`` (a tracer light tuple; default the linear light) from every G-buffer
        pixel of ``target``."""
        if target.gbuffer != GBuffer.FULL:
            raise RuntimeError("the soft-shadow pass needs a renderer made with gbuffer=True")
        textures = (target.position, target.normal, target.colour)
        light = light or self.segment()
        if self.progress is not None:
            return trace_in_bands(self.ctx, self._tracer(geom, settings), target, models,
                                  settings, light, self.progress)
        return self._tracer(geom, settings).trace(textures, target.size, models, settings, light)

    def _tracer(self, geom: PackedGeometry, settings: TraceSettings) -> SoftTracer | RasterSoft:
        if is_raster(settings.method):
            if self.raster is None:
                self.raster = RasterSoft(self.ctx, geom, self.scene, self.timer.clock)
            return self.raster
        tracer = self.tracer
        if tracer is None or tracer.grid.cells_per_triangle != settings.cells_per_triangle:
            if tracer is not None:
                tracer.release()
            tracer = self.tracer = SoftTracer(self.ctx, geom, self.scene,
                                              settings.cells_per_triangle, self.timer.clock)
        return tracer

    def relight(self, frame: Frame, target: FrameTarget, geom: PackedGeometry,
                models: np.ndarray, traced_hard: bool, soft: TraceSettings | None,
                read: bool) -> bool:
        """Light ``frame`` again through traced visibility: the hard light's exact one
        (``traced_hard``, the ``traced`` method; with every light's in the dumps), then the
        linear light's through ``soft``. Returns whether the frame's picture is now the
        composite's."""
        if self.direct is not None and target.gbuffer != GBuffer.LEAN:
            self.direct.forget()   # the walkers move unseen by it until its next frame
        if traced_hard:
            result = self.light_frame(frame, target, geom, models, None, read)
            if frame.gbuffer is not None:
                frame.gbuffer["lit"] = result.visibility
                if "lit_lights" in frame.gbuffer:
                    lights = self.scene.lights
                    frame.gbuffer["lit_lights"] = stack_lights(
                        result.visibility, len(lights), lambda k: self.trace(
                            target, geom, models, EXACT_HARD, hard_light(lights[k])).visibility)
        if soft is not None:
            gbuffer_ms = frame.ms.get(passes.TOTAL, 0.0)
            frame.soft = self.light_frame(frame, target, geom, models, soft, read)
            frame.ms.setdefault(passes.GBUFFER, gbuffer_ms)
            if frame.gbuffer is not None:
                frame.gbuffer["soft"] = frame.soft.visibility
        return traced_hard or soft is not None

    def is_direct(self, soft: TraceSettings | None, traced_hard: bool) -> bool:
        """Whether a frame with ``soft`` goes through :attr:`direct`: the window's raster soft
        shadows, lit in the shading pass (not with the ``traced`` method, whose composite
        needs the full G-buffer)."""
        return (soft is not None and not traced_hard and self._upsampling is not None
                and is_raster(soft.method))

    def before_shade(self, geom: PackedGeometry, models: np.ndarray, soft: TraceSettings,
                     view: View, draw_points: Callable[[FrameTarget], None]
                     ) -> Callable[[object], None]:
        """A direct frame's soft shadows up to its shading pass (:class:`DirectFrames`): the
        points drawn by ``draw_points``; returns what binds the blocks to the shading pass's
        program."""
        divisor = self._upsampling.divisor
        if self.direct is not None and self.direct.divisor != divisor:
            self.direct.release()
            self.direct = None
        if self.direct is None:
            self.direct = DirectFrames(self.ctx, self.timer, divisor)
        key = (self._view_key + np.asarray(view.size, np.int64).tobytes()
               if self._view_key else None)
        self.last_soft = soft
        return self.direct.before_shade(self._tracer(geom, soft), models,
                                        self._moved_walkers(models), soft, self.segment(),
                                        self._radiance(), view, key, draw_points)

    def _exact(self, geom: PackedGeometry, models: np.ndarray) -> ExactTrace:
        """The linear light's exact visibility at chosen points (``analytic``), with the
        walkers at ``models``: what a still view settles its pixels to."""
        def trace(points: np.ndarray, normals: np.ndarray) -> np.ndarray:
            tracer = self._tracer(geom, EXACT_SOFT)
            return tracer.trace_points(points, normals, models, EXACT_SOFT,
                                       self.segment()).visibility
        return trace

    def _moved_walkers(self, models: np.ndarray) -> np.ndarray:
        """The boxes the walkers moved through since the last soft frame (walker_boxes)."""
        boxes = walker_boxes(self._walker_bounds, self._last_models, models)
        self._last_models = np.array(models, np.float64)
        return boxes

    def _radiance(self) -> np.ndarray:
        """The linear light's radiance, linear RGB."""
        return light_radiance(self.scene.light) * LINEAR_LIGHT_SHARE

    def light_frame(self, frame: Frame, target: FrameTarget, geom: PackedGeometry,
                    models: np.ndarray, soft: TraceSettings | None, read: bool) -> TraceResult:
        """Trace and light ``frame`` again: by the linear light through ``soft`` samples, or
        with ``soft`` None by the hard light's exact visibility (the ``traced`` method). The
        tracer's passes join the frame's times as ``soft_*`` or ``traced_*``; ``total`` grows
        by them and by the composite."""
        self._direct_frame = target.gbuffer == GBuffer.LEAN
        if self._direct_frame:
            return self.direct.composite(frame, self.composite, self.raster, target,
                                         self._radiance(), read,
                                         self._exact(geom, models) if self.settle else None)
        if soft is None:
            settings, light, soft_light, prefix = EXACT_HARD, hard_light(self.scene.light), None, \
                "traced"
        else:
            light = self.segment()
            settings, soft_light, prefix = soft, (light[1] + light[2]) / 2, "soft"
            self.last_soft = soft
        before = {k: self.timer.ms.get(k, 0.0) for k in ("composite", "soft_upsample")}
        if soft is not None and self._upsampling is not None:
            result, visibility = self._reduced_trace(target, geom, models, soft, light)
        else:
            result = self.trace(target, geom, models, settings, light)
            visibility = result.visibility
        light_kind = blocks.LIGHT_KINDS[self.scene.light.kind]
        with self.timer.measure("composite"):
            self.composite.draw(self._textures(target), target.size, visibility, light_kind,
                                hard=soft_light is None, soft_light=soft_light,
                                soft_radiance=self._radiance())
        if read:
            frame.image = self.composite.read()
        frame.ms.update({f"{prefix}_{k}": v for k, v in result.ms.items()})
        extra = 0.0
        for name, ms in before.items():
            if name in self.timer.ms:
                frame.ms[name] = self.timer.ms[name]
                extra += self.timer.ms[name] - ms
        frame.ms["total"] = frame.ms.get("total", 0.0) + result.ms["total"] + extra
        return result

    @staticmethod
    def _textures(target: FrameTarget) -> tuple:
        """What the composite reads of the frame: G-buffer, picture, shading normal, albedo."""
        return (target.position, target.normal, target.colour, target.shading, target.albedo)

    def window_visibility(self, target: FrameTarget) -> np.ndarray:
        """The linear light's visibility the last soft frame of the window lit each pixel by,
        (H, W) float32 with row 0 at the top, NaN where no geometry (to measure)."""
        if self._direct_frame:
            vis = self.direct.visibility(self.composite, self.raster, target)
        else:
            tex = self.reduced.visibility
            w, h = tex.size
            vis = np.frombuffer(tex.read(), np.float16).reshape(h, w)[::-1].astype(np.float32)
        covered = target.read_colour()[..., 3] > 0
        return np.where(covered, vis, np.nan).astype(np.float32)

    def _reduced_trace(self, target: FrameTarget, geom: PackedGeometry, models: np.ndarray,
                       settings: TraceSettings, light: tuple):
        """The window's soft trace: a share of the pixels, accumulated while the view stays
        (game/soft/upsample.py, game/soft/accumulate.py). Returns the reduced trace and the
        full-resolution visibility texture."""
        if self.reduced is None:
            self.reduced = ReducedTrace(self.ctx, self._upsampling)
        self.reduced.set_upsampling(self._upsampling)
        key = b"".join((self._view_key, np.asarray(target.size, np.int64).tobytes(),
                        repr(settings).encode(),
                        np.asarray(light[1:], np.float64).tobytes()))
        motion = FrameMotion(key=key, boxes=self._moved_walkers(models), camera=self._camera,
                             light=light)
        tracer = self._tracer(geom, settings)

        def trace(textures, size):
            return tracer.trace(textures, size, models, settings, light)

        textures = (target.position, target.normal, target.colour)
        result = self.reduced.run(textures, target.size, motion, trace, self.timer)
        return result, self.reduced.visibility

    def _bounds(self) -> np.ndarray:
        """The walkers' local bounds, (n, 2, 3)."""
        return np.array([c.mesh.bounds for c in self.scene.characters],
                        np.float64).reshape(-1, 2, 3)

    def invalidate(self) -> None:
        """The geometry changed: the next trace builds its grid anew (and accumulates anew)."""
        self._walker_bounds = self._bounds()
        self._last_models = None
        if self.direct is not None:
            self.direct.forget()
        if self.tracer is not None:
            self.tracer.release()
            self.tracer = None
        if self.raster is not None:
            self.raster.release()
            self.raster = None
        if self.reduced is not None:
            self.reduced.restart()

    def gl_objects(self) -> dict[str, int]:
        counts = {"composite": self.composite.gl_objects()}
        if self.tracer is not None:
            counts["tracer"] = self.tracer.gl_objects()
        if self.raster is not None:
            counts["raster_soft"] = self.raster.gl_objects()
        if self.reduced is not None:
            counts["upsample"] = self.reduced.gl_objects()
        if self.direct is not None:
            counts["direct_raster"] = self.direct.gl_objects()
        return counts

    def release(self) -> None:
        self.invalidate()
        self.composite.release()
        if self.reduced is not None:
            self.reduced.release()
            self.reduced = None
        if self.direct is not None:
            self.direct.release()
            self.direct = None


def trace_in_bands(ctx, tracer: SoftTracer | RasterSoft, target: FrameTarget,
                   models: np.ndarray, settings: TraceSettings, light: tuple,
                   progress: Callable[[float], None]) -> TraceResult:
    """Trace every pixel of ``target``'s G-buffer in bands of rows, calling ``progress`` after
    each with the share done.

    Each band is the whole G-buffer with the coverage of the other rows cleared, so a point
    keeps its pixel index (which seeds its samples) and gets the visibility one pass would
    give it; the results are put together row by row. A trace that would be done within
    :data:`PROGRESS_AFTER_S` at the first band's pace does the rest in one go."""
    w, h = target.size
    alpha = target.read_colour()[..., 3]            # row 0 at the top
    mask = ctx.texture((w, h), 4)
    rows = -(-h // PROGRESS_BANDS)
    parts: list[tuple[int, int, TraceResult]] = []
    try:
        start, top = time.perf_counter(), 0
        while top < h:
            bottom = min(h, top + rows)
            covered = np.zeros((h, w, 4), np.uint8)
            covered[top:bottom, :, 3] = alpha[top:bottom]
            mask.write(np.ascontiguousarray(covered[::-1]).tobytes())
            parts.append((top, bottom, tracer.trace(
                (target.position, target.normal, mask), (w, h), models, settings, light)))
            top = bottom
            progress(top / h)
            pace = (time.perf_counter() - start) / top * h
            if len(parts) == 1 and pace < PROGRESS_AFTER_S:
                rows = h - top   # quick: the rest at once
    finally:
        mask.release()
    first = parts[0][2]
    vis = np.full((h, w), np.nan, np.float32)
    counters = {name: np.zeros((h, w), v.dtype) for name, v in first.counters.items()}
    ms: dict[str, float] = {}
    for top, bottom, part in parts:
        vis[top:bottom] = part.visibility[top:bottom]
        for name, values in counters.items():
            values[top:bottom] = part.counters[name][top:bottom]
        for key, value in part.ms.items():
            ms[key] = ms.get(key, 0.0) + value
    # The bands' dispatches add up; the budget and the samples per dispatch are the
    # smallest any band needed.
    return dataclasses.replace(
        first, visibility=vis, counters=counters, ms=ms,
        truncated=sum(part.truncated for *_, part in parts),
        rounds=sum(part.rounds for *_, part in parts),
        step_budget=min(part.step_budget for *_, part in parts),
        samples_per_dispatch=min(part.samples_per_dispatch for *_, part in parts))

