"""The blocks every pass of a frame reads, filled from the frame's plan and view.

The uniform blocks Frame, ShadowMaps and Lights and the storage buffers MapGrid, Models and
CharacterMaps (declared in game/gpu/blocks.py) are written once per frame and bound once; the
shadow-map pass, the culling pass, the shading pass and the soft composite all read them. The
map records are written a second time, as a texture the shading pass's lookup reads
(game/render/map_records.py).
"""

from __future__ import annotations

import math

import moderngl
import numpy as np

from game import transforms
from game.gpu import blocks, depth_bounds
from game.gpu.blocks import FRAME_DTYPE, LIGHT_DTYPE, MAP_DTYPE
from game.render.frame import View
from game.render.map_records import RECORD_DEFINES, MapRecords
from game.scene.geometry import PackedGeometry, srgb_to_linear
from game.scene.model import Light
from game.shadows.light_kinds import kind_of
from game.shadows.lights import LightSpan
from game.shadows.map_grid import MapGrid
from game.shadows.plan import (
    KIND_ALL,
    KIND_CASCADE,
    KIND_CHARACTER,
    KIND_CLUMP,
    KIND_FALLBACK,
    ShadowPlan,
    ShadowSettings,
)


def shader_defines(ctx) -> dict:
    """The #defines every shader of the frame is built with (MANY_LIGHTS 0: the shading pass
    sets its own)."""
    d = {"MAX_MAPS": blocks.max_maps(ctx), "MAX_LIGHTS": blocks.MAX_LIGHTS, "MANY_LIGHTS": 0,
         "GRID_NONE": blocks.GRID_NONE,
         "GRID_ORTHO": blocks.GRID_ORTHO, "GRID_OCTAHEDRAL": blocks.GRID_OCTAHEDRAL,
         "GRID_TILES": blocks.GRID_TILES,
         "KIND_CASCADE": KIND_CASCADE, "KIND_CLUMP": KIND_CLUMP, "KIND_FALLBACK": KIND_FALLBACK,
         "KIND_CHARACTER": KIND_CHARACTER, "KIND_ALL": KIND_ALL,
         "MAP_FRESH": blocks.MAP_FRESH, "MAP_BOUNDED": blocks.MAP_BOUNDED,
         "BOUNDS_BLOCK": depth_bounds.BLOCK, **RECORD_DEFINES}
    d.update({f"DEBUG_{name.upper().replace('-', '_')}": value
              for name, value in blocks.DEBUG_VIEWS.items() if name != "none"})
    d.update({f"LIGHT_{kind.upper()}": value for kind, value in blocks.LIGHT_KINDS.items()})
    return d


# A light of colour [1, 1, 1] and intensity 1 lights a surface facing it with this radiance.
LIGHT_RADIANCE = 1.6


def light_radiance(light: Light) -> np.ndarray:
    """A light's colour times its intensity, linear RGB."""
    return srgb_to_linear(np.asarray(light.color, float)) * light.intensity * LIGHT_RADIANCE


def ambient_share(lights: list[Light]) -> float:
    """How bright the sky's ambient light is: that of the brightest directional light (the sun,
    or a dim moon at night), at most 1; a scene lit only by lamps keeps the full ambient."""
    sky = [light.intensity * float(srgb_to_linear(np.asarray(light.color, float)).max())
           for light in lights if light.parallel]
    return min(1.0, max(sky)) if sky else 1.0


