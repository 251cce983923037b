// The leaf walk of METHOD_TRI_CACHE: a ray tests only the leaf's triangles that may meet the
// point's light triangle, remembered per triangle. Part of trace.comp (needs
// trace_leaf_list.glsl).
#if METHOD == METHOD_TRI_CACHE
uint g_ray_id;

// The per-triangle scheme that "Some Ideas on Shadow Algorithms" cites as [643]: a ray id and a
// flag per triangle. They share one 32-bit word, so a word another invocation overwrote only
// costs a repeated test, never a wrong flag.
bool tri_cache_may_occlude(int tri) {
    g_bytes_candidates += 4u;
    uint state = u_tri_state[tri];
    if ((state >> 1u) == g_ray_id) {
        return (state & 1u) == 0u;
    }
    bool may = may_occlude_point(tri);
    g_bytes_candidates += 4u;
    u_tri_state[tri] = (g_ray_id << 1u) | (may ? 0u : 1u);
    return may;
}

int leaf_walk(Ray r, int leaf, int s0, int d0, int ns, int n, int k) {
    for (; k < n; ++k) {
        if (must_stop(1)) {
            g_stop_ref = k;
            return WALK_STOP;
        }
        g_steps += 1;
        int tri = leaf_tri(k, s0, d0, ns);
        if (tri_cache_may_occlude(tri) && test_tri(r, tri)) {
            return WALK_HIT;
        }
        g_progress = true;
    }
    return WALK_CLEAR;
}
#endif
