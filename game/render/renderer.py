"""The one owner of GL objects: buffers, programs, the depth array, the frame target.

Data flows one way through a frame: scene state -> shadow plan (game/shadow_methods.py) ->
shadow passes into the depth texture array -> block uploads -> the camera pass's triangle
culling (game/triangle_cull.py) -> the shading pass -> pixels and G-buffer. Passes are methods
here because they only draw with objects this class owns; every object is created here or by a
helper this class owns (the culler, the soft tracer) and released by :meth:`Renderer.release`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import moderngl
import numpy as np

from game import transforms
from game.gpu import blocks as gpu_blocks
from game.gpu import glsl, resources
from game.gpu.blocks import FRAME_DTYPE, LIGHT_KINDS, MAP_DTYPE
from game.gpu.depth_array import DepthArray
from game.gpu.limits import GLLimits, fit_settings
from game.gpu.timing import PassTimer
from game.render.cull import TriangleCuller
from game.scene import geometry
from game.scene.loader import Body, Camera, Character, Scene
from game.shadows import map_grid
from game.shadows.methods import clumped as shadow_methods
from game.shadows.methods.traced import TRACED_METHOD, TRACED_SETTINGS, hard_light
from game.soft.tracer import SoftTracer, TraceResult, TraceSettings

SKY = (0.58, 0.68, 0.80)
DEBUG_VIEWS = {"none": gpu_blocks.DEBUG_NONE, "map": gpu_blocks.DEBUG_MAP,
               "map-count": gpu_blocks.DEBUG_MAP_COUNT, "cache": gpu_blocks.DEBUG_CACHE}
SHADOW_UNIT = 0  # texture unit of the depth array
SOFT_UNIT = 4    # texture unit of the soft visibility (game/tracer.py uses 1-3)
LAYERED_EXTENSION = "GL_ARB_shader_viewport_layer_array"
CLEAR_EXTENSION = "GL_ARB_clear_texture"  # DepthArray.clear


@dataclass
class View:
    """Where the camera is this frame."""

    view: np.ndarray   # (4, 4) world -> view
    proj: np.ndarray   # (4, 4) view -> clip

    @staticmethod
    def from_camera(camera: Camera, size: tuple[int, int]) -> View:
        aspect = size[0] / size[1]
        return View(transforms.look_at(camera.position, camera.target),
                    transforms.perspective(camera.fov, aspect, camera.near, camera.far))


@dataclass
class Frame:
    """What one rendered frame produced."""

    # The next three are None when the frame was rendered with ``read=False`` (the window
    # blits the target instead of reading it back).
    image: np.ndarray | None          # (H, W, 3) uint8, row 0 at the top
    covered: np.ndarray | None        # (H, W) bool: geometry under the pixel centre
    maps_sampled: np.ndarray | None   # (H, W) int: shadow maps read for the pixel
    ms: dict[str, float]
    maps_rendered: int
    maps_cached: int
    maps_total: int
    triangles_to_maps: int
    gbuffer: dict[str, np.ndarray] | None = None  # position, normal, object, lit
    gl_objects: dict[str, int] | None = None  # live GL objects by owner, after the frame
    texels_to_maps: int = 0    # depth texels cleared and rendered into maps this frame
    camera_triangles: int = 0  # triangles the camera pass drew (after culling)

    @property
    def maps_per_fragment(self) -> float | None:
        if self.covered is None:
            return None
        n = int(self.covered.sum())
        return float(self.maps_sampled[self.covered].sum()) / n if n else 0.0


def _defines(ctx, extra: dict | None = None) -> dict:
    d = dict(gpu_blocks.BINDINGS)
    d.update(MAX_MAPS=gpu_blocks.max_maps(ctx),
             GRID_NONE=gpu_blocks.GRID_NONE, GRID_ORTHO=gpu_blocks.GRID_ORTHO,
             GRID_OCTAHEDRAL=gpu_blocks.GRID_OCTAHEDRAL,
             DEBUG_MAP=gpu_blocks.DEBUG_MAP, DEBUG_MAP_COUNT=gpu_blocks.DEBUG_MAP_COUNT,
             LIGHT_DIRECTIONAL=LIGHT_KINDS["directional"], LIGHT_SPOT=LIGHT_KINDS["spot"],
             LIGHT_POINT=LIGHT_KINDS["point"], KIND_CASCADE=shadow_methods.KIND_CASCADE)
    d.update(extra or {})
    d.setdefault("DEBUG_CACHE", gpu_blocks.DEBUG_CACHE)
    return d


class Renderer:
    """Renders frames of one scene with one hard-shadow method at a time."""

    def __init__(self, ctx, scene: Scene, size: tuple[int, int],
                 settings: shadow_methods.ShadowSettings | None = None, gbuffer: bool = False,
                 clock: str = "auto", limits: GLLimits | None = None, cull: bool = True):
        self.ctx = ctx
        self.scene = scene
        self.size = (int(size[0]), int(size[1]))
        self.settings = settings or shadow_methods.ShadowSettings()
        # The G-buffer is kept when the caller asks (dumps, soft shadows) and while the traced
        # method needs it for its rays.
        self._gbuffer_asked = gbuffer
        self.gbuffer = gbuffer or self.settings.method == TRACED_METHOD
        self.debug_view = "none"
        self.timer = PassTimer(ctx, clock)
        self.last_plan: shadow_methods.ShadowPlan | None = None  # for the overlay's map list
        self.geom = geometry.pack(scene)
        self.max_maps = gpu_blocks.max_maps(ctx)
        self._owned: list = []
        self._array: DepthArray | None = None
        self._static_order: list[int] | None = None
        self._tracer: SoftTracer | None = None  # the soft-shadow pass, made on first use
        self._soft_visibility = None  # the soft pass's visibility texture, on first use

        self.depth_prog = self._own(ctx.program(
            vertex_shader=glsl.build("depth.vert", _defines(ctx)),
            fragment_shader=glsl.build("depth.frag")))
        # All character maps in one layered draw where the vertex shader may pick the layer
        # (their corners cleared first with glClearTexSubImage); otherwise one framebuffer
        # switch per map (the seed: map generation parallelises).
        self.layered = {LAYERED_EXTENSION, CLEAR_EXTENSION} <= set(ctx.extensions)
        if self.layered:
            self.layered_prog = self._own(ctx.program(
                vertex_shader=glsl.build("depth_layered.vert", _defines(ctx)),
                fragment_shader=glsl.build("depth.frag")))

        vertices = np.empty(len(self.geom.positions), dtype=[("p", "<f4", 3), ("o", "<i4")])
        vertices["p"] = self.geom.positions
        vertices["o"] = self.geom.objects
        self.vbo = self._own(ctx.buffer(vertices.tobytes()))
        self.layout = geometry.layout(self.geom)
        self.ibo = self._own(ctx.buffer(self.layout.indices.tobytes()))
        # The camera pass draws only the triangles that can cover a pixel centre (see
        # game/triangle_cull.py); ``cull = False`` draws them all, with the same pixels.
        self.cull = cull
        self._culled = False  # whether the last frame's camera pass was culled
        self.culler: TriangleCuller | None = None
        if TriangleCuller.fits(len(self.layout.indices)):
            self.culler = TriangleCuller(ctx, _defines(ctx), self.ibo)
            self.culler.set_layout(self.geom, self.layout)
        content = [(self.vbo, "3f 1i", "in_position", "in_object")]
        self.depth_vao = self._own(ctx.vertex_array(self.depth_prog, content, self.ibo, 4))
        if self.layered:
            self.layered_vao = self._own(ctx.vertex_array(self.layered_prog, content, self.ibo,
                                                          4))
        # The shading programs, one per variant (see _shading_program): each made on first use
        # and kept, so that switching back and forth makes no new objects after the first.
        self._shading: dict[tuple, tuple] = {}
        self._grid_mode = gpu_blocks.GRID_NONE  # of the last frame, for the soft composite

        self.frame_ubo = self._own(ctx.buffer(reserve=FRAME_DTYPE.itemsize))
        self.maps_ubo = self._own(ctx.buffer(reserve=MAP_DTYPE.itemsize * self.max_maps))
        self.grid_ssbo = self._own(ctx.buffer(reserve=4 * 1024))
        self.models_ssbo = self._own(ctx.buffer(reserve=64 * max(1, self.geom.n_characters)))
        self.character_maps_ssbo = self._own(
            ctx.buffer(reserve=4 * max(1, self.geom.n_characters)))
        self._make_target()
        self.limits = limits or GLLimits.of(ctx)
        self.max_layers = self.limits.max_layers
        self._light_rot = self._light_rotation(scene.light)
        self.method = self._create_method(self.settings)

    # -- ownership --------------------------------------------------------------------------
    def _own(self, obj):
        self._owned.append(obj)
        return obj

    def _make_target(self) -> None:
        ctx, size = self.ctx, self.size
        self.color_tex = ctx.texture(size, 4)
        attachments = [self.color_tex]
        self.gbuffer_tex = []
        if self.gbuffer:
            self.gbuffer_tex = [ctx.texture(size, 4, dtype="f4") for _ in range(2)]
            attachments += self.gbuffer_tex
        self.depth_rb = ctx.depth_renderbuffer(size)
        self.target = ctx.framebuffer(attachments, self.depth_rb)

    def _release_target(self) -> None:
        for obj in [self.target, self.depth_rb, self.color_tex, *self.gbuffer_tex]:
            obj.release()

    def _shading_program(self, grid_mode: int, soft: bool = False) -> tuple:
        """The shading pass's (program, vertex arrays), compiled for what a frame fixes: the
        G-buffer outputs, the soft composite, the light's kind, PCF, the map grid's mode and
        the debug view. The vertex arrays draw every triangle, and the culled ones (``None``
        without a culler).

        One program that branched on uniforms for these cost 2.5 times as much on llvmpipe
        (17.0 ms against 6.9 ms for the default scene at 960x540, medians of 199 frames),
        because llvmpipe runs both sides of a branch under a lane mask: code that a frame can
        never reach still runs.
        """
        s = self.settings
        key = (self.gbuffer, soft, LIGHT_KINDS[self.scene.light.kind], s.pcf, grid_mode,
               DEBUG_VIEWS[self.debug_view])
        if key not in self._shading:
            ctx = self.ctx
            gbuffer, soft, light_kind, pcf, grid_mode, debug_view = key
            defines = _defines(ctx, {"GBUFFER": gbuffer, "SOFT": soft, "LIGHT_KIND": light_kind,
                                     "PCF": pcf, "GRID": grid_mode, "DEBUG_VIEW": debug_view})
            prog = self._own(ctx.program(
                vertex_shader=glsl.build("shade.vert", _defines(ctx)),
                fragment_shader=glsl.build("shade.frag", defines)))
            content = [(self.vbo, "3f 1i", "in_position", "in_object")]
            vaos = (self._own(ctx.vertex_array(prog, content, self.ibo, 4)),
                    None if self.culler is None else
                    self._own(ctx.vertex_array(prog, content, self.culler.output, 4)))
            self._shading[key] = (prog, vaos)
        return self._shading[key]

    def set_gbuffer(self, on: bool) -> None:
        """Ask for the G-buffer that the tracer reads, or drop it (the window asks for it for
        soft shadows only: it costs fill on llvmpipe). The traced method keeps it regardless."""
        self._gbuffer_asked = on
        self._update_gbuffer()

    def _update_gbuffer(self) -> None:
        on = self._gbuffer_asked or self.settings.method == TRACED_METHOD
        if on != self.gbuffer:
            self._remake_target(self.size, on)

    def resize(self, size: tuple[int, int]) -> None:
        """Re-create the frame target at ``size`` (the window's framebuffer changed)."""
        size = (int(size[0]), int(size[1]))
        if size != self.size:
            self._remake_target(size, self.gbuffer)

    def _remake_target(self, size: tuple[int, int], gbuffer: bool) -> None:
        """Release the frame target and make it anew at ``size``, with or without G-buffer."""
        self.ctx.detect_framebuffer(0).use()
        self._release_target()
        self.size, self.gbuffer = size, gbuffer
        self._make_target()

    def release(self) -> None:
        """Release every GL object this renderer made."""
        # moderngl re-binds the framebuffer it last used after creating one; leave it the
        # default framebuffer, not one whose name is about to be deleted.
        self.ctx.detect_framebuffer(0).use()
        # A program still in use is only flagged for deletion, its shaders kept alive with it.
        from OpenGL import GL

        GL.glUseProgram(0)
        self._release_target()
        if self._array is not None:
            self._array.release()
            self._array = None
        if self._tracer is not None:
            self._tracer.release()
            self._tracer = None
        for obj in reversed(self._owned):
            obj.release()
        self._owned = []
        if self.culler is not None:
            self.culler.release()
            self.culler = None
        self.timer.release()

    # -- settings -----------------------------------------------------------------------------
    def set_settings(self, settings: shadow_methods.ShadowSettings) -> None:
        """Switch method or parameters; every map is planned (and cached) anew."""
        self.method = self._create_method(settings)
        self._update_gbuffer()

    def set_light(self, light) -> None:
        """Move the hard light: clump maps are re-rendered on the next frame."""
        self.scene.light = light
        self._light_rot = self._light_rotation(light)
        self.method.set_light(light)

    @staticmethod
    def _light_rotation(light) -> np.ndarray:
        """4x4 world-to-light rotation of a directional light (the identity for others)."""
        rot = np.eye(4)
        if light.kind == "directional":
            rot[:3, :3] = transforms.light_rotation(light.direction)
        return rot

    # -- frame ------------------------------------------------------------------------------
    def _ensure_array(self, resolution: int, layers: int) -> DepthArray:
        a = self._array
        if a is None or a.resolution != resolution or a.layers < layers:
            if a is not None:
                a.release()
                self._array = None  # a refused new array must not leave the released one
            self._array = DepthArray(self.ctx, resolution, layers)
            self.method.mark_rendered_lost()
        return self._array

    def _models(self, t: float) -> np.ndarray:
        if not self.scene.characters:
            return np.zeros((0, 4, 4))
        return np.stack([c.model_matrix(t) for c in self.scene.characters])

    def _upload_maps(self, plan: shadow_methods.ShadowPlan) -> None:
        if len(plan.maps) > self.max_maps:
            raise RuntimeError(f"{len(plan.maps)} maps exceed the uniform block ({self.max_maps})")
        block = np.zeros(max(1, len(plan.maps)), MAP_DTYPE)
        fresh = set(plan.render_static) | set(plan.render_dynamic)  # for the "cache" view
        for i, rec in enumerate(plan.maps):
            block[i]["view_proj"] = rec.fit.view_proj.T
            block[i]["params"] = (rec.layer, rec.fit.texel, float(rec.fit.perspective),
                                  rec.viewport / plan.resolution)
            block[i]["eye"] = (*rec.fit.eye, rec.kind)
            block[i]["bounds"] = rec.fit.rect
            block[i]["depth"] = (rec.fit.near, 1.0 / (rec.fit.far - rec.fit.near),
                                 float(i in fresh), 0.0)
        self.maps_ubo.write(block.tobytes())

    def _upload_frame(self, view: View, n_maps: int, grid: map_grid.MapGrid) -> None:
        s, light, geom = self.settings, self.scene.light, self.geom
        f = np.zeros(1, FRAME_DTYPE)
        f["view_proj"] = (view.proj @ view.view).T
        f["light_rot"] = self._light_rot.T
        eye = np.linalg.inv(view.view)[:3, 3]
        f["camera_pos"] = (*eye, 1.0)
        direction = light.direction if light.direction is not None else np.zeros(3)
        f["light_dir"] = (*direction, LIGHT_KINDS[light.kind])
        position = light.position if light.position is not None else np.zeros(3)
        cos_half = math.cos(math.radians(light.cone / 2)) if light.cone else -1.0
        f["light_pos"] = (*position, cos_half)
        f["bias"] = (s.normal_bias, s.depth_bias, s.slope_bias, s.max_slope)
        f["grid_rect"] = grid.rect
        f["counts"] = (n_maps, grid.mode, grid.size, DEBUG_VIEWS[self.debug_view])
        f["options"] = (int(s.pcf), geom.first_character, len(geom.names), geom.n_floors)
        self.frame_ubo.write(f.tobytes())
        data = grid.data.astype(np.int32)
        if self.grid_ssbo.size < data.nbytes:
            self.grid_ssbo.orphan(data.nbytes)
        self.grid_ssbo.write(data.tobytes())

    def _draw_scene(self, vaos: tuple) -> None:
        """Draw every object from the camera: closed volumes with back faces culled, then the
        open meshes; only the triangles the culling pass kept when it ran for this frame."""
        vao, culled = vaos
        if self._culled:
            self.culler.draw(culled)
            return
        closed, total = self.layout.n_closed, len(self.layout.indices)
        if closed:
            self.ctx.enable(moderngl.CULL_FACE)
            vao.render(moderngl.TRIANGLES, vertices=closed)
            self.ctx.disable(moderngl.CULL_FACE)
        if total > closed:
            vao.render(moderngl.TRIANGLES, vertices=total - closed, first=closed)

    def _draw_maps(self, plan, indices: list[int], array: DepthArray) -> int:
        """Render the listed maps into their layers; returns the triangles drawn."""
        triangles = 0
        for index in indices:
            rec = plan.maps[index]
            fbo = array.framebuffers[rec.layer]
            fbo.use()
            fbo.viewport = (0, 0, rec.viewport, rec.viewport)
            fbo.clear(depth=1.0, viewport=(0, 0, rec.viewport, rec.viewport))
            self.depth_prog["u_map"].value = index
            for first, count in self.layout.ranges(rec.objects):
                self.depth_vao.render(moderngl.TRIANGLES, vertices=count, first=first)
                triangles += count // 3
        return triangles

    def _draw_characters_layered(self, plan, indices: list[int], array: DepthArray) -> int:
        """Clear every character map's corner, then render them all into the layered
        framebuffer."""
        if not indices:
            return 0
        for i in indices:
            array.clear(plan.maps[i].layer, plan.maps[i].viewport)
        fbo = array.layered
        fbo.use()
        fbo.viewport = (0, 0, array.resolution, array.resolution)
        characters = [o for i in indices for o in plan.maps[i].objects]
        for first, count in self.layout.ranges(characters):
            self.layered_vao.render(moderngl.TRIANGLES, vertices=count, first=first)
        return sum(self.geom.triangle_count(plan.maps[i].objects) for i in indices)

    def render(self, t: float, view: View, read: bool = True) -> Frame:
        """Render the scene at time ``t`` seen from ``view``.

        With ``read=False`` the pixels stay in :attr:`target` (the window blits them) and the
        frame's image, coverage and maps-per-fragment are None.
        """
        ctx, timer = self.ctx, self.timer
        timer.begin_frame()
        models = self._models(t)
        with timer.measure("total", wall=True):
            # The array first: re-creating it marks every cached layer for re-rendering.
            array = self._ensure_array(self.method.resolution, self.method.layers)
            plan = self.method.plan(models, view)
            # The method keeps one order list until it re-clumps: identity says "unchanged".
            if plan.static_order is not None and plan.static_order is not self._static_order:
                self.layout = geometry.layout(self.geom, plan.static_order)
                self.ibo.write(self.layout.indices.tobytes())
                if self.culler is not None:
                    self.culler.set_layout(self.geom, self.layout)
                self._static_order = plan.static_order
            if len(models):
                self.models_ssbo.write(transforms.gl_bytes(models))
                character_maps = np.full(self.geom.n_characters, -1, np.int32)
                for index, rec in enumerate(plan.maps):
                    if rec.kind == shadow_methods.KIND_CHARACTER:
                        for obj in rec.objects:  # shared maps (issue 6) hold several
                            character_maps[obj - self.geom.first_character] = index
                self.character_maps_ssbo.write(character_maps.tobytes())
            self._upload_maps(plan)
            self.last_plan = plan
            s = self.settings
            # How far the shader may look from a fragment, in texels: the bias offsets (as in
            # shaders/shadow.glsl) plus one PCF tap and one for rounding.
            reach = s.normal_bias + s.depth_bias + s.slope_bias * s.max_slope + 2.0
            grid = map_grid.build([m.fit for m in plan.maps], self.scene.light.kind,
                                  self.scene.light.position, s.grid,
                                  [m.cover for m in plan.maps], reach)
            self._upload_frame(view, len(plan.maps), grid)
            self._grid_mode = grid.mode
            # Bind after the uploads: a buffer that had to grow is bound as it is now.
            for name, binding in (("frame_ubo", "FRAME_BINDING"), ("maps_ubo", "MAPS_BINDING")):
                getattr(self, name).bind_to_uniform_block(gpu_blocks.BINDINGS[binding])
            self.models_ssbo.bind_to_storage_buffer(gpu_blocks.BINDINGS["MODELS_BINDING"])
            self.grid_ssbo.bind_to_storage_buffer(gpu_blocks.BINDINGS["GRID_BINDING"])
            self.character_maps_ssbo.bind_to_storage_buffer(
                gpu_blocks.BINDINGS["CHARACTER_MAPS_BINDING"])

            ctx.enable(moderngl.DEPTH_TEST)
            ctx.disable(moderngl.CULL_FACE)
            triangles = 0
            with timer.measure("shadow_static"):
                triangles += self._draw_maps(plan, plan.render_static, array)
            with timer.measure("shadow_dynamic"):
                dynamic = plan.render_dynamic
                layered = self.layered and all(
                    plan.maps[i].kind == shadow_methods.KIND_CHARACTER for i in dynamic)
                if layered:
                    triangles += self._draw_characters_layered(plan, dynamic, array)
                else:
                    triangles += self._draw_maps(plan, dynamic, array)

            self._culled = self.cull and self.culler is not None
            if self._culled:
                with timer.measure("cull"):
                    self.culler.run(self.size)
            with timer.measure("shade"):
                self.target.use()
                self.target.viewport = (0, 0, *self.size)
                self.target.clear(*SKY, 0.0)
                array.bind(SHADOW_UNIT)
                prog, vaos = self._shading_program(grid.mode)
                prog["u_shadow_maps"].value = SHADOW_UNIT
                self._draw_scene(vaos)
        ms = dict(timer.ms)
        rendered = len(plan.render_static) + len(plan.render_dynamic)
        if not read:
            frame = Frame(image=None, covered=None, maps_sampled=None, ms=ms,
                          maps_rendered=rendered, maps_cached=len(plan.maps) - rendered,
                          maps_total=len(plan.maps), triangles_to_maps=triangles)
            return self._traced(t, frame)
        with timer.measure("readback", wall=True):
            rgba = np.frombuffer(self.target.read(components=4, attachment=0), np.uint8)
            rgba = rgba.reshape(self.size[1], self.size[0], 4)[::-1]
            gbuffer = self._read_gbuffer(rgba) if self.gbuffer else None
        ms = dict(timer.ms)
        return self._traced(t, Frame(
            image=np.ascontiguousarray(rgba[..., :3]),
            covered=rgba[..., 3] > 0,
            maps_sampled=np.maximum(rgba[..., 3].astype(np.int32) - 1, 0),
            ms=ms, maps_rendered=rendered, maps_cached=len(plan.maps) - rendered,
            maps_total=len(plan.maps), triangles_to_maps=triangles, gbuffer=gbuffer,
            gl_objects=self.gl_objects(), camera_triangles=self._camera_triangles(),
            texels_to_maps=sum(plan.maps[i].viewport ** 2
                               for i in (*plan.render_static, *plan.render_dynamic))))

    def _camera_triangles(self) -> int:
        """Triangles the last camera pass drew: what the culling kept, or all of them."""
        return self.culler.kept() if self._culled else len(self.layout.indices) // 3

    def _traced(self, t: float, frame: Frame) -> Frame:
        """The traced method: exact hard shadows from the tracer replace the frame's shading
        (its planner drew no maps); other methods' frames pass through."""
        if self.settings.method != TRACED_METHOD:
            return frame
        result = self.trace(t, TRACED_SETTINGS, hard_light(self.scene.light))
        frame.image = self.shade_soft(result, hard=True)
        if frame.gbuffer is not None:
            frame.gbuffer["lit"] = result.visibility
        self.add_trace_ms(frame, result, "traced")
        return frame

    def add_trace_ms(self, frame: Frame, result: TraceResult, prefix: str) -> None:
        """The tracer's passes and the composite into the frame's times; ``total`` grows by
        both."""
        frame.ms.update({f"{prefix}_{k}": v for k, v in result.ms.items()})
        composite = self.timer.ms.get("composite", 0.0)
        frame.ms["total"] = frame.ms.get("total", 0.0) + result.ms["total"] + composite
        frame.ms["composite"] = composite

    def _read_gbuffer(self, rgba: np.ndarray) -> dict[str, np.ndarray]:
        h, w = self.size[1], self.size[0]
        pos = np.frombuffer(self.target.read(components=4, attachment=1, dtype="f4"), np.float32)
        nrm = np.frombuffer(self.target.read(components=4, attachment=2, dtype="f4"), np.float32)
        pos = pos.reshape(h, w, 4)[::-1]
        nrm = nrm.reshape(h, w, 4)[::-1]
        covered = rgba[..., 3] > 0
        position = np.where(covered[..., None], pos[..., :3], np.nan).astype(np.float32)
        normal = np.where(covered[..., None], nrm[..., :3], np.nan).astype(np.float32)
        obj = np.where(covered, np.rint(pos[..., 3]), -1).astype(np.int32)
        lit = np.where(covered, nrm[..., 3], np.nan).astype(np.float32)
        return {"position": position, "normal": normal, "object": obj, "lit": lit}

    def trace(self, t: float, settings: TraceSettings, light=None) -> TraceResult:
        """Run the soft-shadow pass (game/tracer.py) over the G-buffer of the last frame.

        ``light`` is a tracer light tuple; default: the scene's linear light. The tracer is
        made on first use, kept for later frames (its static grid is cached) and released with
        the renderer; a new ``cells_per_triangle`` makes a new one.
        """
        if not self.gbuffer:
            raise RuntimeError("the soft-shadow pass needs a renderer made with gbuffer=True")
        tracer = self._tracer
        if tracer is None or tracer.grid.cells_per_triangle != settings.cells_per_triangle:
            if tracer is not None:
                tracer.release()
            tracer = self._tracer = SoftTracer(self.ctx, self.geom, self.scene,
                                               settings.cells_per_triangle, self.timer.clock)
        if light is None:
            segment = self.scene.linear_light
            if segment is None:
                raise RuntimeError("the scene has no [linear_light]")
            light = (gpu_blocks.TRACE_LIGHT_SEGMENT, segment.a, segment.b)
        textures = (self.gbuffer_tex[0], self.gbuffer_tex[1], self.color_tex)
        return tracer.trace(textures, self.size, self._models(t), settings, light)

    def shade_soft(self, result: TraceResult, hard: bool = False) -> np.ndarray:
        """Shade the last frame again, lit by the linear light through ``result``'s visibility
        (``hard``: by the hard light, ``result`` being its traced visibility).

        Returns the (H, W, 3) image; the G-buffer textures are left as the frame wrote them.
        """
        tex = self._soft_visibility
        if tex is None or tuple(tex.size) != self.size:  # first use, or the frame was resized
            if tex is not None:
                self._owned.remove(tex)
                tex.release()
            tex = self._soft_visibility = self._own(self.ctx.texture(self.size, 1, dtype="f4"))
        vis = np.nan_to_num(result.visibility[::-1], nan=1.0).astype(np.float32)
        tex.write(np.ascontiguousarray(vis).tobytes())
        segment = self.scene.linear_light
        with self.timer.measure("composite"):
            self.target.use()
            self.target.viewport = (0, 0, *self.size)
            self.target.clear(*SKY, 0.0)
            self._array.bind(SHADOW_UNIT)
            tex.use(SOFT_UNIT)
            prog, vaos = self._shading_program(self._grid_mode, soft=True)
            prog["u_shadow_maps"].value = SHADOW_UNIT
            prog["u_soft"].value = SOFT_UNIT
            prog["u_soft_hard"].value = hard
            if not hard:
                middle = (segment.a + segment.b) / 2
                prog["u_soft_light"].value = tuple(float(x) for x in middle)
            self._draw_scene(vaos)
        rgba = np.frombuffer(self.target.read(components=4, attachment=0), np.uint8)
        return np.ascontiguousarray(rgba.reshape(self.size[1], self.size[0], 4)[::-1, :, :3])

    @property
    def soft_tracer(self) -> SoftTracer | None:
        return self._tracer

    @property
    def shadow_array(self) -> DepthArray | None:
        """The depth texture array of the last frame (the overlay's layer viewer reads it)."""
        return self._array

    @property
    def shadow_memory_bytes(self) -> int:
        return self._array.bytes if self._array is not None else 0

    # -- limits and run-time changes (issue 6) -------------------------------------------------
    def _create_method(self, settings: shadow_methods.ShadowSettings):
        """The planner for ``settings`` fitted inside the GL limits and the memory budget."""
        self.settings, notes = fit_settings(settings, self.limits, self.geom.n_characters)
        method = shadow_methods.create(self.geom, self.scene.light, self.settings,
                                       self.max_layers)
        method.notes[:0] = notes
        return method

    def gl_objects(self) -> dict[str, int]:
        """Live GL objects by owner: what this renderer and the objects it owns hold."""
        target = 3 + len(self.gbuffer_tex)  # framebuffer, colour texture, depth renderbuffer
        shaders = resources.attached_shaders(o for o in self._owned
                                             if isinstance(o, moderngl.Program))
        array = 0 if self._array is None else 1 + len(self._array._fbo_ids)
        counts = {"renderer": len(self._owned) + target + shaders, "depth_array": array,
                  "timer_queries": len(self.timer._queries)}
        if self._tracer is not None:
            counts["tracer"] = self._tracer.gl_objects
        if self.culler is not None:
            counts["culler"] = self.culler.gl_objects
        return counts

    # -- run-time scene changes through the Python API (issue 6, cache invalidation) -------------
    # Each change re-packs the geometry into the same GL buffers (no new GL objects) and tells
    # the method what changed, so it re-renders only the maps that the change makes stale.
    def add_static(self, body: Body) -> list[int]:
        """Add a static object; returns the clumps whose maps the next frame re-renders."""
        if body.name in self.scene.object_names():
            raise ValueError(f"an object named {body.name!r} exists already")
        self.scene.statics.append(body)
        return self._statics_changed({body.name})

    def remove_static(self, name: str) -> list[int]:
        """Remove a static object by name; its clump's map is re-rendered without it."""
        self.scene.statics.remove(self._static(name))
        return self._statics_changed({name})

    def move_static(self, name: str, transform: np.ndarray) -> list[int]:
        """Apply a world (4, 4) ``transform`` to a static: its old and new clumps re-render."""
        body = self._static(name)
        body.mesh = body.mesh.copy()
        body.mesh.apply_transform(np.asarray(transform, float))
        return self._statics_changed({name})

    def add_character(self, character: Character) -> None:
        """Add a character; it takes a free layer of the array if there is one."""
        if character.name in self.scene.object_names():
            raise ValueError(f"an object named {character.name!r} exists already")
        self.scene.characters.append(character)
        self._characters_changed()

    def remove_character(self, name: str) -> None:
        """Remove a character by name; its layer goes back to the pool."""
        matches = [c for c in self.scene.characters if c.name == name]
        if not matches:
            raise KeyError(f"no character named {name!r}")
        self.scene.characters.remove(matches[0])
        self._characters_changed()

    def _static(self, name: str) -> Body:
        for body in self.scene.statics:
            if body.name == name:
                return body
        raise KeyError(f"no static named {name!r}")

    def _repack(self) -> None:
        """Geometry of the changed scene into the existing buffers (grown when needed)."""
        self.geom = geometry.pack(self.scene)
        vertices = np.empty(len(self.geom.positions), dtype=[("p", "<f4", 3), ("o", "<i4")])
        vertices["p"] = self.geom.positions
        vertices["o"] = self.geom.objects
        self.layout = geometry.layout(self.geom)
        self._static_order = None  # the next plan's order is applied afresh
        n = max(1, self.geom.n_characters)
        for buffer, data in ((self.vbo, vertices.tobytes()),
                             (self.ibo, self.layout.indices.tobytes()),
                             (self.models_ssbo, bytes(64 * n)),
                             (self.character_maps_ssbo, bytes(4 * n))):
            buffer.orphan(max(len(data), 4))
            buffer.write(data)
        if self.culler is not None and not TriangleCuller.fits(len(self.layout.indices)):
            self.culler.release()
            self.culler = None  # the cached shading programs' culled vertex arrays go unused
        if self.culler is not None:
            self.culler.set_layout(self.geom, self.layout)
        if self._tracer is not None:
            # The tracer's grid holds the old triangles: the next trace builds it anew.
            self._tracer.release()
            self._tracer = None

    def _statics_changed(self, names: set[str]) -> list[int]:
        self._repack()
        update = getattr(self.method, "update_statics", None)
        if update is None:  # a method without partial updates plans everything anew
            self.method = self._create_method(self.settings)
            return []
        return update(self.geom, names)

    def _characters_changed(self) -> None:
        self._repack()
        update = getattr(self.method, "update_characters", None)
        if update is None:
            self.method = self._create_method(self.settings)
        else:
            update(self.geom)
