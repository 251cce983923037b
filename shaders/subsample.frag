#version 430
// The reduced soft trace's G-buffer: one full-resolution G-buffer pixel per block of
// u_divisor x u_divisor pixels, copied as it is (no averaging: a traced point must lie on a
// surface the frame shows). Drawn into a target of u_cells pixels, one per block.
//
// Low-resolution pixel (x, y) holds block ((x + u_shift) mod u_cells.x, y): a shift gives each
// block another pixel index in the trace, hence other sample jitters (trace.glsl seeds them by
// the index), so that rounds of accumulation add new samples instead of repeating old ones.

uniform sampler2D u_position;   // full resolution: xyz world position; w object index
uniform sampler2D u_normal;     // xyz geometric unit normal facing the camera
uniform sampler2D u_colour;     // a > 0 where geometry covers the pixel
uniform int u_divisor;          // block side, pixels
uniform ivec2 u_phase;          // the pixel of each block that is traced, from its corner
uniform int u_shift;            // block columns the low-resolution pixels are shifted by
uniform ivec2 u_cells;          // the low-resolution size: blocks per row and column

layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out vec4 out_colour;
layout(location = 3) out vec4 out_filter_normal;   // the normal again, n * 0.5 + 0.5 in 8 bits

void main() {
    ivec2 cell = ivec2(gl_FragCoord.xy);
    cell.x += u_shift;   // 0 <= u_shift < u_cells.x
    cell.x -= cell.x >= u_cells.x ? u_cells.x : 0;
    ivec2 px = cell * u_divisor + u_phase;
    if (any(greaterThanEqual(px, textureSize(u_colour, 0)))) {
        // A block cut by the frame's edge whose phase pixel lies outside: nothing to trace.
        out_position = vec4(0.0);
        out_normal = vec4(0.0, 0.0, 1.0, 0.0);
        out_colour = vec4(0.0);
        out_filter_normal = vec4(0.5, 0.5, 1.0, 0.0);
        return;
    }
    out_position = texelFetch(u_position, px, 0);
    out_normal = texelFetch(u_normal, px, 0);
    out_colour = texelFetch(u_colour, px, 0);
    out_filter_normal = vec4(out_normal.xyz * 0.5 + 0.5, 0.0);
}
