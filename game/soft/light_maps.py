"""The raster soft methods' depth maps: one per point of the segment for the statics, cached, and
one per point with the walkers drawn over a copy of it, every frame.

:class:`LightMaps` owns a depth array (game/gpu/depth_array.py) of ``2 K`` layers (``K`` when the
scene has no characters), the casters' vertex buffers and the depth program, and releases them in
:meth:`LightMaps.release`. Layer ``k`` holds the floors and statics seen from point ``k``; layer
``K + k`` holds the same and the characters, seen through the same frustum, so a lookup reads
one layer per point. The statics' layers are drawn again only when the frusta change
(game/soft/map_frusta.py snaps them, so a still or slowly moving view keeps them).

Each frame the walkers' layers get back the statics' depth only where the walkers were drawn
the frame before (the rectangle their boxes covered in that map; the whole layer after the
statics' layers were drawn again), and the walkers are drawn over it with the depth test: a
layer is not cleared and copied whole for a few walkers.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import moderngl
import numpy as np

from game import transforms
from game.errors import GameError
from game.gpu import glsl, resources
from game.gpu.depth_array import DepthArray
from game.scene.geometry import PackedGeometry
from game.soft.grid import character_triangles, static_triangles
from game.soft.map_frusta import MapFrustum, frusta_key

# The most the raster methods' depth maps may take, in bytes: the maps at the largest K and
# resolution the settings allow would take far more than a frame does.
MAX_MAP_BYTES = 1 << 30
# Texels the walkers' rectangle in a map grows by on each side (the bilinear compare reads the
# texel beside the one a point falls in).
RECT_MARGIN = 2


@dataclass
class MapCounts:
    """The map passes of one frame: what the cache saved is ``static_cached``, each of which
    would otherwise have drawn every static triangle again."""

    static_rendered: int = 0     # statics' maps drawn this frame
    static_cached: int = 0       # statics' maps reused from an earlier frame
    dynamic_rendered: int = 0    # walkers' maps drawn this frame
    triangles_to_maps: int = 0   # triangles drawn into the maps this frame
    triangles_uncached: int = 0  # what redrawing every map with every caster would draw

    def stats(self) -> dict[str, int]:
        """The counts under the names of the trace stats (docs/reference.md, section 4)."""
        out = {f"soft_maps_{k}" if not k.startswith("triangles") else f"soft_{k}": v
               for k, v in asdict(self).items()}
        out["soft_maps_rendered"] = self.static_rendered + self.dynamic_rendered
        out["soft_maps_if_uncached"] = self.static_rendered + self.static_cached
        return out


class LightMaps:
    """Depth maps from ``count`` points along the segment, for the statics and the walkers."""

    def __init__(self, ctx, geom: PackedGeometry, count: int, resolution: int):
        self.ctx = ctx
        self.geom = geom
        self.count = int(count)
        self.resolution = int(resolution)
        self.dynamic = geom.n_characters > 0
        layers = self.count * (2 if self.dynamic else 1)
        need = layers * self.resolution ** 2 * 4
        if need > MAX_MAP_BYTES:
            raise GameError(f"{layers} soft-shadow maps of {self.resolution}^2 texels need "
                            f"{need / 2**20:.0f} MiB; at most {MAX_MAP_BYTES / 2**20:.0f} MiB "
                            "(fewer maps or a smaller --map-resolution)")
        self.array: DepthArray | None = DepthArray(ctx, self.resolution, layers)
        self._objects: list = []
        self.program = self.static_vao = self.dynamic_vao = self.dynamic_vbo = None
        self.dynamic_triangles = 0
        try:
            self.program = ctx.program(vertex_shader=glsl.build("soft_maps.vert"),
                                       fragment_shader=glsl.build("depth.frag"))
            self._objects.append(self.program)
            statics = static_triangles(geom).reshape(-1, 3)
            self.static_triangles = len(statics) // 3
            self.static_vbo = ctx.buffer(np.ascontiguousarray(statics, np.float32).tobytes()
                                         if len(statics) else np.zeros(3, np.float32).tobytes())
            self._objects.append(self.static_vbo)
            self.static_vao = ctx.vertex_array(self.program, [(self.static_vbo, "3f",
                                                               "in_position")])
            self._objects.append(self.static_vao)
        except BaseException:
            self.release()
            raise
        self._static_key: bytes | None = None
        # Per walkers' layer, the texel rectangles (x0, y0, x1, y1) where it differs from the
        # statics' layer, one per walker; None: the whole layer (not copied since the statics
        # were drawn).
        self._dirty: list[list[tuple[int, int, int, int]] | None] = [None] * self.count
        self._walker_sizes = [len(geom.triangles[geom.character_object(i)])
                              for i in range(geom.n_characters)]
        self._walker_closed = np.array([bool(geom.closed[geom.character_object(i)])
                                        for i in range(geom.n_characters)], bool)
        self.closed_triangles = 0   # the walkers' first triangles, drawn back-face culled

    def gl_objects(self) -> int:
        """The depth array's texture and framebuffers, the program (and its shaders), the
        vertex buffers and arrays."""
        programs = [self.program] if self.program is not None else []
        return (self.array.gl_objects() + len(self._objects)
                + resources.attached_shaders(programs))

    def release(self) -> None:
        for obj in reversed(self._objects):
            obj.release()
        self._objects = []
        self.program = self.static_vao = self.dynamic_vao = self.dynamic_vbo = None
        if self.array is not None:
            self.array.release()
            self.array = None

    def bind(self, unit: int) -> None:
        """Bind the depth array for sampling (the lookups' samplers set the filtering)."""
        self.array.bind(unit)

    def draw_statics(self, frusta: list[MapFrustum], cached: bool = True) -> MapCounts:
        """Draw the statics' maps if the frusta changed since they were drawn (always, without
        ``cached``: what the cache saves is measured so); returns the frame's counts so far."""
        if len(frusta) != self.count:
            raise ValueError(f"{len(frusta)} frusta for {self.count} maps")
        counts = MapCounts()
        key = frusta_key(frusta, self.resolution)
        if key != self._static_key or not cached:
            self._draw(self.static_vao, self.static_triangles, frusta, 0)
            self._static_key = key
            self._dirty = [None] * self.count
            counts.static_rendered = self.count
            counts.triangles_to_maps += self.count * self.static_triangles
        else:
            counts.static_cached = self.count
        counts.triangles_uncached = self.count * self.static_triangles
        return counts

    def draw_walkers(self, frusta: list[MapFrustum], models: np.ndarray,
                     counts: MapCounts, cull: bool = True) -> None:
        """Draw the walkers at their poses ``models`` over the statics' depth into the walkers'
        layers, through the same frusta, and add them to ``counts``; with ``cull``, the closed
        walkers' back faces culled (:meth:`_upload_characters`: the same depth)."""
        if not self.dynamic:
            return
        tris = self._upload_characters(models, cull)
        corners = _box_corners(tris, self._walker_sizes)
        res = self.resolution
        for k, frustum in enumerate(frusta):
            self._restore(k)
            self._dirty[k] = _texel_rects(frustum.view_proj, corners, res)
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.ctx.disable(moderngl.CULL_FACE | moderngl.BLEND)
        if self.dynamic_triangles:
            closed, rest = self.closed_triangles, self.dynamic_triangles - self.closed_triangles
            for k, frustum in enumerate(frusta):
                fb = self.array.framebuffers[self.count + k]
                fb.use()
                fb.viewport = (0, 0, res, res)
                self.program["u_view_proj"].write(transforms.gl_bytes(frustum.view_proj))
                if closed:
                    self.ctx.enable(moderngl.CULL_FACE)
                    self.dynamic_vao.render(moderngl.TRIANGLES, vertices=3 * closed)
                    self.ctx.disable(moderngl.CULL_FACE)
                if rest:
                    self.dynamic_vao.render(moderngl.TRIANGLES, vertices=3 * rest,
                                            first=3 * closed)
        self.ctx.detect_framebuffer(0).use()
        counts.dynamic_rendered = self.count
        counts.triangles_to_maps += self.count * self.dynamic_triangles
        counts.triangles_uncached += self.count * self.dynamic_triangles

    def _restore(self, k: int) -> None:
        """Copy the statics' depth of point ``k`` over what its walkers' layer has beside it."""
        from OpenGL import GL

        rects = self._dirty[k]
        if rects is None:
            rects = [(0, 0, self.resolution, self.resolution)]
        tex = self.array.texture
        for x0, y0, x1, y1 in rects:
            if x1 > x0 and y1 > y0:
                GL.glCopyImageSubData(tex, GL.GL_TEXTURE_2D_ARRAY, 0, x0, y0, k,
                                      tex, GL.GL_TEXTURE_2D_ARRAY, 0, x0, y0, self.count + k,
                                      x1 - x0, y1 - y0, 1)

    def _upload_characters(self, models: np.ndarray, cull: bool) -> np.ndarray:
        """Put the walkers' triangles at ``models`` in their buffer, those of closed walkers
        first (:attr:`closed_triangles`); returns them, walker by walker as the scene lists them.

        A closed, outward-wound walker's depth from any point is that of its faces turned toward
        the point (a ray into a closed volume enters it through one), so its back faces are
        culled: half its triangles are not rasterised. A pose that mirrors a walker turns its
        winding inside out; it is drawn whole."""
        tris = np.ascontiguousarray(character_triangles(self.geom, models), np.float32)
        poses = np.asarray(models)[:len(self._walker_sizes), :3, :3]
        culled = self._walker_closed & (np.linalg.det(poses) > 0.0) & cull
        ends = np.cumsum(self._walker_sizes)
        parts = [(slice(e - n, e), c)
                 for e, n, c in zip(ends, self._walker_sizes, culled, strict=True)]
        first = [part for part, c in parts if c]
        ordered = (np.concatenate([tris[part] for part in first]
                                  + [tris[part] for part, c in parts if not c])
                   if len(tris) else tris)
        self.closed_triangles = int(sum(part.stop - part.start for part in first))
        data = ordered.tobytes() if len(tris) else np.zeros(9, np.float32).tobytes()
        if self.dynamic_vbo is None or self.dynamic_vbo.size != len(data):
            if self.dynamic_vbo is not None:
                self._objects.remove(self.dynamic_vao)
                self._objects.remove(self.dynamic_vbo)
                self.dynamic_vao.release()
                self.dynamic_vbo.release()
            self.dynamic_vbo = self.ctx.buffer(data)
            self._objects.append(self.dynamic_vbo)
            self.dynamic_vao = self.ctx.vertex_array(self.program, [(self.dynamic_vbo, "3f",
                                                                     "in_position")])
            self._objects.append(self.dynamic_vao)
        else:
            self.dynamic_vbo.write(data)
        self.dynamic_triangles = len(tris)
        return tris

    def _draw(self, vao, triangles: int, frusta: list[MapFrustum], first_layer: int) -> None:
        """Clear layers ``first_layer ..`` and draw ``vao``'s triangles into each through its
        frustum."""
        res = self.resolution
        self.ctx.enable(moderngl.DEPTH_TEST)
        self.ctx.disable(moderngl.CULL_FACE | moderngl.BLEND)
        for k, frustum in enumerate(frusta):
            layer = first_layer + k
            self.array.clear(layer, res)
            if not triangles:
                continue
            fb = self.array.framebuffers[layer]
            fb.use()
            fb.viewport = (0, 0, res, res)
            self.program["u_view_proj"].write(transforms.gl_bytes(frustum.view_proj))
            vao.render(moderngl.TRIANGLES, vertices=3 * triangles)
        self.ctx.detect_framebuffer(0).use()


def _box_corners(triangles: np.ndarray, sizes: list[int]) -> np.ndarray:
    """The 8 corners (n, 8, 3) of the box around each walker's triangles: ``triangles``
    (t, 3, 3) holds the walkers' in turn, ``sizes`` of each (walkers of none are left out)."""
    sizes = np.asarray(sizes, np.int64)
    sizes = sizes[sizes > 0]
    if not len(sizes):
        return np.zeros((0, 8, 3))
    starts = np.r_[0, np.cumsum(sizes)[:-1]] * 3
    points = triangles.reshape(-1, 3).astype(np.float64)
    lo = np.minimum.reduceat(points, starts, axis=0)
    hi = np.maximum.reduceat(points, starts, axis=0)
    pick = np.array([[(i >> a) & 1 for a in range(3)] for i in range(8)], bool)   # (8, 3)
    return np.where(pick[None], hi[:, None], lo[:, None])


def _texel_rects(view_proj: np.ndarray, corners: np.ndarray, resolution: int
                 ) -> list[tuple[int, int, int, int]]:
    """The texels (x0, y0, x1, y1; ends exclusive) of a map of ``resolution`` that each box of
    ``corners`` (n, 8, 3) covers, grown by :data:`RECT_MARGIN`; the whole map for a box that
    reaches behind the map's eye."""
    if not len(corners):
        return []
    clip = np.concatenate([corners, np.ones(corners.shape[:2] + (1,))], axis=2) \
        @ np.asarray(view_proj, np.float64).T                                  # (n, 8, 4)
    w = np.maximum(clip[..., 3:4], 1e-9)
    uv = (clip[..., :2] / w * 0.5 + 0.5) * resolution
    lo = np.clip(np.floor(uv.min(axis=1)) - RECT_MARGIN, 0, resolution).astype(int)
    hi = np.clip(np.ceil(uv.max(axis=1)) + RECT_MARGIN, 0, resolution).astype(int)
    behind = np.any(clip[..., 3] <= 1e-9, axis=1)
    lo[behind], hi[behind] = 0, resolution
    return [(int(a), int(b), int(c), int(d)) for (a, b), (c, d) in zip(lo, hi, strict=True)]