class FrameBlocks:
    """The frame's uniform and storage buffers and the map records' texture. Owns them; the
    buffers grow in place."""

    def __init__(self, ctx, n_characters: int, n_lights: int = 1):
        self._ctx = ctx
        self.max_maps = blocks.max_maps(ctx)
        self.frame = ctx.buffer(reserve=FRAME_DTYPE.itemsize)
        self.maps = ctx.buffer(reserve=MAP_DTYPE.itemsize * self.max_maps)
        self.lights = ctx.buffer(reserve=LIGHT_DTYPE.itemsize * blocks.MAX_LIGHTS)
        self.grid = ctx.buffer(reserve=4 * 1024)
        self.models = ctx.buffer(reserve=64 * max(1, n_characters))
        self.n_lights = n_lights
        self.character_maps = ctx.buffer(reserve=4 * max(1, n_characters * n_lights))
        self.pixels = ctx.buffer(reserve=4 * self.max_maps)  # per map: pixels near its edges
        self.records = MapRecords(ctx, self.max_maps)  # the maps again, for the lookup
        self._frame_data = np.zeros(1, FRAME_DTYPE)

    def upload(self, plan: ShadowPlan, bounded: list[bool], spans: list[LightSpan],
               view: View, grids: list[MapGrid], models: np.ndarray, geom: PackedGeometry,
               lights: list[Light], settings: ShadowSettings, enabled=None) -> None:
        """Fill every block for this frame: ``bounded`` says which maps have depth bounds,
        ``spans`` and ``grids`` are each light's maps and map grid; a light not ``enabled``
        (default: all are) gives no light this frame."""
        if len(plan.maps) > self.max_maps:
            raise RuntimeError(f"{len(plan.maps)} maps exceed the uniform block ({self.max_maps})")
        n = geom.n_characters
        if len(models):
            self.models.write(transforms.gl_bytes(models))
            character_maps = np.full((len(spans), n), -1, np.int32)
            for k, span in enumerate(spans):
                for index in range(span.first_map, span.first_map + span.map_count):
                    rec = plan.maps[index]
                    if rec.kind == KIND_CHARACTER:
                        for obj in rec.objects:  # a shared map holds several
                            character_maps[k, obj - geom.first_character] = index
            self.character_maps.write(character_maps.tobytes())
        block = self._maps(plan, bounded)
        self.maps.write(block.tobytes())
        self.records.write(block)
        data, bases = join_grids(grids, spans)
        tile_base = len(data)
        tiles_x, tiles = tile_lights(lights, view, tile_base, enabled)
        data = np.concatenate([data, tiles])
        records = np.zeros(blocks.MAX_LIGHTS, LIGHT_DTYPE)
        for k, (light, span, grid) in enumerate(zip(lights, spans, grids, strict=True)):
            records[k] = _light_record(light, span, grid, bases[k], k * n,
                                       enabled is None or enabled[k])
        self.lights.write(records[:max(1, len(lights))].tobytes())
        f = self._frame_data
        f["view_proj"] = (view.proj @ view.view).T
        f["camera_pos"] = np.linalg.inv(view.view)[:3, 3]
        f["floor_count"] = geom.n_floors
        f["normal_bias"], f["depth_bias"] = settings.normal_bias, settings.depth_bias
        f["slope_bias"], f["max_slope"] = settings.slope_bias, settings.max_slope
        f["first_character"] = geom.first_character
        f["light_count"] = len(lights)
        f["ambient"] = ambient_share(lights)
        f["tile_base"], f["tile_size"], f["tiles_x"] = tile_base, TILE_PIXELS, tiles_x
        self.frame.write(f.tobytes())
        if self.grid.size < data.nbytes:
            self.grid.orphan(data.nbytes)
        self.grid.write(data.tobytes())

    def keep_visibility_of(self, light: int) -> None:
        """Make the G-buffer keep light ``light``'s visibility (the dumps' ``lit_lights``)."""
        self._frame_data["dump_light"] = light
        self.frame.write(self._frame_data.tobytes())

    @staticmethod
    def _maps(plan: ShadowPlan, bounded: list[bool]) -> np.ndarray:
        block = np.zeros(max(1, len(plan.maps)), MAP_DTYPE)
        maps = plan.maps
        if not maps:
            return block
        fresh = set(plan.render_static) | set(plan.render_dynamic)  # for the "cache" view
        fits = [rec.fit for rec in maps]
        n = len(maps)
        # Column by column: a crowd's frame has hundreds of records.
        block["view_proj"][:n] = np.stack([f.view_proj for f in fits]).transpose(0, 2, 1)
        block["layer"][:n] = [rec.layer for rec in maps]
        block["texel"][:n] = [f.texel for f in fits]
        block["uv_scale"][:n] = np.array([rec.viewport for rec in maps], float) / plan.resolution
        block["uv_offset"][:n] = np.array([rec.origin for rec in maps], float) / plan.resolution
        block["flags"][:n] = [(blocks.MAP_FRESH if i in fresh else 0)
                              | (blocks.MAP_BOUNDED if bounded[i] else 0) for i in range(n)]
        block["eye"][:n] = np.stack([f.eye for f in fits])
        block["kind"][:n] = [rec.kind for rec in maps]
        block["bounds"][:n] = np.stack([f.rect for f in fits])
        near = np.array([f.near for f in fits])
        block["near"][:n] = near
        block["inv_depth_range"][:n] = 1.0 / (np.array([f.far for f in fits]) - near)
        return block

    def bind(self) -> None:
        """Bind every block to its binding point (after the uploads: a grown buffer is bound
        as it is now)."""
        b = blocks.BINDINGS
        self.frame.bind_to_uniform_block(b["Frame"])
        self.maps.bind_to_uniform_block(b["ShadowMaps"])
        self.lights.bind_to_uniform_block(b["Lights"])
        self.grid.bind_to_storage_buffer(b["MapGrid"])
        self.models.bind_to_storage_buffer(b["Models"])
        self.character_maps.bind_to_storage_buffer(b["CharacterMaps"])

    def count_pixels(self) -> None:
        """Zero the per-map counts of pixels near shadow edges and bind them for the next draw
        (after the culler, which binds its own buffers to the same point)."""
        self._ctx.memory_barrier(moderngl.BUFFER_UPDATE_BARRIER_BIT)  # the last count's writes
        self.pixels.write(bytes(self.pixels.size))
        self.pixels.bind_to_storage_buffer(blocks.BINDINGS["MapPixels"])

    def counted_pixels(self, n_maps: int) -> np.ndarray:
        """The counts of the last counted draw's first ``n_maps`` maps."""
        if n_maps == 0:
            return np.zeros(0, np.int64)
        self._ctx.memory_barrier(moderngl.BUFFER_UPDATE_BARRIER_BIT)
        return np.frombuffer(self.pixels.read(size=4 * n_maps), np.uint32).astype(np.int64)

    def characters_changed(self, n_characters: int) -> None:
        """Characters were added or removed: the per-character buffers, resized and zeroed."""
        n = max(1, n_characters)
        for buffer, size in ((self.models, 64 * n),
                             (self.character_maps, 4 * max(1, n_characters * self.n_lights))):
            buffer.orphan(size)
            buffer.write(bytes(size))

    def gl_objects(self) -> int:
        return 8

    def release(self) -> None:
        for buffer in (self.frame, self.maps, self.lights, self.grid, self.models,
                       self.character_maps, self.pixels):
            buffer.release()
        self.records.release()


