"""Every uniform and storage block the shaders read, declared once, here.

Each block's data is a numpy structured dtype with named fields and explicit std140 (uniform)
or std430 (storage) padding. Its GLSL declaration is generated from that dtype by this module,
which checks every field's offset against the layout rules as it goes, and reaches the shaders
as a generated include: ``#include "blocks/frame.glsl"`` (see :data:`GENERATED`). No shader
declares a block by hand. The binding points and texture units are the tables
:data:`BINDINGS` and :data:`TEXTURE_UNITS`.

Matrices are stored as GLSL reads them (column-major): fill them with the transpose of our
column-vector matrices (``transforms.gl_bytes`` order). Fields whose names start with ``_pad``
are padding and have no GLSL twin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# -- constants the shaders share ------------------------------------------------------------------

LIGHT_KINDS = {"directional": 0, "spot": 1, "point": 2}
# GRID_TILES: an orthographic grid aligned to a partition of tiles; a cell's list starts with its
# tile's map where that tile's casters reach the cell, the one static map that can shadow it
# (shaders/shadow.glsl).
GRID_NONE, GRID_ORTHO, GRID_OCTAHEDRAL, GRID_TILES = 0, 1, 2, 3
DEBUG_VIEWS = {"none": 0, "map": 1, "map-count": 2, "cache": 3, "shadowed-lights": 4}
TRACE_LIGHT_SEGMENT, TRACE_LIGHT_POINT, TRACE_LIGHT_DIRECTIONAL = 0, 1, 2

# Binding points of every block. Uniform and storage blocks are numbered apart, as GL numbers
# them, and each kind stays below the GL 4.3 minimum of its binding points (36 uniform, 8
# storage). The frame's storage buffers keep 0-2 for the whole frame; the tracer's and the
# culler's take 3-7 in turn, each binding its own before it dispatches, and the shading pass's
# pixel counts take 3 while it draws.
UNIFORM_BINDINGS = {"Frame": 0, "ShadowMaps": 1, "TraceParams": 2, "CullParams": 3,
                    "Lights": 4}
STORAGE_BINDINGS = {
    "MapGrid": 0, "Models": 1, "CharacterMaps": 2,
    "Triangles": 3, "StaticCells": 4, "DynamicCells": 5, "TriState": 6, "Results": 7,
    "Corners": 3, "Indices": 4, "Chunks": 5, "Culled": 6, "Commands": 7,
    "MapPixels": 3,
}
BINDINGS = {**UNIFORM_BINDINGS, **STORAGE_BINDINGS}
MIN_GL_BINDINGS = {"uniform": 36, "buffer": 8}  # GL_MAX_*_BUFFER_BINDINGS of any GL 4.3

# Texture units. Passes that never run together may share a unit.
TEXTURE_UNITS = {
    "shadow_maps": 0,        # the depth array (shading pass)
    "shadow_bounds": 11,     # its cached maps' depth bounds (shading pass)
    "map_records": 15,       # the map records as the lookup reads them (game/render/map_records.py)
    "trace_position": 1,     # the G-buffer, read by the tracer and the soft composite
    "trace_normal": 2,
    "trace_colour": 3,
    "soft_visibility": 4,    # the traced visibility (soft composite)
    "composite_shading": 5,  # the G-buffer's shading normal and base colour (soft composite)
    "composite_albedo": 6,
    "upsample_samples": 7,   # the reduced soft trace, one texel per block: position and
    "upsample_sample_normals": 8,  # visibility, normal, and where the samples agree
    "upsample_agreed": 9,
    "upsample_accumulated": 10,  # its per-pixel mean while nothing moves (game/soft/upsample.py)
    "soft_maps": 0,          # the raster soft methods' depth array, compared (game/soft/raster.py)
    "soft_maps_depth": 4,    # the same array read as depth (pcss's blocker search)
    # The window's raster soft shadows (game/soft/direct.py): each block's value and the points'
    # visibility (shading pass and composite); the lean G-buffer (composite), on the full one's
    # units, which a program reads one or the other of.
    "soft_blocks": 12,
    "soft_points": 13,
    "soft_history": 14,      # the visibility a still view keeps (game/soft/still_lookups.py)
    "lean_depth": 1,
    "lean_normal": 2,
    "lean_light": 5,
    "layer_view": 0,         # the overlay's layer viewer reads the depth array
    "present_frame": 0,      # the window's picture of the frame
}

# -- the blocks' data ------------------------------------------------------------------------------

# A map record's flags: drawn this frame, not taken from the cache (the "cache" debug view);
# its depth bounds are made (game/gpu/depth_bounds.py).
MAP_FRESH, MAP_BOUNDED = 1, 2

# One shadow map (struct ShadowMap, an element of the ShadowMaps uniform block).
MAP_DTYPE = np.dtype([
    ("view_proj", "<f4", (4, 4)),  # world -> the map's clip space
    ("layer", "<i4"),              # layer of the depth array
    ("texel", "<f4"),              # orthographic: metres per texel; perspective: per metre of depth
    ("uv_scale", "<f4"),           # share of its layer's side the map's square takes
    ("flags", "<i4"),              # MAP_FRESH | MAP_BOUNDED
    ("eye", "<f4", 3),             # the map's eye (perspective maps)
    ("kind", "<i4"),               # what it holds: KIND_* of game/shadows/plan.py
    ("bounds", "<f4", 4),          # orthographic: light-space rectangle (xmin, ymin, xmax, ymax)
    ("near", "<f4"),               # orthographic: the near plane's distance along the light
    ("inv_depth_range", "<f4"),    # orthographic: 1 / (far - near)
    ("uv_offset", "<f4", 2),       # where in its layer the map's square starts (uv)
])
assert MAP_DTYPE.itemsize == 128

# What the whole frame shares (uniform block Frame). The lights are in the Lights block.
FRAME_DTYPE = np.dtype([
    ("view_proj", "<f4", (4, 4)),  # camera: world -> clip
    ("camera_pos", "<f4", 3),
    ("floor_count", "<i4"),        # objects below this index are floors
    ("normal_bias", "<f4"),        # texels, times sin(angle to the light)
    ("depth_bias", "<f4"),         # texels
    ("slope_bias", "<f4"),         # texels, times tan(angle to the light)
    ("max_slope", "<f4"),          # cap on that tan
    ("first_character", "<i4"),    # object index of the first character
    ("light_count", "<i4"),        # records in the Lights block
    ("dump_light", "<i4"),         # the light whose visibility the G-buffer keeps
    ("ambient", "<f4"),            # the sky's share of the ambient light
    ("tile_base", "<i4"),          # where the screen tiles' light lists start in MapGrid
    ("tile_size", "<i4"),          # pixels per side of a tile
    ("tiles_x", "<i4"),            # tiles per row
    ("_pad0", "<i4"),
])
assert FRAME_DTYPE.itemsize == 128

# One hard-shadow light of many (struct LightRecord, an element of the Lights uniform block):
# where its maps are, and how its map grid is read.
LIGHT_DTYPE = np.dtype([
    ("light_rot", "<f4", (4, 4)),  # directional: world -> light-space axes
    ("position", "<f4", 3),        # spot and point
    ("kind", "<i4"),               # LIGHT_KINDS
    ("direction", "<f4", 3),       # directional and spot: the way the light travels
    ("cos_half_cone", "<f4"),      # spot; -1 otherwise
    ("radiance", "<f4", 3),        # colour times intensity, linear RGB
    ("range", "<f4"),              # metres; 0: unlimited
    ("grid_rect", "<f4", 4),       # light-space rectangle its map grid covers
    ("grid_size", "<i4"),          # its map grid's cells per side
    ("grid_mode", "<i4"),          # GRID_*
    ("grid_base", "<i4"),          # where its grid starts in the MapGrid buffer
    ("first_map", "<i4"),          # its maps: u_maps[first_map, first_map + map_count)
    ("map_count", "<i4"),
    ("first_character_map", "<i4"),  # its entries of the CharacterMaps buffer
    ("_pad0", "<i4", 2),
])
assert LIGHT_DTYPE.itemsize == 160
MAX_LIGHTS = 64  # light records in the Lights block (the scene loader's limit)

# The soft-shadow tracer's parameters (uniform block TraceParams).
TRACE_DTYPE = np.dtype([
    ("grid_origin", "<f4", 3),     # the (top) grid's lower corner
    ("_pad0", "<f4"),
    ("grid_cell", "<f4", 3),       # top cell size along each axis, metres
    ("_pad1", "<f4"),
    ("grid_dims", "<i4", 3),       # top cells per axis
    ("_pad2", "<i4"),
    ("light_a", "<f4", 3),         # segment start; point light: position; directional: to the light
    ("_pad3", "<f4"),
    ("light_b", "<f4", 3),         # segment end
    ("light_mode", "<i4"),         # TRACE_LIGHT_*
    ("ray_offset", "<f4"),         # ray start offset along the normal, metres ...
    ("ray_offset_per_metre", "<f4"),  # ... plus this much per metre from the origin
    ("directional_far", "<f4"),    # length of a directional light's rays
    ("samples", "<i4"),            # samples per shaded point
    ("triangles", "<i4"),          # triangles in all: statics, then the posed characters
    ("ray_id_base", "<i4"),        # tri-cache: ray id of pixel 0
    ("width", "<i4"),              # G-buffer size
    ("height", "<i4"),
    ("round_index", "<i4"),        # 0: the first dispatch of a trace; later: resume the cursors
    ("step_budget", "<i4"),        # loop iterations a point may take per dispatch
    ("loop_probe_trips", "<i4"),   # 2: the loop that detects llvmpipe's loop limit
    ("_pad4", "<i4"),
])
assert TRACE_DTYPE.itemsize == 128

# One shaded point's result and where its work resumes (struct PointResult, an element of the
# Results buffer). The record after the points (index width * height) holds totals of a
# dispatch: the points it left pending and those it truncated.
TRACE_RESULT_DTYPE = np.dtype([
    ("visibility", "<f4"),              # visible share of the light; < 0 where no geometry
    ("ray_triangle_tests", "<u4"),
    ("triangle_triangle_tests", "<u4"),
    ("voxels_visited", "<u4"),
    ("candidates", "<u4"),
    ("overflows", "<u4"),
    ("truncated", "<u4"),               # 1: the shader ran out of llvmpipe's loop budget
    ("visible", "<u4"),                 # visible samples so far (accumulated over dispatches)
    ("bytes_triangles", "<u4", 2),      # bytes read from Triangles, (low, high) 32-bit words
    ("bytes_cells", "<u4", 2),          # bytes read from the structure's tables and lists
    ("bytes_candidates", "<u4", 2),     # bytes of candidate state read and written
    ("dispatches", "<u4"),              # dispatches this point had work in
    ("pending", "<u4"),                 # 1: work is left for the next dispatch
    ("at_sample", "<i4"),               # the cursor: the sample where the work resumes,
    ("at_top", "<i4"),                  # its top cell (analytic: enumeration index), -1: start
    ("at_sub", "<i4"),                  # its sub-cell (analytic: enumeration index), -1: start
    ("at_ref", "<i4"),                  # the entry of the leaf's list (brute: the triangle)
    ("near_hit", "<f4"),                # analytic, collinear point: nearest hit so far
    ("intervals", "<i4"),               # analytic: hidden intervals kept in kept_intervals
    ("_pad0", "<i4", 2),
    ("kept_intervals", "<f4", (4, 4)),  # analytic: up to 8 (l, r), two per column
])
assert TRACE_RESULT_DTYPE.itemsize == 160

# The camera pass's triangle culling (uniform block CullParams).
CULL_DTYPE = np.dtype([
    ("closed_triangles", "<i4"),   # closed volumes come first in the index buffer ...
    ("triangles", "<i4"),          # ... then open meshes
    ("closed_chunks", "<i4"),      # chunks of 32 triangles that hold closed volumes
    ("chunks", "<i4"),
    ("keep_closed", "<i4", 2),     # [first, end) triangles always kept: the characters among
    ("keep_open", "<i4", 2),       # the closed volumes, and among the open meshes
    ("viewport", "<f4", 2),        # pixels
    ("_pad0", "<f4", 2),
])
assert CULL_DTYPE.itemsize == 48

# One chunk of 32 triangles (struct Chunk, an element of the Chunks buffer).
CHUNK_DTYPE = np.dtype([
    ("mask", "<u4"),               # bit i: triangle i of the chunk is kept
    ("first", "<u4"),              # its first slot in the output, in triangles
])
assert CHUNK_DTYPE.itemsize == 8

# glDrawElementsIndirect's command (struct DrawCommand, an element of the Commands buffer).
DRAW_COMMAND_DTYPE = np.dtype([
    ("count", "<u4"), ("instances", "<u4"), ("first_index", "<u4"), ("base_vertex", "<u4"),
    ("base_instance", "<u4"),
])
assert DRAW_COMMAND_DTYPE.itemsize == 20


# -- GLSL from the dtypes --------------------------------------------------------------------------

# A dtype's kind -> its GLSL scalar type and vector prefix.
_VECTORS = {"f": ("float", "vec"), "i": ("int", "ivec"), "u": ("uint", "uvec")}


def glsl_type(dtype: np.dtype) -> tuple[str, int, int]:
    """The GLSL type of one field's dtype, its base alignment and its size (both layouts)."""
    base, shape = (dtype.subdtype if dtype.subdtype is not None else (dtype, ()))
    if base.itemsize != 4 or base.kind not in _VECTORS or base.byteorder == ">":
        raise TypeError(f"no GLSL type for {dtype}")
    scalar, vector = _VECTORS[base.kind]
    if shape == ():
        return scalar, 4, 4
    if len(shape) == 1 and 2 <= shape[0] <= 4:
        n = shape[0]
        return f"{vector}{n}", (8 if n == 2 else 16), 4 * n
    if shape == (4, 4) and base.kind == "f":
        return "mat4", 16, 64
    raise TypeError(f"no GLSL type for {dtype}")


