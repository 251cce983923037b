// Sampled methods: which triangles of a leaf a ray tests. The ray-triangle test that every
// leaf walk ends in, the walk of a leaf's whole list, and that walk as the leaf walk of the
// methods without a cache (grid; brute never walks leaves). Part of trace.comp (needs
// trace_structure.glsl).

bool test_tri(Ray r, int tri) {
    if (mailbox_seen(tri)) {
        return false;
    }
    g_ray_tri += 1u;
    g_bytes_triangles += uint(TRIANGLE_BYTES);
    return ray_hits_triangle(r, tri);
}

// Every triangle of a leaf, from entry k on (the grid method; voxel-cache's overflow path).
int list_walk(Ray r, int s0, int d0, int ns, int n, int k) {
    for (; k < n; ++k) {
        if (must_stop(1)) {
            g_stop_ref = k;
            return WALK_STOP;
        }
        g_steps += 1;
        if (test_tri(r, leaf_tri(k, s0, d0, ns))) {
            return WALK_HIT;
        }
        g_progress = true;
    }
    return WALK_CLEAR;
}

#if METHOD != METHOD_TRI_CACHE && METHOD != METHOD_VOXEL_CACHE
int leaf_walk(Ray r, int leaf, int s0, int d0, int ns, int n, int k) {
    return list_walk(r, s0, d0, ns, n, k);
}
#endif