TILE_PIXELS = 16  # a screen tile's side: a multiple of the 4 x 4 pixels llvmpipe shades at once


def tile_lights(lights: list[Light], view: View, base: int, enabled=None
                ) -> tuple[int, np.ndarray]:
    """The lights that can reach each screen tile, as offsets (from ``base``, where the data
    will start in the MapGrid buffer) then lists: tiles row by row from the bottom, as
    gl_FragCoord counts them. A lamp's range is a sphere; it is listed for the tiles its
    screen rectangle meets (every tile when the sphere reaches the camera's near plane). A
    light without a range, and a directional one, is listed everywhere. With one light there
    is no list to read: (1, empty offsets)."""
    w, h = view.size
    tiles_x, tiles_y = -(-w // TILE_PIXELS), -(-h // TILE_PIXELS)
    if len(lights) == 1:
        return 1, np.full(2, base, np.int32)
    clip = view.proj @ view.view
    reaches = np.zeros((tiles_y, tiles_x, len(lights)), bool)
    for k, light in enumerate(lights):
        if enabled is not None and not enabled[k]:
            continue
        rect = _screen_rect(light, clip, w, h)
        if rect is not None:
            x0, y0, x1, y1 = (int(v) // TILE_PIXELS for v in rect)
            reaches[y0:y1 + 1, x0:x1 + 1, k] = True
    reaches = reaches.reshape(tiles_x * tiles_y, len(lights))
    counts = reaches.sum(axis=1)
    offsets = base + len(counts) + 1 + np.concatenate([[0], np.cumsum(counts)])
    lists = np.nonzero(reaches)[1]  # tile by tile, each tile's lights in file order
    return tiles_x, np.concatenate([offsets, lists]).astype(np.int32)


def _screen_rect(light: Light, clip: np.ndarray, w: int, h: int) -> tuple | None:
    """Pixels (x0, y0, x1, y1), y from the bottom, that a lamp's range sphere may cover; the
    whole screen for a light without a range; None when the sphere is off screen."""
    if light.range is None or light.position is None:
        return 0, 0, w - 1, h - 1
    r = light.range
    corners = light.position + r * np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1)
                                             for z in (-1, 1)], float)
    p = clip @ np.c_[corners, np.ones(8)].T
    if np.any(p[3] <= 1e-6):
        return 0, 0, w - 1, h - 1  # the sphere reaches the camera's plane
    ndc = p[:2] / p[3]
    if (np.all(ndc[0] < -1) or np.all(ndc[0] > 1) or np.all(ndc[1] < -1)
            or np.all(ndc[1] > 1) or np.all(p[2] > p[3])):
        return None
    x = np.clip((ndc[0] * 0.5 + 0.5) * w, 0, w - 1)
    y = np.clip((ndc[1] * 0.5 + 0.5) * h, 0, h - 1)
    return x.min(), y.min(), x.max(), y.max()


