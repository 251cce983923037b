"""The blocks every pass of a frame reads, filled from the frame's plan and view.

The uniform blocks Frame and ShadowMaps and the storage buffers MapGrid, Models and
CharacterMaps (declared in game/gpu/blocks.py) are written once per frame and bound once; the
shadow-map pass, the culling pass, the shading pass and the soft composite all read them.
"""

from __future__ import annotations

import math

import numpy as np

from game import transforms
from game.gpu import blocks
from game.gpu.blocks import FRAME_DTYPE, MAP_DTYPE
from game.render.frame import View
from game.scene.geometry import PackedGeometry
from game.scene.model import Light
from game.shadows.fit import light_rotation_of
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
    """The #defines every shader of the frame is built with."""
    d = {"MAX_MAPS": blocks.max_maps(ctx), "GRID_NONE": blocks.GRID_NONE,
         "GRID_ORTHO": blocks.GRID_ORTHO, "GRID_OCTAHEDRAL": blocks.GRID_OCTAHEDRAL,
         "KIND_CASCADE": KIND_CASCADE, "KIND_CLUMP": KIND_CLUMP, "KIND_FALLBACK": KIND_FALLBACK,
         "KIND_CHARACTER": KIND_CHARACTER, "KIND_ALL": KIND_ALL}
    d.update({f"DEBUG_{name.upper().replace('-', '_')}": value
              for name, value in blocks.DEBUG_VIEWS.items() if name != "none"})
    d.update({f"LIGHT_{kind.upper()}": value for kind, value in blocks.LIGHT_KINDS.items()})
    return d


class FrameBlocks:
    """The frame's uniform and storage buffers. Owns them; they grow in place."""

    def __init__(self, ctx, n_characters: int):
        self.max_maps = blocks.max_maps(ctx)
        self.frame = ctx.buffer(reserve=FRAME_DTYPE.itemsize)
        self.maps = ctx.buffer(reserve=MAP_DTYPE.itemsize * self.max_maps)
        self.grid = ctx.buffer(reserve=4 * 1024)
        self.models = ctx.buffer(reserve=64 * max(1, n_characters))
        self.character_maps = ctx.buffer(reserve=4 * max(1, n_characters))

    def upload(self, plan: ShadowPlan, view: View, grid: MapGrid, models: np.ndarray,
               geom: PackedGeometry, light: Light, settings: ShadowSettings) -> None:
        """Fill every block for this frame."""
        if len(plan.maps) > self.max_maps:
            raise RuntimeError(f"{len(plan.maps)} maps exceed the uniform block ({self.max_maps})")
        if len(models):
            self.models.write(transforms.gl_bytes(models))
            character_maps = np.full(geom.n_characters, -1, np.int32)
            for index, rec in enumerate(plan.maps):
                if rec.kind == KIND_CHARACTER:
                    for obj in rec.objects:  # a shared map holds several
                        character_maps[obj - geom.first_character] = index
            self.character_maps.write(character_maps.tobytes())
        self.maps.write(self._maps(plan).tobytes())
        self.frame.write(self._frame(view, len(plan.maps), grid, geom, light, settings).tobytes())
        data = grid.data.astype(np.int32)
        if self.grid.size < data.nbytes:
            self.grid.orphan(data.nbytes)
        self.grid.write(data.tobytes())

    @staticmethod
    def _maps(plan: ShadowPlan) -> np.ndarray:
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
        block["fresh"][:n] = [i in fresh for i in range(n)]
        block["eye"][:n] = np.stack([f.eye for f in fits])
        block["kind"][:n] = [rec.kind for rec in maps]
        block["bounds"][:n] = np.stack([f.rect for f in fits])
        near = np.array([f.near for f in fits])
        block["near"][:n] = near
        block["inv_depth_range"][:n] = 1.0 / (np.array([f.far for f in fits]) - near)
        return block

    def _frame(self, view: View, n_maps: int, grid: MapGrid, geom: PackedGeometry,
               light: Light, s: ShadowSettings) -> np.ndarray:
        light_rot = np.eye(4)  # directional lights only; the identity for others
        rotation = light_rotation_of(light)
        if rotation is not None:
            light_rot[:3, :3] = rotation
        f = np.zeros(1, FRAME_DTYPE)
        f["view_proj"] = (view.proj @ view.view).T
        f["light_rot"] = light_rot.T
        f["camera_pos"] = np.linalg.inv(view.view)[:3, 3]
        f["map_count"] = n_maps
        f["light_dir"] = light.direction if light.direction is not None else np.zeros(3)
        f["floor_count"] = geom.n_floors
        f["light_pos"] = light.position if light.position is not None else np.zeros(3)
        f["cos_half_cone"] = math.cos(math.radians(light.cone / 2)) if light.cone else -1.0
        f["normal_bias"], f["depth_bias"] = s.normal_bias, s.depth_bias
        f["slope_bias"], f["max_slope"] = s.slope_bias, s.max_slope
        f["grid_rect"] = grid.rect
        f["first_character"] = geom.first_character
        f["grid_size"] = grid.size
        return f

    def bind(self) -> None:
        """Bind every block to its binding point (after the uploads: a grown buffer is bound
        as it is now)."""
        b = blocks.BINDINGS
        self.frame.bind_to_uniform_block(b["Frame"])
        self.maps.bind_to_uniform_block(b["ShadowMaps"])
        self.grid.bind_to_storage_buffer(b["MapGrid"])
        self.models.bind_to_storage_buffer(b["Models"])
        self.character_maps.bind_to_storage_buffer(b["CharacterMaps"])

    def characters_changed(self, n_characters: int) -> None:
        """Characters were added or removed: the per-character buffers, resized and zeroed."""
        n = max(1, n_characters)
        for buffer, size in ((self.models, 64 * n), (self.character_maps, 4 * n)):
            buffer.orphan(size)
            buffer.write(bytes(size))

    def gl_objects(self) -> int:
        return 5

    def release(self) -> None:
        for buffer in (self.frame, self.maps, self.grid, self.models, self.character_maps):
            buffer.release()
