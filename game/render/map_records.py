"""The map records as the shading pass's lookup reads them: one row of RGBA32F texels per map.

The same records are in the ShadowMaps uniform block, which the map passes read at the draw's
or the vertex's map. The lookup reads them at the map each fragment found in its grid cell,
which differs from lane to lane, and llvmpipe reads a uniform-block member at a per-lane index
one float and one lane at a time, thirteen times per orthographic map considered. A texel
fetch reads four floats per lane at once, so the lookup fetches two texels per map, then the
rectangle (orthographic) or the matrix (perspective) it needs (shaders/shadow.glsl;
docs/design/shading-variants.md). A program for several lights runs both samplers for every
map, and there those two reads cost less from the block, so it reads them there.

:class:`MapRecords` owns its texture; its owner, the frame's blocks, releases it.
"""

from __future__ import annotations

import moderngl
import numpy as np

from game.gpu import blocks

# Texel columns of a map's row; keep in sync with shaders/shadow.glsl (as #defines).
RECORD_BOUNDS = 0      # orthographic: the light-space rectangle
RECORD_DEPTH = 1       # near, 1 / (far - near), texel, uv_scale
RECORD_LAYER = 2       # uv_offset, layer, kind * RECORD_FLAG_CODES + flags
RECORD_VIEW_PROJ = 3   # perspective: the four columns of world -> clip
RECORD_TEXELS = RECORD_VIEW_PROJ + 4
RECORD_FLAG_CODES = 4  # flags are MAP_FRESH | MAP_BOUNDED, below 4
assert blocks.MAP_FRESH | blocks.MAP_BOUNDED < RECORD_FLAG_CODES

RECORD_DEFINES = {"RECORD_BOUNDS": RECORD_BOUNDS, "RECORD_DEPTH": RECORD_DEPTH,
                  "RECORD_LAYER": RECORD_LAYER, "RECORD_VIEW_PROJ": RECORD_VIEW_PROJ,
                  "RECORD_FLAG_CODES": RECORD_FLAG_CODES}


def record_rows(block: np.ndarray) -> np.ndarray:
    """(n, RECORD_TEXELS, 4) float32 rows of the ShadowMaps block's records ``block``. Ints are
    stored as floats, exact below 2^24."""
    rows = np.zeros((len(block), RECORD_TEXELS, 4), np.float32)
    rows[:, RECORD_BOUNDS] = block["bounds"]
    rows[:, RECORD_DEPTH] = np.stack([block["near"], block["inv_depth_range"], block["texel"],
                                      block["uv_scale"]], axis=1)
    rows[:, RECORD_LAYER, :2] = block["uv_offset"]
    rows[:, RECORD_LAYER, 2] = block["layer"]
    rows[:, RECORD_LAYER, 3] = block["kind"] * RECORD_FLAG_CODES + block["flags"]
    # The block holds each matrix as GL reads it, column by column.
    rows[:, RECORD_VIEW_PROJ:] = block["view_proj"]
    return rows


class MapRecords:
    """A (RECORD_TEXELS x ``max_maps``) RGBA32F texture, written each frame."""

    def __init__(self, ctx, max_maps: int):
        self.texture = ctx.texture((RECORD_TEXELS, max_maps), 4, dtype="f4")
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)  # read with texelFetch

    def write(self, block: np.ndarray) -> None:
        rows = record_rows(block)
        self.texture.write(rows.tobytes(), viewport=(0, 0, RECORD_TEXELS, len(rows)))

    def bind(self, unit: int) -> None:
        self.texture.use(unit)

    def release(self) -> None:
        self.texture.release()