def join_grids(grids: list[MapGrid], spans: list[LightSpan]) -> tuple[np.ndarray, list[int]]:
    """Every light's map grid in one buffer, and where each starts. A grid's cell offsets
    point into its own data and its lists hold its light's map indices: both are shifted,
    except a partition's -1 (no static map in the cell), which must stay no map."""
    parts, bases, at = [], [], 0
    for grid, span in zip(grids, spans, strict=True):
        data = grid.data.astype(np.int32)
        cells = grid.size * grid.size + 1
        if at or span.first_map:
            data = data.copy()
            data[:cells] += at
            lists = data[cells:]
            lists[lists >= 0] += span.first_map
        parts.append(data)
        bases.append(at)
        at += len(data)
    return np.concatenate(parts), bases


def _light_record(light: Light, span: LightSpan, grid: MapGrid, grid_base: int,
                  first_character_map: int, enabled: bool) -> np.ndarray:
    record = np.zeros(1, LIGHT_DTYPE)
    light_rot = np.eye(4)  # directional lights only; the identity for others
    rotation = kind_of(light).rotation(light)
    if rotation is not None:
        light_rot[:3, :3] = rotation
    record["light_rot"] = light_rot.T
    record["position"] = light.position if light.position is not None else np.zeros(3)
    record["kind"] = blocks.LIGHT_KINDS[light.kind]
    record["direction"] = light.direction if light.direction is not None else np.zeros(3)
    record["cos_half_cone"] = math.cos(math.radians(light.cone / 2)) if light.cone else -1.0
    record["radiance"] = light_radiance(light) if enabled else np.zeros(3)
    if not enabled:  # switched off in the window: its maps are not read either
        span = LightSpan(span.first_map, 0, span.first_layer)
        grid = MapGrid(blocks.GRID_NONE, grid.size, grid.rect, grid.data)
    record["range"] = light.range or 0.0
    record["grid_rect"] = grid.rect
    record["grid_size"] = grid.size
    record["grid_mode"] = grid.mode
    record["grid_base"] = grid_base
    record["first_map"] = span.first_map
    record["map_count"] = span.map_count
    record["first_character_map"] = first_character_map
    return record[0]
