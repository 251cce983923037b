"""The shadow-map pass: the planned maps drawn into the layers of the depth texture array."""

from __future__ import annotations

import bisect

import moderngl

from game.gpu import glsl, resources
from game.gpu.depth_array import DepthArray
from game.gpu.depth_bounds import DepthBounds, holds
from game.render.scene_buffers import SceneBuffers
from game.shadows.plan import KIND_CHARACTER, ShadowPlan

LAYERED_EXTENSION = "GL_ARB_shader_viewport_layer_array"
CLEAR_EXTENSION = "GL_ARB_clear_texture"  # DepthArray.clear
CLIP_PLANES = tuple(0x3000 + k for k in range(4))  # GL_CLIP_DISTANCE0..3: depth_layered.vert


def merged_squares(squares: set[tuple[int, int, int, int]]) -> set[tuple[int, int, int, int]]:
    """The same texels as these (layer, x, y, side) squares, in fewer squares: four squares of
    one side that tile the aligned square twice as large become that square, again and again.

    Character maps are packed as power-of-two squares in Z order (game/shadows/crowd.py), so a
    layer's maps merge into a few squares, and the clears cost a few calls instead of one per map.
    """
    squares = set(squares)
    while True:
        quads: dict[tuple[int, int, int, int], int] = {}
        for layer, x, y, side in squares:
            if side & (side - 1) == 0 and x % side == 0 and y % side == 0:
                parent = (layer, x - x % (2 * side), y - y % (2 * side), 2 * side)
                quads[parent] = quads.get(parent, 0) + 1
        full = [q for q, n in quads.items() if n == 4]
        if not full:
            return squares
        for layer, x, y, side in full:
            half = side // 2
            squares -= {(layer, x + dx, y + dy, half) for dx in (0, half) for dy in (0, half)}
            squares.add((layer, x, y, side))


def bounded_maps(plan: ShadowPlan) -> list[bool]:
    """Which of the plan's maps have depth bounds (game/gpu/depth_bounds.py): those drawn once
    and kept, not those drawn every frame, whose squares are made of whole blocks; none where
    the plan has several lights (docs/design/depth-bounds.md says why)."""
    if len(plan.light_first_maps) > 1:
        return [False] * len(plan.maps)
    each_frame = set(plan.render_dynamic)
    return [i not in each_frame and holds(rec.origin, rec.viewport)
            for i, rec in enumerate(plan.maps)]


