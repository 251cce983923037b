"""The shading pass: every object seen from the camera, lit through the maps, and the G-buffer.

One program per variant. What a frame fixes (the G-buffer outputs, the light's kind, PCF, the
map grid's mode and the debug view) is a ``#define``, and the pass keeps one compiled program
per combination it meets. llvmpipe runs both sides of a branch under a lane mask, so one program
that branched on uniforms paid for code that no fragment of the frame could reach
(docs/design/shading-variants.md).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import moderngl
import numpy as np
from OpenGL import GL

from game.gpu import blocks, glsl, resources
from game.render.cull import TriangleCuller
from game.render.depth_first import DepthFirst, DepthFirstChoice
from game.render.map_records import MapRecords
from game.render.scene_buffers import SceneBuffers
from game.render.shadow_pass import ShadowMapPass
from game.render.target import FrameTarget, GBuffer
from game.soft.block_values import BLOCK_DEFINES

SHADOW_UNIT = blocks.TEXTURE_UNITS["shadow_maps"]
BOUNDS_UNIT = blocks.TEXTURE_UNITS["shadow_bounds"]
RECORDS_UNIT = blocks.TEXTURE_UNITS["map_records"]


class Variant(NamedTuple):
    """What one shading program is compiled for."""

    gbuffer: GBuffer
    light_kind: int     # blocks.LIGHT_KINDS of the one light (0 with several)
    pcf: bool
    grid_mode: int      # blocks.GRID_* of the one light's map grid (0 with several)
    debug_view: int     # blocks.DEBUG_VIEWS
    many_lights: bool = False  # lights, kinds and grids read from the Lights block
    count_pixels: bool = False  # each map's pixels near its shadow edges, counted (FrameBlocks)
    # The colour's alpha holds the map records each pixel considered, not the maps it read.
    count_candidates: bool = False
    depth_bounds: bool = False  # some maps have depth bounds (game/gpu/depth_bounds.py)
    # The G-buffer alone, no light (the window's soft points, game/soft/direct.py).
    unlit: bool = False

    @classmethod
    def of(cls, gbuffer: GBuffer, lights: list, pcf: bool, grid_mode: int,
           debug_view: int, count_pixels: bool = False, depth_bounds: bool = False) -> Variant:
        """The variant for a frame: with several lights, their kinds and grids are read from
        their records, so one program serves them all."""
        if len(lights) > 1:
            return cls(gbuffer, 0, pcf, 0, debug_view, True, count_pixels, False, depth_bounds)
        return cls(gbuffer, blocks.LIGHT_KINDS[lights[0].kind], pcf, grid_mode, debug_view,
                   False, count_pixels, False, depth_bounds)

    @classmethod
    def points(cls) -> Variant:
        """The full G-buffer of the surface, unlit."""
        return cls(GBuffer.FULL, 0, False, 0, 0, unlit=True)


class ShadingPass:
    """Draws the scene into a :class:`FrameTarget`. Owns its programs and vertex arrays: each
    made on first use and kept, so that switching back and forth makes no new objects."""

    def __init__(self, ctx, buffers: SceneBuffers, defines: dict, records: MapRecords,
                 depth_first: DepthFirst = DepthFirst.AUTO):
        self.ctx = ctx
        self.buffers = buffers
        self.records = records  # the frame's blocks own them; the lookup reads them
        self.defines = defines
        self.depth_first = DepthFirstChoice(depth_first)
        self._programs: dict[Variant, tuple] = {}
        self._depth: tuple | None = None   # the depth pass's program and vertex arrays
        # The last draw's variant, culled_only and bind, for :meth:`candidates` to replay.
        self.last: tuple[Variant, bool, Callable[[object], None] | None] | None = None

    def _program(self, variant: Variant, culler: TriangleCuller | None) -> tuple:
        """(program, vertex array over every triangle, vertex array over the culled ones)."""
        if variant not in self._programs:
            defines = {**self.defines, "GBUFFER": int(variant.gbuffer), "UNLIT": variant.unlit,
                       "GBUFFER_LEAN": int(GBuffer.LEAN), "GBUFFER_FULL": int(GBuffer.FULL),
                       **BLOCK_DEFINES,
                       "LIGHT_KIND": variant.light_kind,
                       "PCF": variant.pcf, "GRID": variant.grid_mode,
                       "DEBUG_VIEW": variant.debug_view, "MANY_LIGHTS": variant.many_lights,
                       "COUNT_PIXELS": variant.count_pixels,
                       "COUNT_CANDIDATES": variant.count_candidates,
                       "DEPTH_BOUNDS": variant.depth_bounds}
            self._programs[variant] = self._made("shade.frag", defines, culler)
        return self._programs[variant]

    def _depth_program(self, culler: TriangleCuller | None) -> tuple:
        if self._depth is None:
            self._depth = self._made("depth_only.frag", {}, culler)
        return self._depth

    def _made(self, fragment: str, defines: dict, culler: TriangleCuller | None) -> tuple:
        """shade.vert with ``fragment``: (program, vertex array over every triangle, vertex
        array over the culled ones, or None without a culler)."""
        prog = self.ctx.program(vertex_shader=glsl.build("shade.vert", self.defines),
                                fragment_shader=glsl.build(fragment, defines))
        culled = (None if culler is None
                  else self.buffers.vertex_array(prog, culler.output, surface=True))
        return prog, self.buffers.vertex_array(prog, surface=True), culled

    def _geometry(self, vao, culled, culler, culled_only: bool) -> None:
        if culled_only:
            culler.draw(culled)
            return
        layout = self.buffers.layout
        closed, total = layout.n_closed, len(layout.indices)
        if closed:
            self.ctx.enable(moderngl.CULL_FACE)
            vao.render(moderngl.TRIANGLES, vertices=closed)
            self.ctx.disable(moderngl.CULL_FACE)
        if total > closed:
            vao.render(moderngl.TRIANGLES, vertices=total - closed, first=closed)

    def candidates(self, target: FrameTarget, maps: ShadowMapPass,
                   culler: TriangleCuller | None) -> np.ndarray:
        """(H, W) map records each pixel considered in the last draw: it is drawn again
        (outside the frame's timings), with what it bound besides, and the records counted in
        the colour's alpha, which alone differs."""
        variant, culled_only, bind = self.last
        self.draw(target, maps, variant._replace(count_pixels=False, count_candidates=True),
                  culler, culled_only, bind)
        return np.maximum(target.read_colour()[..., 3].astype(np.int32) - 1, 0)

    def each_light(self, target: FrameTarget, maps: ShadowMapPass, frame_blocks,
                   culler: TriangleCuller | None, variant: Variant, lit: np.ndarray,
                   covered: np.ndarray, n_lights: int) -> np.ndarray:
        """(H, W, ``n_lights``) visibility of every light, light 0's ``lit`` first: the pass
        drawn again once per further light, its G-buffer keeping that light's (outside the
        frame's timings; the picture drawn last is the frame's own)."""
        out = np.empty((*lit.shape, n_lights), np.float32)
        out[..., 0] = lit
        for k in range(1, n_lights):
            frame_blocks.keep_visibility_of(k)
            self.draw(target, maps, variant, culler, False)
            out[..., k] = target.read_gbuffer(covered)["lit"]
        frame_blocks.keep_visibility_of(0)
        self.draw(target, maps, variant, culler, False)
        return out

    def draw(self, target: FrameTarget, maps: ShadowMapPass, variant: Variant,
             culler: TriangleCuller | None, culled_only: bool,
             bind: Callable[[object], None] | None = None) -> None:
        """Clear ``target`` and draw every object: with ``culled_only``, the triangles the
        culler's last run kept; otherwise closed volumes with back faces culled, then the open
        meshes. ``bind(program)`` sets what else the variant reads (the lean G-buffer's soft
        blocks, game/soft/direct.py)."""
        prog, vao, culled = self._program(variant, culler)
        if not variant.unlit:
            self.last = (variant, culled_only, bind)
        target.begin()
        if bind is not None:
            bind(prog)
        self.ctx.enable(moderngl.DEPTH_TEST)
        if not variant.unlit:
            maps.array.bind(SHADOW_UNIT)
            prog["u_shadow_maps"].value = SHADOW_UNIT
            # Bound here, not with the frame's blocks: moderngl makes and writes textures
            # through its own unit, which is 15 where a GL has only 16.
            self.records.bind(RECORDS_UNIT)
            prog["u_map_records"].value = RECORDS_UNIT
        if variant.depth_bounds:
            maps.bounds.bind(BOUNDS_UNIT)
            prog["u_shadow_bounds"].value = BOUNDS_UNIT
        if variant.unlit:
            self._geometry(vao, culled, culler, culled_only)
            return
        pixels = target.size[0] * target.size[1]
        if not self.depth_first.choose():
            with self.depth_first.counting(pixels):
                self._geometry(vao, culled, culler, culled_only)
            return
        self._depth_pass(culler, culled_only, pixels)
        self._geometry(vao, culled, culler, culled_only)

    def _depth_pass(self, culler: TriangleCuller | None, culled_only: bool, pixels: int) -> None:
        """The scene's depth alone, each a step farther than it is. The shading pass then tests
        as it always does (nearer than what is there): at each pixel the fragments at the
        nearest depth pass, the first one drawn writes it, and a later one at the same depth no
        longer passes, so the first drawn of the nearest wins, as in a single pass. The step
        needs the same depths in both passes, to the bit: shade.vert's ``invariant``."""
        _, depth_vao, depth_culled = self._depth_program(culler)
        GL.glColorMask(False, False, False, False)
        self.ctx.polygon_offset = (0.0, 1.0)
        try:
            with self.depth_first.counting(pixels):
                self._geometry(depth_vao, depth_culled, culler, culled_only)
        finally:
            self.ctx.polygon_offset = (0.0, 0.0)
            GL.glColorMask(True, True, True, True)

    def _entries(self) -> list[tuple]:
        return [*self._programs.values(), *([self._depth] if self._depth else [])]

    def gl_objects(self) -> int:
        """Programs, their attached shaders, their vertex arrays and the depth-first query."""
        entries = self._entries()
        programs = [entry[0] for entry in entries]
        arrays = sum(1 + (entry[2] is not None) for entry in entries)
        return (len(programs) + resources.attached_shaders(programs) + arrays
                + self.depth_first.gl_objects())

    def release(self) -> None:
        for prog, vao, culled in self._entries():
            for obj in (culled, vao, prog):
                if obj is not None:
                    obj.release()
        self._programs = {}
        self._depth = None
        self.depth_first.release()
