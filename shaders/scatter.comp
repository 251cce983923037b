#version 430
// The characters' leaf table of the soft-shadow pass: sets the (start, count) pairs of the
// leaves they touch this frame and clears those they left (game/soft/tracer.py), so that a
// frame rewrites what the characters moved through, not every leaf of the structure.
// Entry e is three ints at u_dynamic_cells[u_first + 3 e]: leaf, start, count.
#include "blocks/trace.glsl"

layout(local_size_x = 64) in;

uniform int u_first;
uniform int u_count;

void main() {
    int e = int(gl_GlobalInvocationID.x);
    if (e < u_count) {
        int at = u_first + 3 * e;
        int leaf = u_dynamic_cells[at];
        u_dynamic_cells[2 * leaf] = u_dynamic_cells[at + 1];
        u_dynamic_cells[2 * leaf + 1] = u_dynamic_cells[at + 2];
    }
}
