// The soft-shadow tracer's blocks. Keep in sync with game/gpu_blocks.py (TRACE_DTYPE,
// TRACE_RESULT_DTYPE, TRACE_BINDINGS); binding points arrive as #defines from Python.

layout(std140, binding = TRACE_PARAMS_BINDING) uniform TraceParams {  // gpu_blocks.TRACE_DTYPE
    vec4 u_grid_origin;  // xyz lower corner
    vec4 u_grid_cell;    // xyz cell size
    ivec4 u_grid_dims;   // xyz cells per axis, w cells in all
    vec4 u_light_a;      // segment start; point light: position; directional: unit dir to light
    vec4 u_light_b;      // segment end
    vec4 u_offset;       // x ray start offset (m), y per metre from the origin, z directional far
    ivec4 u_counts;      // x samples, y triangles, z static triangles, w ray id base
    ivec4 u_size;        // x width, y height, z light mode (TRACE_LIGHT_*)
    ivec4 u_range;       // x first sample, y samples in this dispatch, z accumulate, w 2
};

// Three vec4 per triangle (xyz used), world space: statics first, then the posed characters.
layout(std430, binding = TRIANGLES_BINDING) readonly buffer Triangles {
    vec4 u_tri[];
};

// Cell lists in CSR form (game/trace_grid.py CellLists.gpu_array): entries 0..cells are
// offsets into this same array; the triangle ids of cell c are [cells[c], cells[c + 1]).
layout(std430, binding = STATIC_CELLS_BINDING) readonly buffer StaticCells {
    int u_static_cells[];
};
layout(std430, binding = DYNAMIC_CELLS_BINDING) readonly buffer DynamicCells {
    int u_dynamic_cells[];
};

// tri-cache: per triangle (ray id << 1) | flag, flag 1 = cannot occlude for that shaded point.
layout(std430, binding = TRI_STATE_BINDING) coherent buffer TriState {
    uint u_tri_state[];
};

struct PointResult {     // keep in sync with gpu_blocks.TRACE_RESULT_DTYPE
    float visibility;    // < 0: no geometry under the pixel
    uint ray_triangle_tests;
    uint triangle_triangle_tests;
    uint voxels_visited;
    uint candidates;
    uint overflows;
    uint truncated;      // 1: the loop budget of llvmpipe ran out (see trace.comp)
    uint visible;        // visible samples so far
};

layout(std430, binding = RESULTS_BINDING) buffer Results {
    PointResult u_results[];
};