def _round_up(value: int, alignment: int) -> int:
    return (value + alignment - 1) // alignment * alignment


def glsl_members(dtype: np.dtype, layout: str, indent: str = "    ") -> str:
    """The GLSL member declarations of ``dtype``, one per line, after checking that each field's
    offset is where ``layout`` (``"std140"`` or ``"std430"``) puts it, and the size too."""
    lines, offset, alignment = [], 0, 4
    for name in dtype.names:
        field, at = dtype.fields[name][:2]
        if name.startswith("_pad"):
            continue  # GLSL has no member here: the layout rules must leave the same gap
        glsl, align, size = glsl_type(field)
        expected = _round_up(offset, align)
        if at != expected:
            raise AssertionError(f"{name}: at byte {at}, but {layout} puts it at {expected}")
        lines.append(f"{indent}{glsl} {name};")
        offset, alignment = at + size, max(alignment, align)
    if layout == "std140":
        alignment = max(alignment, 16)  # std140 rounds a struct's alignment up to a vec4's
    if dtype.itemsize != _round_up(offset, alignment):
        raise AssertionError(f"{dtype.itemsize} bytes, but {layout} makes it "
                             f"{_round_up(offset, alignment)}")
    return "\n".join(lines)


@dataclass(frozen=True)
class Struct:
    """A GLSL struct made from a dtype (the element of an array in a block)."""

    name: str
    dtype: np.dtype
    layout: str

    def glsl(self) -> str:
        return f"struct {self.name} {{\n{glsl_members(self.dtype, self.layout)}\n}};"