class ShadowMapPass:
    """Draws a plan's maps. Owns the depth programs, their vertex arrays and the depth array.

    Where the vertex shader may pick the layer (GL_ARB_shader_viewport_layer_array) and layers
    can be cleared in place (GL_ARB_clear_texture), all character maps are cleared and drawn in
    one layered draw (:attr:`layered`); otherwise each map costs one framebuffer switch.
    """

    def __init__(self, ctx, buffers: SceneBuffers, defines: dict):
        self.ctx = ctx
        self.buffers = buffers
        self.depth_prog = ctx.program(vertex_shader=glsl.build("depth.vert", defines),
                                      fragment_shader=glsl.build("depth.frag"))
        self.layered = {LAYERED_EXTENSION, CLEAR_EXTENSION} <= set(ctx.extensions)
        self.layered_prog = None
        if self.layered:
            self.layered_prog = ctx.program(
                vertex_shader=glsl.build("depth_layered.vert", defines),
                fragment_shader=glsl.build("depth.frag"))
        self.depth_vao = buffers.vertex_array(self.depth_prog)
        self.layered_vao = buffers.vertex_array(self.layered_prog) if self.layered else None
        self.array: DepthArray | None = None
        self.bounds: DepthBounds | None = None

    def prepare(self, resolution: int, layers: int) -> bool:
        """Make sure the array holds ``layers`` layers of ``resolution``; True when it was made
        anew (every cached map in it is lost)."""
        a = self.array
        if a is not None and a.resolution == resolution and a.layers >= layers:
            return False
        if a is not None:
            a.release()
            self.bounds.release()
            self.array = self.bounds = None  # a refused new array must not leave released ones
        self.array = DepthArray(self.ctx, resolution, layers)
        self.bounds = DepthBounds(self.ctx, resolution, layers)
        return True

    def draw_static(self, plan: ShadowPlan, bounded: list[bool], unit: int) -> int:
        """Render the plan's cached maps due this frame, and make the depth bounds of those
        that ``bounded`` (:func:`bounded_maps`) marks, reading the array through texture unit
        ``unit``; returns the triangles drawn."""
        triangles = self.draw_maps(plan, plan.render_static)
        self.bounds.build(self.array, unit, [
            (plan.maps[i].layer, *plan.maps[i].origin, plan.maps[i].viewport)
            for i in plan.render_static if bounded[i]])
        return triangles

    def draw_maps(self, plan: ShadowPlan, indices: list[int]) -> int:
        """Render the listed maps into their layers, one framebuffer each; returns the
        triangles drawn."""
        self._depth_state()
        layout, triangles = self.buffers.layout, 0
        for index in indices:
            rec = plan.maps[index]
            fbo = self.array.framebuffers[rec.layer]
            fbo.use()
            square = (*rec.origin, rec.viewport, rec.viewport)
            fbo.viewport = square
            fbo.clear(depth=1.0, viewport=square)
            self.depth_prog["u_map"].value = index
            ranges = (layout.ranges(rec.objects) if rec.pieces is None
                      else layout.piece_ranges(rec.pieces))
            for first, count in ranges:
                self.depth_vao.render(moderngl.TRIANGLES, vertices=count, first=first)
                triangles += count // 3
        return triangles

    def draw_dynamic(self, plan: ShadowPlan) -> int:
        """Render the plan's per-frame maps: in one layered draw per light when they are all
        character maps and the GL allows it, else map by map. Returns the triangles drawn."""
        indices = plan.render_dynamic
        if not (self.layered and all(plan.maps[i].kind == KIND_CHARACTER for i in indices)):
            return self.draw_maps(plan, indices)
        if not indices:
            return 0
        self._depth_state()
        array = self.array
        squares = {(plan.maps[i].layer, *plan.maps[i].origin, plan.maps[i].viewport)
                   for i in indices}
        for layer, x, y, side in merged_squares(squares):
            array.clear(layer, side, (x, y))
        fbo = array.layered
        fbo.use()
        fbo.viewport = (0, 0, array.resolution, array.resolution)
        for plane in CLIP_PLANES:
            self.ctx.enable_direct(plane)
        # One draw per light that has character maps this frame, of the characters it holds.
        by_light: dict[int, set[int]] = {}
        for i in indices:
            light = bisect.bisect_right(plan.light_first_maps, i) - 1
            by_light.setdefault(light, set()).update(plan.maps[i].objects)
        for light, characters in sorted(by_light.items()):
            self.layered_prog["u_light"].value = light
            for first, count in self.buffers.layout.ranges(sorted(characters)):
                self.layered_vao.render(moderngl.TRIANGLES, vertices=count, first=first)
        for plane in CLIP_PLANES:
            self.ctx.disable_direct(plane)
        return sum(self.buffers.geom.triangle_count(plan.maps[i].objects) for i in indices)

    def _depth_state(self) -> None:
        """Depth test on; both faces drawn (a map holds every caster's nearest surface)."""
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.ctx.disable(moderngl.CULL_FACE)

    @property
    def memory_bytes(self) -> int:
        return self.array.bytes + self.bounds.bytes if self.array is not None else 0

    def _programs(self) -> list:
        return [p for p in (self.depth_prog, self.layered_prog) if p is not None]

    def gl_objects(self) -> int:
        """Programs, their attached shaders, vertex arrays, and the array's texture and
        framebuffers."""
        programs = self._programs()
        array = 0 if self.array is None else self.array.gl_objects() + self.bounds.gl_objects()
        return 2 * len(programs) + resources.attached_shaders(programs) + array

    def release(self) -> None:
        if self.array is not None:
            self.array.release()
            self.bounds.release()
            self.array = self.bounds = None
        for obj in (self.depth_vao, self.layered_vao, *self._programs()):
            if obj is not None:
                obj.release()
