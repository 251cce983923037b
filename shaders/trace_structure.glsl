// The soft-shadow tracer's access to the scene: the current point's light triangle, the mailbox
// of tested triangles, triangle loads and the structure's leaves (game/soft/grid.py
// Structure.gpu_array). Part of trace.comp (needs blocks/trace.glsl, trace.glsl and
// trace_budget.glsl).

// The light triangle of the current point: its apex and the segment.
vec3 g_apex;
vec3 g_la;
vec3 g_lb;

// Mailbox: the last MAILBOX_SIZE triangles tested by the current ray (or, for analytic, point).
int g_mailbox[MAILBOX_SIZE];
int g_mailbox_next;

void mailbox_reset() {
    for (int i = 0; i < MAILBOX_SIZE; ++i) {
        g_mailbox[i] = -1;
    }
    g_mailbox_next = 0;
}

// True if the triangle was already tested; otherwise remembers it.
bool mailbox_seen(int tri) {
    for (int i = 0; i < MAILBOX_SIZE; ++i) {
        if (g_mailbox[i] == tri) {
            return true;
        }
    }
    g_mailbox[g_mailbox_next] = tri;
    g_mailbox_next = (g_mailbox_next + 1) % MAILBOX_SIZE;
    return false;
}

void load_triangle(int tri, out vec3 v0, out vec3 v1, out vec3 v2) {
    g_bytes_triangles += uint(TRIANGLE_BYTES);
    v0 = tri_vertex(tri, 0);
    v1 = tri_vertex(tri, 1);
    v2 = tri_vertex(tri, 2);
}

bool may_occlude_point(int tri) {
    g_tri_tri += 1u;
    vec3 v0, v1, v2;
    load_triangle(tri, v0, v1, v2);
    return triangles_may_meet(g_apex, g_la, g_lb, v0, v1, v2);
}

// ---- The structure (game/soft/grid.py Structure.gpu_array) ----------------------------------
// A leaf's lists (static, then the characters'): returns its n >= 0 entries and where each
// list starts; or, for a subdivided top cell (TWO_LEVEL), a negative n that sub_dims unpacks,
// with s0 its sub-grid's first leaf.
int leaf_size(int leaf, out int s0, out int d0, out int ns) {
    g_bytes_cells += 16u;
    s0 = u_static_cells[2 * leaf];
    ns = u_static_cells[2 * leaf + 1];
    d0 = u_dynamic_cells[2 * leaf];
    return ns < 0 ? ns : ns + u_dynamic_cells[2 * leaf + 1];
}

// The cells per axis of the sub-grid that a negative leaf_size stands for.
ivec3 sub_dims(int n) {
    int bits = -1 - n;
    int mask = (1 << SUB_DIMS_BITS) - 1;
    return ivec3(bits & mask, (bits >> SUB_DIMS_BITS) & mask, bits >> (2 * SUB_DIMS_BITS));
}

int leaf_tri(int k, int s0, int d0, int ns) {
    g_bytes_cells += 4u;
    return k < ns ? u_static_cells[s0 + k] : u_dynamic_cells[d0 + k - ns];
}

ivec3 unflatten(int i, ivec3 dims) {
    return ivec3(i % dims.x, (i / dims.x) % dims.y, i / (dims.x * dims.y));
}

int flatten(ivec3 c, ivec3 dims) {
    return c.x + dims.x * (c.y + dims.y * c.z);
}
