"""The renderer: frames of one scene, with one hard-shadow method at a time.

It orchestrates passes that each own their GL objects. A frame: the method's plan
(game/shadows/) -> the frame's blocks (frame_blocks) -> the shadow maps drawn into the depth
array (shadow_pass) -> the camera pass's triangle culling (cull) -> the shading pass into the
frame target (shading_pass, target) -> pixels and G-buffer read back. A frame lit through
traced visibility (soft shadows, the ``traced`` method) then goes through the tracer and the
soft composite (traced_lighting). Run-time scene edits are in scene_edits.

With view-sized clump maps the shading pass also counts, one frame in ``COUNT_EVERY``, the pixels
near each map's shadow edges; the next frame's plan reads them back (long after the GPU is done
with them) and sizes the maps by them (game/shadows/view_budget.py). The first frame has no
counts to go by: it is planned, drawn and counted, then planned and drawn again by its own
counts.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from game.gpu import blocks, context
from game.gpu.limits import GLLimits
from game.gpu.timing import PassTimer
from game.render.cull import TriangleCuller
from game.render.frame import Frame, View
from game.render.frame_blocks import FrameBlocks, ambient_share, shader_defines
from game.render.scene_buffers import SceneBuffers
from game.render.scene_edits import SceneEdits
from game.render.shading_pass import ShadingPass, Variant
from game.render.shadow_pass import ShadowMapPass
from game.render.target import SKY, FrameTarget
from game.render.traced_lighting import TracedLighting
from game.scene.geometry import PackedGeometry
from game.scene.model import Scene
from game.shadows import map_grid
from game.shadows.budget import fit_settings
from game.shadows.lights import LightShadows, LightSpan
from game.shadows.method import VISIBILITY_TRACED, ShadowMethod
from game.shadows.plan import ShadowPlan, ShadowSettings
from game.soft.methods import EXACT_HARD, TraceSettings, hard_light
from game.soft.tracer import TraceResult

# View-sized maps: one frame in this many counts the pixels near each map's shadow edges.
# Counting costs the shading pass about a fifth more on llvmpipe (a texture gather per map read
# and the atomic counters); the weights move slowly (game/shadows/methods/clumped.py ``served``).
COUNT_EVERY = 4


class Renderer(SceneEdits):
    """Renders frames of one scene with one hard-shadow method at a time."""

    def __init__(self, ctx, scene: Scene, size: tuple[int, int],
                 settings: ShadowSettings | None = None, gbuffer: bool = False,
                 clock: str = "auto", limits: GLLimits | None = None, cull: bool = True):
        self.ctx = ctx
        self.scene = scene
        self.timer = PassTimer(ctx, clock)
        self.limits = limits or GLLimits.of(ctx)
        self.debug_view = "none"
        # The camera pass draws only the triangles that can cover a pixel centre
        # (game/render/cull.py); ``cull = False`` draws them all, with the same pixels.
        self.cull = cull
        self.last_plan: ShadowPlan | None = None  # for the overlay's map list
        self.last_spans: list[LightSpan] = []       # each light's maps in it
        # The last frame's plan, when its draw counted the pixels that read each map (the
        # view-sized maps' needs): read back at the next plan, when the GPU is long done.
        self._counted: ShadowPlan | None = None
        self._uncounted = 0  # frames drawn since the last counted one
        self.grids = [map_grid.GridBuilder() for _ in scene.lights]
        self.lights_on = [True] * len(scene.lights)  # the window switches lights off
        # The G-buffer is kept when the caller asks (dumps, soft shadows) and while the method
        # traces its visibility from it.
        self._gbuffer_asked = gbuffer
        self._composited = False  # whether the last frame's picture is the composite's
        self.buffers = self.blocks = self.shadow_pass = self.culler = None
        self.shading = self.traced = self.target = None
        try:  # a part that fails (a refused setting, a driver limit) leaves none behind
            self.buffers = SceneBuffers(ctx, scene)
            self.blocks = FrameBlocks(ctx, self.geom.n_characters, len(scene.lights))
            defines = shader_defines(ctx)
            self.shadow_pass = ShadowMapPass(ctx, self.buffers, defines)
            if TriangleCuller.fits(len(self.buffers.layout.indices)):
                self.culler = TriangleCuller(ctx, defines, self.buffers)
            self.shading = ShadingPass(ctx, self.buffers, defines)
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
        self._counted = None

    def set_settings(self, settings: ShadowSettings) -> None:
        """Switch method or parameters; every map is planned (and cached) anew."""
        self._set_method(settings)
        self.target.remake(self.size, self._gbuffer_needed())

    def set_light(self, light, index: int = 0) -> None:
        """Move hard light ``index``: its maps (only) are re-rendered on the next frame."""
        self.scene.lights[index] = light
        self.shadows.methods[index].set_light(light)

    def set_gbuffer(self, on: bool) -> None:
        """Keep the G-buffer (the tracer reads it) or drop it (it costs fill on llvmpipe); the
        traced method keeps it regardless."""
        self._gbuffer_asked = on
        self.target.remake(self.size, self._gbuffer_needed())

    def _gbuffer_needed(self) -> bool:
        return self._gbuffer_asked or self.method.visibility == VISIBILITY_TRACED

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
        with timer.measure("total", wall=True):
            plan, triangles, culled = self._draw(models, view)
            first = None
            if self._counted is not None and self.shadows.placed_blind:
                # View-sized maps placed before any pixel was counted (the first frame): they
                # are placed anew at once, by this draw's counts, and drawn again.
                self.shadows.place_anew()
                self._uncounted = COUNT_EVERY  # counted at the sides it is placed at
                first = plan
                plan, more, culled = self._draw(models, view)
                triangles += more
        frame = self._frame(plan, triangles, culled, read, first)
        self._composited = False
        if self.method.visibility == VISIBILITY_TRACED:
            result = self.traced.light_frame(frame, self.target, self.geom, models, None, read)
            self._composited = True
            if frame.gbuffer is not None:
                frame.gbuffer["lit"] = result.visibility
                if "lit_lights" in frame.gbuffer:
                    frame.gbuffer["lit_lights"] = self._traced_lights(result.visibility, models)
        if soft is not None:
            gbuffer_ms = frame.ms.get("total", 0.0)
            frame.soft = self.traced.light_frame(frame, self.target, self.geom, models, soft,
                                                 read)
            self._composited = True
            frame.ms["gbuffer"] = gbuffer_ms
            if frame.gbuffer is not None:
                frame.gbuffer["soft"] = frame.soft.visibility
        return frame

    def _draw(self, models: np.ndarray, view: View) -> tuple[ShadowPlan, int, bool]:
        """Plan, draw the maps and shade: the plan, the triangles drawn into maps, and whether
        the camera pass drew only the culled triangles."""
        timer = self.timer
        plan, grid_mode = self._plan(models, view)
        with timer.measure("shadow_static"):
            triangles = self.shadow_pass.draw_maps(plan, plan.render_static)
        with timer.measure("shadow_dynamic"):
            triangles += self.shadow_pass.draw_dynamic(plan)
        culled = self.cull and self.culler is not None
        if culled:
            with timer.measure("cull"):
                self.culler.run(self.size)
        with timer.measure("shade"):
            s = self.settings
            count = self.shadows.counts_pixels and (
                self.shadows.placed_blind or self._uncounted >= COUNT_EVERY - 1)
            self._uncounted = 0 if count else self._uncounted + 1
            variant = Variant.of(self.target.gbuffer, self.scene.lights, s.pcf, grid_mode,
                                 blocks.DEBUG_VIEWS[self.debug_view], count)
            if count:
                self.blocks.count_pixels()
            self.shading.draw(self.target, self.shadow_pass.array, variant, self.culler, culled)
            self._counted = plan if count else None
        return plan, triangles, culled

    def _plan(self, models: np.ndarray, view: View) -> tuple[ShadowPlan, int]:
        """The method's plan for this frame, in the blocks; and the map grid's mode."""
        # The array first: making it anew loses every cached layer.
        if self.shadow_pass.prepare(self.shadows.resolution, self.shadows.layers):
            self.shadows.mark_rendered_lost()
        if self._counted is not None:
            pixels = self.blocks.counted_pixels(len(self._counted.maps))
            # A light switched off read no map: its maps keep what they had.
            self.shadows.served([pixels[span.first_map:span.first_map + span.map_count]
                                 if on else None
                                 for span, on in zip(self.last_spans, self.lights_on,
                                                     strict=True)])
            self._counted = None
        plan, spans = self.shadows.plan(models, view)
        if self.buffers.order_statics(plan.static_pieces) and self.culler is not None:
            self.culler.set_layout()
        s, lights = self.settings, self.scene.lights
        # How far the shader may look from a fragment, in texels: the bias offsets (as in
        # shaders/shadow.glsl) plus one PCF tap and one for rounding.
        reach = s.normal_bias + s.depth_bias + s.slope_bias * s.max_slope + 2.0
        grids = []
        for light, span, builder in zip(lights, spans, self.grids, strict=True):
            maps = plan.maps[span.first_map:span.first_map + span.map_count]
            dynamic = [i - span.first_map for i in plan.render_dynamic
                       if span.first_map <= i < span.first_map + span.map_count]
            grids.append(builder.build([m.fit for m in maps], light.kind, light.position,
                                       s.grid, [m.cover for m in maps], reach,
                                       steady=min(dynamic, default=len(maps))))
        self.blocks.upload(plan, spans, view, grids, models, self.geom, lights, s,
                           self.lights_on)
        self.blocks.bind()
        self.last_plan, self.last_spans = plan, spans
        return plan, grids[0].mode

    def _frame(self, plan: ShadowPlan, triangles: int, culled: bool, read: bool,
               first: ShadowPlan | None = None) -> Frame:
        """The frame's record; ``first`` is a plan drawn before ``plan`` in the same frame,
        whose renders count too."""
        rendered = len(plan.render_static) + len(plan.render_dynamic)
        drawn = (*plan.render_static, *plan.render_dynamic)
        texels = sum(plan.maps[i].viewport ** 2 for i in drawn)
        if first is not None:
            again = (*first.render_static, *first.render_dynamic)
            texels += sum(first.maps[i].viewport ** 2 for i in again)
        counts = {"maps_rendered": rendered + (len(again) if first is not None else 0),
                  "maps_cached": len(plan.maps) - rendered,
                  "maps_total": len(plan.maps), "triangles_to_maps": triangles,
                  "texels_to_maps": texels,
                  "maps_waiting": plan.backlog,
                  "characters": dict(plan.characters)}
        if not read:
            return Frame(image=None, covered=None, maps_sampled=None, ms=dict(self.timer.ms),
                         **counts)
        with self.timer.measure("readback", wall=True):
            rgba = self.target.read_colour()
            covered = rgba[..., 3] > 0
            gbuffer = self.target.read_gbuffer(covered) if self.target.gbuffer else None
        if gbuffer is not None and len(self.scene.lights) > 1:
            gbuffer["lit_lights"] = self._lit_lights(gbuffer["lit"], covered)
        return Frame(
            image=np.ascontiguousarray(rgba[..., :3]), covered=covered,
            maps_sampled=np.maximum(rgba[..., 3].astype(np.int32) - 1, 0),
            ms=dict(self.timer.ms), gbuffer=gbuffer, gl_objects=self.gl_objects(),
            camera_triangles=(self.culler.kept() if culled
                              else len(self.buffers.layout.indices) // 3), **counts)

    def _lit_lights(self, lit: np.ndarray, covered: np.ndarray) -> np.ndarray:
        """(H, W, L) visibility of every light: the shading pass drawn again once per further
        light, its G-buffer keeping that light's (outside the frame's timings; same picture)."""
        out = np.empty((*lit.shape, len(self.scene.lights)), np.float32)
        out[..., 0] = lit
        s = self.settings
        variant = Variant.of(True, self.scene.lights, s.pcf, blocks.GRID_NONE,
                             blocks.DEBUG_VIEWS[self.debug_view])
        for k in range(1, len(self.scene.lights)):
            self.blocks.keep_visibility_of(k)
            self.shading.draw(self.target, self.shadow_pass.array, variant, self.culler, False)
            out[..., k] = self.target.read_gbuffer(covered)["lit"]
        self.blocks.keep_visibility_of(0)
        self.shading.draw(self.target, self.shadow_pass.array, variant, self.culler, False)
        return out

    def _traced_lights(self, first: np.ndarray, models: np.ndarray) -> np.ndarray:
        """(H, W, L) exact visibility of every light (the traced method), outside the frame's
        timings: one traced ray per pixel and light."""
        out = np.empty((*first.shape, len(self.scene.lights)), np.float32)
        out[..., 0] = first
        for k, light in enumerate(self.scene.lights[1:], start=1):
            out[..., k] = self.traced.trace(self.target, self.geom, models, EXACT_HARD,
                                            hard_light(light)).visibility
        return out

    def trace(self, t: float, settings: TraceSettings, light=None) -> TraceResult:
        """Trace over the last frame's G-buffer: ``light`` is a tracer light tuple, by default
        the scene's linear light. The frame's picture is left as it was."""
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
