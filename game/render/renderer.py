"""The renderer: frames of one scene, with one hard-shadow method at a time.

It orchestrates passes that each own their GL objects. A frame: the method's plan
(game/shadows/) -> the frame's blocks (frame_blocks) -> the shadow maps drawn into the depth
array (shadow_pass) -> the camera pass's triangle culling (cull) -> the shading pass into the
frame target (shading_pass, target) -> pixels and G-buffer read back. A frame lit through
traced visibility (soft shadows, the ``traced`` method) then goes through the tracer and the
soft composite (traced_lighting). Run-time scene edits are in scene_edits; the view-sized maps'
pixel counts in pixel_counts. The passes' names are game/render/passes.py's.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from game.gpu import blocks, context
from game.gpu.limits import GLLimits
from game.gpu.timing import PassTimer
from game.render import passes
from game.render.cull import TriangleCuller
from game.render.depth_first import DepthFirst
from game.render.frame import Frame, View, plan_counts
from game.render.frame_blocks import FrameBlocks, ambient_share, shader_defines
from game.render.light_grids import build_grids
from game.render.pixel_counts import COUNT_EVERY, PixelCounts
from game.render.scene_buffers import SceneBuffers
from game.render.scene_edits import SceneEdits
from game.render.shading_pass import SHADOW_UNIT, ShadingPass, Variant
from game.render.shadow_pass import ShadowMapPass, bounded_maps
from game.render.target import SKY, FrameTarget, GBuffer
from game.render.traced_lighting import TracedLighting
from game.scene.geometry import PackedGeometry
from game.scene.model import Scene
from game.shadows import collapse, map_grid
from game.shadows.budget import fit_settings
from game.shadows.lights import LightShadows, LightSpan
from game.shadows.method import VISIBILITY_TRACED, ShadowMethod
from game.shadows.plan import ShadowPlan, ShadowSettings
from game.soft.methods import TraceSettings
from game.soft.tracer import TraceResult

__all__ = ["COUNT_EVERY", "Frame", "Renderer", "View"]


class Renderer(SceneEdits):
    """Renders frames of one scene with one hard-shadow method at a time."""

    def __init__(self, ctx, scene: Scene, size: tuple[int, int],
                 settings: ShadowSettings | None = None, gbuffer: bool = False,
                 clock: str = "auto", limits: GLLimits | None = None, cull: bool = True,
                 depth_first: DepthFirst = DepthFirst.AUTO):
        self.ctx = ctx
        self.scene = scene
        self.timer = PassTimer(ctx, clock)
        self.limits = limits or GLLimits.of(ctx)
        self.debug_view = "none"
        self.cull = cull  # only the triangles that can cover a pixel centre (render/cull.py)
        self.last_plan: ShadowPlan | None = None  # for the overlay's map list
        self.last_spans: list[LightSpan] = []       # each light's maps in it
        self.last_view: View | None = None          # and the view and poses it was made for
        self.last_models = np.zeros((0, 4, 4))
        self._collapse: tuple = (None, (), [], -math.inf)  # plan, view, notes, when made
        self.counts = PixelCounts()
        self.count_candidates = False  # read frames count the map records each pixel considered
        self.grids = [map_grid.GridBuilder() for _ in scene.lights]
        self.lights_on = [True] * len(scene.lights)  # the window switches lights off
        self._gbuffer_asked = gbuffer  # dumps and soft shadows; the traced method needs it too
        self._composited = False  # whether the last frame's picture is the composite's
        self._soft_bind = None    # binds a direct soft frame's blocks to the shading pass
        self.buffers = self.blocks = self.shadow_pass = self.culler = None
        self.shading = self.traced = self.target = None
        try:  # a part that fails (a refused setting, a driver limit) leaves none behind
            self.buffers = SceneBuffers(ctx, scene)
            self.blocks = FrameBlocks(ctx, self.geom.n_characters, len(scene.lights))
            defines = shader_defines(ctx)
            self.shadow_pass = ShadowMapPass(ctx, self.buffers, defines)
            if TriangleCuller.fits(len(self.buffers.layout.indices)):
                self.culler = TriangleCuller(ctx, defines, self.buffers)
            self.shading = ShadingPass(ctx, self.buffers, defines, self.blocks.records,
                                       depth_first)
            self.traced = TracedLighting(ctx, defines, scene, self.timer)
            self._set_method(settings or ShadowSettings())
            self.target = FrameTarget(ctx, size, self._gbuffer_needed())
            # The sky is as bright as the sky lights: a moonlit night's is dark.
            self.target.sky = tuple(c * ambient_share(scene.lights) ** (1 / 2.2) for c in SKY)
        except BaseException:
            self.release()
            raise

    # -- what it renders --------------------------------------------------------------------
    @property
    def geom(self) -> PackedGeometry:
        return self.buffers.geom

    @property
    def size(self) -> tuple[int, int]:
        return self.target.size

    @property
    def notes(self) -> list[str]:
        """How the settings and the method degraded to fit this GL and the budget."""
        notes = self.fit_notes + self.shadows.notes
        if self.method.visibility == VISIBILITY_TRACED and len(self.scene.lights) > 1:
            notes = notes + [f"{self.settings.method}: the picture is lit by light 0 alone; "
                             "the dumps hold every light's exact visibility"]
        return notes + self.collapse_notes()

    def collapse_notes(self, max_age_s: float = 0.0) -> list[str]:
        """One line per light whose maps were far coarser on screen, in the last frame, than
        its plan aimed for, and one per light whose method wasted its maps on the view
        (game/shadows/collapse.py); kept while the plan and view are, or
        for ``max_age_s`` seconds (the window asks every frame, and a large scene's take a
        while)."""
        plan, view = self.last_plan, self.last_view
        if plan is None or view is None:
            return []
        key = (view.view.tobytes(), view.proj.tobytes(), view.size)
        last_plan, last_key, notes, made = self._collapse
        if (last_plan is not plan or last_key != key) and time.monotonic() - made >= max_age_s:
            notes = collapse.collapse_notes(self.shadows.methods, plan.maps,
                                            [s.first_map for s in self.last_spans], view,
                                            self.geom, self.last_models)
            self._collapse = (plan, key, notes, time.monotonic())
        return notes

    @property
    def method(self) -> ShadowMethod:
        """The first light's shadow method (each light has its own: :attr:`shadows`)."""
        return self.shadows.methods[0]

    def _set_method(self, settings: ShadowSettings) -> None:
        self.settings, self.fit_notes = fit_settings(settings, self.limits,
                                                     self.geom.n_characters)
        self.shadows = LightShadows(self.geom, self.scene.lights, self.settings,
                                    self.limits.max_layers, self.limits.max_maps)
        self.counts.forget()

    def set_settings(self, settings: ShadowSettings) -> None:
        """Switch method or parameters; every map is planned (and cached) anew."""
        self._set_method(settings)   # the next frame makes the target it needs

    def set_light(self, light, index: int = 0) -> None:
        """Move hard light ``index``: its maps (only) are re-rendered on the next frame."""
        self.scene.lights[index] = light
        self.shadows.methods[index].set_light(light)

    def set_gbuffer(self, on: bool) -> None:
        """Keep the G-buffer (the tracer reads it; the traced method always) or drop it, from
        the next frame on."""
        self._gbuffer_asked = on

    def _gbuffer_needed(self) -> GBuffer:
        """The G-buffer a frame keeps unless it is a direct soft frame (lean)."""
        traced = self.method.visibility == VISIBILITY_TRACED
        return GBuffer.FULL if self._gbuffer_asked or traced else GBuffer.NONE

    def resize(self, size: tuple[int, int]) -> None:
        """Make the frame target anew at ``size`` (the window's framebuffer changed)."""
        self.target.remake(size, self.target.gbuffer)

    def models(self, t: float) -> np.ndarray:
        """The characters' (n, 4, 4) model matrices at scene time ``t``."""
        if not self.scene.characters:
            return np.zeros((0, 4, 4))
        return np.stack([c.model_matrix(t) for c in self.scene.characters])

    # -- a frame ------------------------------------------------------------------------------
    def render(self, t: float, view: View, read: bool = True,
               soft: TraceSettings | None = None) -> Frame:
        """Render the scene at time ``t`` seen from ``view``; with ``soft``, lit by the linear
        light through traced soft shadows instead of the hard light.

        With ``read=False`` the pixels stay on the GPU (:attr:`display`; the window shows them)
        and the frame's image, coverage and maps per fragment are None.
        """
        timer = self.timer
        timer.begin_frame()
        models = self.models(t)
        if view.size != self.size:  # the character maps are sized for this frame's pixels
            view = dataclasses.replace(view, size=self.size)
        traced_hard = self.method.visibility == VISIBILITY_TRACED
        direct = self.traced.is_direct(soft, traced_hard)
        self.target.remake(self.size, GBuffer.LEAN if direct else self._gbuffer_needed())
        with timer.measure(passes.TOTAL, wall=True):
            plan, triangles, culled = self._draw(models, view, soft if direct else None)
            first = None
            if self.counts.place_again(self.shadows):
                first = plan
                plan, more, culled = self._draw(models, view)
                triangles += more
        frame = self._frame(plan_counts(plan, triangles, first), culled, read)
        self._composited = self.traced.relight(frame, self.target, self.geom, models,
                                               traced_hard, soft, read)
        return frame

    def _draw(self, models: np.ndarray, view: View, soft: TraceSettings | None = None
              ) -> tuple[ShadowPlan, int, bool]:
        """Plan, draw the maps and shade: the plan, the triangles drawn into maps, and whether
        the camera pass drew only the culled triangles. With ``soft``, a direct soft frame's
        blocks are made before the shading pass, which lights the frame through them (and
        through the last ones made, on a lean target without ``soft``)."""
        timer = self.timer
        plan, grid_mode, bounded = self._plan(models, view)
        with timer.measure(passes.SHADOW_STATIC):
            triangles = self.shadow_pass.draw_static(plan, bounded, SHADOW_UNIT)
        with timer.measure(passes.SHADOW_DYNAMIC):
            triangles += self.shadow_pass.draw_dynamic(plan)
        culled = self.cull and self.culler is not None
        if culled:
            with timer.measure(passes.CULL):
                self.culler.run(self.size)
        if soft is not None:
            self._soft_bind = self.traced.before_shade(
                self.geom, models, soft, view, lambda points: self.shading.draw(
                    points, self.shadow_pass, Variant.points(), self.culler, culled))
        bind = self._soft_bind if self.target.gbuffer == GBuffer.LEAN else None
        with timer.measure(passes.SHADE):
            count = self.counts.count_now(self.shadows)
            variant = Variant.of(self.target.gbuffer, self.scene.lights, self.settings.pcf,
                                 grid_mode, blocks.DEBUG_VIEWS[self.debug_view], count,
                                 any(bounded))
            if count:
                self.blocks.count_pixels()
            self.shading.draw(self.target, self.shadow_pass, variant, self.culler, culled, bind)
            self.counts.drawn(plan, count)
        return plan, triangles, culled

    def _plan(self, models: np.ndarray, view: View) -> tuple[ShadowPlan, int, list[bool]]:
        """The method's plan for this frame, in the blocks; the map grid's mode; and which
        maps have depth bounds (:func:`bounded_maps`)."""
        # The array first: making it anew loses every cached layer.
        shape = self.shadows.prepare()
        if self.shadow_pass.prepare(shape.resolution, shape.layers):
            self.shadows.mark_rendered_lost()
        self.counts.hand_back(self.shadows, self.blocks, self.last_spans, self.lights_on)
        plan, spans = self.shadows.plan(models, view)
        if self.buffers.order_statics(plan.static_pieces) and self.culler is not None:
            self.culler.set_layout()
        s, lights = self.settings, self.scene.lights
        grids = build_grids(self.grids, plan, spans, lights, s)
        bounded = bounded_maps(plan)
        self.blocks.upload(plan, bounded, spans, view, grids, models, self.geom, lights, s,
                           self.lights_on)
        self.blocks.bind()
        self.last_plan, self.last_spans = plan, spans
        self.last_view, self.last_models = view, models
        return plan, grids[0].mode, bounded

    def _frame(self, counts: dict, culled: bool, read: bool) -> Frame:
        """The frame's record, with its ``counts`` (:func:`plan_counts`)."""
        counts = {**counts, "depth_first": self.shading.depth_first.on,
                  "fragments_per_pixel": self.shading.depth_first.fragments_per_pixel}
        if not read:
            return Frame(image=None, covered=None, maps_sampled=None, ms=dict(self.timer.ms),
                         **counts)
        with self.timer.measure(passes.READBACK, wall=True):
            rgba = self.target.read_colour()
            covered = rgba[..., 3] > 0
            gbuffer = (self.target.read_gbuffer(covered) if self.target.gbuffer == GBuffer.FULL
                       else None)
        candidates = (self.shading.candidates(self.target, self.shadow_pass, self.culler)
                      if self.count_candidates else None)
        if gbuffer is not None and len(self.scene.lights) > 1:
            variant = Variant.of(GBuffer.FULL, self.scene.lights, self.settings.pcf,
                                 blocks.GRID_NONE,
                                 blocks.DEBUG_VIEWS[self.debug_view],
                                 depth_bounds=self.shading.last[0].depth_bounds)
            gbuffer["lit_lights"] = self.shading.each_light(
                self.target, self.shadow_pass, self.blocks, self.culler, variant,
                gbuffer["lit"], covered, len(self.scene.lights))
        return Frame(
            image=np.ascontiguousarray(rgba[..., :3]), covered=covered,
            maps_sampled=np.maximum(rgba[..., 3].astype(np.int32) - 1, 0),
            ms=dict(self.timer.ms), gbuffer=gbuffer, gl_objects=self.gl_objects(),
            camera_triangles=(self.culler.kept() if culled
                              else len(self.buffers.layout.indices) // 3),
            map_candidates=candidates, **counts)

    def trace(self, t: float, settings: TraceSettings, light=None) -> TraceResult:
        """Trace ``light`` (default: the linear light) over the last frame's G-buffer."""
        return self.traced.trace(self.target, self.geom, self.models(t), settings, light)

    # -- what it holds ----------------------------------------------------------------------
    @property
    def display(self) -> tuple:
        """(framebuffer, colour texture) holding the last frame's picture."""
        if self._composited:
            return self.traced.composite.framebuffer, self.traced.composite.texture
        return self.target.framebuffer, self.target.colour

    @property
    def shadow_array(self):
        """The depth texture array of the last frame (the overlay's layer viewer reads it)."""
        return self.shadow_pass.array

    @property
    def shadow_memory_bytes(self) -> int:
        return self.shadow_pass.memory_bytes

    @property
    def soft_tracer(self):
        """The compute tracer, once a frame has been traced (None after :meth:`release`)."""
        return self.traced.tracer if self.traced is not None else None

    def gl_objects(self) -> dict[str, int]:
        """Live GL objects by owner: every pass and buffer set this renderer holds."""
        counts = {"scene_buffers": self.buffers.gl_objects(),
                  "frame_blocks": self.blocks.gl_objects(), "target": self.target.gl_objects(),
                  "shadow_pass": self.shadow_pass.gl_objects(),
                  "shading_pass": self.shading.gl_objects(),
                  "timer_queries": self.timer.gl_objects(), **self.traced.gl_objects()}
        if self.culler is not None:
            counts["culler"] = self.culler.gl_objects()
        return counts

    def _geometry_changed(self) -> None:
        """The scene's geometry changed (scene_edits): re-pack it into the same buffers."""
        self.buffers.repack(self.scene)
        self.blocks.characters_changed(self.geom.n_characters)
        if self.culler is not None and not TriangleCuller.fits(len(self.buffers.layout.indices)):
            self.culler.release()
            self.culler = None  # the shading programs' culled vertex arrays go unused
        if self.culler is not None:
            self.culler.set_layout()
        self.traced.invalidate()  # the tracer's grid holds the old triangles

    def release(self) -> None:
        """Release every GL object this renderer made."""
        # A program still in use is only flagged for deletion, its shaders kept alive with it.
        context.unbind_program()
        for part in (self.traced, self.shading, self.culler, self.shadow_pass, self.target,
                     self.blocks, self.buffers):
            if part is not None:
                part.release()
        self.traced = self.shading = self.culler = self.shadow_pass = None
        self.target = self.blocks = self.buffers = None
        self.timer.release()
