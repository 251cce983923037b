"""Every uniform and storage block, declared once as a numpy dtype with explicit std140 padding.

Keep in sync with shaders/blocks.glsl: each dtype below has its GLSL twin there, field by field.
Matrices are stored as GLSL reads them (column-major), so fill them with ``transforms.gl_bytes``
order, i.e. the transpose of our column-vector matrices.
"""

from __future__ import annotations

import numpy as np

# Keep in sync with shaders/blocks.glsl: struct ShadowMap.
MAP_DTYPE = np.dtype([
    ("view_proj", "<f4", (4, 4)),  # world -> the map's clip space (stored transposed)
    # x: layer, y: texel size (orthographic: metres; perspective: per metre of depth),
    # z: 1 for a perspective map, w: share of the layer the map's viewport uses (uv scale)
    ("params", "<f4", 4),
    ("eye", "<f4", 4),  # xyz: the map's eye; w: caster kind (0 static clump, 1 character, 2 all)
    # orthographic maps: the light-space rectangle (xmin, ymin, xmax, ymax) the map covers
    ("bounds", "<f4", 4),
    # orthographic maps: x the near plane's distance along the light, y 1 / (far - near);
    # z: 1 when the map was re-rendered this frame, 0 when it came from the cache (debug view)
    ("depth", "<f4", 4),
])
assert MAP_DTYPE.itemsize == 128

# Keep in sync with shaders/blocks.glsl: uniform block Frame.
FRAME_DTYPE = np.dtype([
    ("view_proj", "<f4", (4, 4)),  # camera: world -> clip (stored transposed)
    ("light_rot", "<f4", (4, 4)),  # directional light: world -> light-space axes (transposed)
    ("camera_pos", "<f4", 4),
    ("light_dir", "<f4", 4),  # xyz: the way the light travels; w: kind (see LIGHT_KINDS)
    ("light_pos", "<f4", 4),  # xyz: position (spot, point); w: cos of the spot's half cone
    ("bias", "<f4", 4),  # x: normal offset, y: depth bias, z: slope bias (texels); w: max slope
    ("grid_rect", "<f4", 4),  # light-space rectangle the map grid covers (xmin, ymin, xmax, ymax)
    ("counts", "<i4", 4),  # x: maps, y: grid mode (GRID_*), z: grid cells per side, w: debug view
    ("options", "<i4", 4),  # x: PCF on, y: first character object, z: objects, w: floors
])
assert FRAME_DTYPE.itemsize == 64 * 2 + 16 * 7

LIGHT_KINDS = {"directional": 0, "spot": 1, "point": 2}
GRID_NONE, GRID_ORTHO, GRID_OCTAHEDRAL = 0, 1, 2
DEBUG_NONE, DEBUG_MAP, DEBUG_MAP_COUNT, DEBUG_CACHE = 0, 1, 2, 3

# Binding points, shared by Python and shaders/blocks.glsl (passed in as #defines).
BINDINGS = {
    "FRAME_BINDING": 0,
    "MAPS_BINDING": 1,
    "GRID_BINDING": 2,
    "MODELS_BINDING": 3,
    "CHARACTER_MAPS_BINDING": 4,
}


def max_maps(ctx) -> int:
    """How many ShadowMap records fit the uniform block on this driver."""
    limit = int(ctx.info.get("GL_MAX_UNIFORM_BLOCK_SIZE", 16384))
    return min(limit // MAP_DTYPE.itemsize, 1024)

# Keep in sync with shaders/trace_blocks.glsl: uniform block TraceParams (game/tracer.py).
TRACE_DTYPE = np.dtype([
    ("grid_origin", "<f4", 4),  # xyz: the grid's lower corner
    ("grid_cell", "<f4", 4),    # xyz: cell size (metres)
    ("grid_dims", "<i4", 4),    # xyz: cells per axis; w: cells in all
    ("light_a", "<f4", 4),      # xyz: segment start; point: position; directional: to the light
    ("light_b", "<f4", 4),      # xyz: segment end
    ("offset", "<f4", 4),       # x: ray start offset (m), y: extra per metre from the origin,
                                # z: far distance of a directional light's rays
    ("counts", "<i4", 4),       # x: samples, y: triangles, z: static triangles, w: ray id base
    ("size", "<i4", 4),         # x: width, y: height, z: light mode (TRACE_LIGHT_*)
    # x: first sample of this dispatch, y: samples in it, z: 1 to add to the stored results,
    # w: 2, the trip count of the loop that detects llvmpipe's loop limit (game/tracer.py)
    ("range", "<i4", 4),
])
assert TRACE_DTYPE.itemsize == 9 * 16

# Keep in sync with shaders/trace_blocks.glsl: struct PointResult, one per pixel.
TRACE_RESULT_DTYPE = np.dtype([
    ("visibility", "<f4"),              # visible share of the light; < 0 where no geometry
    ("ray_triangle_tests", "<u4"),
    ("triangle_triangle_tests", "<u4"),
    ("voxels_visited", "<u4"),
    ("candidates", "<u4"),
    ("overflows", "<u4"),
    ("truncated", "<u4"),                # 1: the shader ran out of llvmpipe's loop budget
    ("visible", "<u4"),                  # visible samples so far (accumulated over dispatches)
])
assert TRACE_RESULT_DTYPE.itemsize == 32

TRACE_LIGHT_SEGMENT, TRACE_LIGHT_POINT, TRACE_LIGHT_DIRECTIONAL = 0, 1, 2
TRACE_BINDINGS = {
    "TRACE_PARAMS_BINDING": 5,
    "TRIANGLES_BINDING": 6,
    "STATIC_CELLS_BINDING": 7,
    "DYNAMIC_CELLS_BINDING": 8,
    "TRI_STATE_BINDING": 9,
    "RESULTS_BINDING": 10,
}

# The camera pass's triangle culling (game/triangle_cull.py, shaders/cull.comp).
CULL_BINDINGS = {
    "CULL_CORNERS_BINDING": 11,
    "CULL_INDICES_BINDING": 12,
    "CULL_CHUNKS_BINDING": 13,
    "CULL_OUTPUT_BINDING": 14,
    "CULL_COMMANDS_BINDING": 15,
}