@dataclass(frozen=True)
class Block:
    """One uniform or storage block.

    Either ``dtype`` gives its members (read as ``instance.member``), or ``array`` gives one
    array member: (element type, member name, length; ``""`` for a runtime-sized array).
    """

    kind: str                      # "uniform" or "buffer"
    name: str
    dtype: np.dtype | None = None
    instance: str = ""
    array: tuple[str, str, str] | None = None
    access: str = ""               # storage blocks: "readonly", "writeonly", "coherent" or ""

    @property
    def layout(self) -> str:
        return "std140" if self.kind == "uniform" else "std430"

    @property
    def binding(self) -> int:
        return BINDINGS[self.name]

    def glsl(self) -> str:
        qualifiers = f"layout({self.layout}, binding = {self.binding})"
        head = " ".join(x for x in (qualifiers, self.access, self.kind, self.name) if x)
        if self.array is not None:
            element, member, length = self.array
            return f"{head} {{\n    {element} {member}[{length}];\n}};"
        return f"{head} {{\n{glsl_members(self.dtype, self.layout)}\n}} {self.instance};"


# The generated includes: the blocks each family of shaders reads, in declaration order.
# MAX_MAPS (the length of the ShadowMaps array) arrives as a #define (see :func:`max_maps`).
GROUPS: dict[str, list[Struct | Block]] = {
    "blocks/frame.glsl": [
        Block("uniform", "Frame", FRAME_DTYPE, instance="u_frame"),
        Struct("ShadowMap", MAP_DTYPE, "std140"),
        Block("uniform", "ShadowMaps", array=("ShadowMap", "u_maps", "MAX_MAPS")),
        Struct("LightRecord", LIGHT_DTYPE, "std140"),
        Block("uniform", "Lights", array=("LightRecord", "u_lights", "MAX_LIGHTS")),
        # Light-space grid of map lists: u_grid[0 .. n*n] are offsets into the same array,
        # where the map indices of each cell follow (game/shadows/map_grid.py); every light's
        # grid in turn, then the screen tiles' light lists in the same form
        # (game/render/frame_blocks.py).
        Block("buffer", "MapGrid", array=("int", "u_grid", ""), access="readonly"),
        # Model matrices of the characters, indexed by object - u_frame.first_character.
        Block("buffer", "Models", array=("mat4", "u_models", ""), access="readonly"),
        # Per light, then per character, the index of its map in u_maps this frame (-1: none).
        Block("buffer", "CharacterMaps", array=("int", "u_character_maps", ""),
              access="readonly"),
    ],
    # Per map of the frame, the pixels that read it within a texel of its shadow edges
    # (shaders/shadow.glsl; view-sized maps are sized by them in the frames after:
    # game/shadows/view_budget.py). Zeroed before each counted draw.
    "blocks/map_pixels.glsl": [
        Block("buffer", "MapPixels", array=("uint", "u_map_pixels", "")),
    ],
    "blocks/trace.glsl": [
        Block("uniform", "TraceParams", TRACE_DTYPE, instance="u_trace"),
        # Three vec4 per triangle (xyz used), world space: statics, then the posed characters.
        Block("buffer", "Triangles", array=("vec4", "u_tri", ""), access="readonly"),
        # The leaves' triangle lists (game/soft/grid.py): a (start, count) pair per leaf, then
        # the ids; a start is a position in the same array. The statics' from
        # Structure.gpu_array; the characters' are written each frame (game/soft/tracer.py),
        # their pairs by shaders/scatter.comp from entries after the ids.
        Block("buffer", "StaticCells", array=("int", "u_static_cells", ""), access="readonly"),
        Block("buffer", "DynamicCells", array=("int", "u_dynamic_cells", "")),
        # tri-cache: per triangle (ray id << 1) | flag, flag 1 = cannot occlude for that point.
        Block("buffer", "TriState", array=("uint", "u_tri_state", ""), access="coherent"),
        Struct("PointResult", TRACE_RESULT_DTYPE, "std430"),
        Block("buffer", "Results", array=("PointResult", "u_results", "")),
    ],
    "blocks/cull.glsl": [
        Block("uniform", "CullParams", CULL_DTYPE, instance="u_cull"),
        # Each triangle's three corners (world space, nine floats), in index-buffer order.
        Block("buffer", "Corners", array=("float", "u_corners", ""), access="readonly"),
        Block("buffer", "Indices", array=("uint", "u_indices", ""), access="readonly"),
        Struct("Chunk", CHUNK_DTYPE, "std430"),
        Block("buffer", "Chunks", array=("Chunk", "u_chunks", "")),
        Block("buffer", "Culled", array=("uint", "u_culled", ""), access="writeonly"),
        Struct("DrawCommand", DRAW_COMMAND_DTYPE, "std430"),
        # Two commands: the closed volumes (back faces culled), then the open meshes.
        Block("buffer", "Commands", array=("DrawCommand", "u_commands", "2"),
              access="writeonly"),
    ],
}


def _generate(name: str, items: list[Struct | Block]) -> str:
    head = f"// {name}: generated by game/gpu/blocks.py from its numpy dtypes; do not edit."
    return "\n".join([head, *(item.glsl() for item in items)]) + "\n"


GENERATED = {name: _generate(name, items) for name, items in GROUPS.items()}


def max_maps(ctx) -> int:
    """How many ShadowMap records fit the uniform block on this driver."""
    limit = int(ctx.info.get("GL_MAX_UNIFORM_BLOCK_SIZE", 16384))
    return min(limit // MAP_DTYPE.itemsize, 1024)
