// The leaf walk of METHOD_VOXEL_CACHE. Part of trace.comp (needs trace_leaf_list.glsl).
#if METHOD == METHOD_VOXEL_CACHE

// The per-voxel scheme of "Some Ideas on Shadow Algorithms", with per-invocation state: a
// direct-mapped table of VC_SLOTS leaves whose candidate lists (the leaf's triangles that may
// meet the light triangle) sit in a pool of VC_POOL triangle ids, bump-allocated. It is reset
// per shaded point and dispatch (the scheme's global ray id) and lives in the invocation's
// private memory, so no other invocation can race on it. A slot that is re-used leaks its pool
// space until the pool is full; then the whole table is flushed. A leaf whose candidates alone
// exceed the pool, or whose list is longer than VC_BIG_LEAF, overflows: counted, and its rays
// test every triangle of the leaf (the grid method there).
uint g_vc_key[VC_SLOTS];        // leaf + 1; 0 = empty
int g_vc_start[VC_SLOTS];       // first candidate in the pool
int g_vc_count[VC_SLOTS];       // candidates; -1 = overflowed
int g_vc_pool[VC_POOL];
int g_vc_used;

void voxel_cache_reset() {
    for (int i = 0; i < VC_SLOTS; ++i) {
        g_vc_key[i] = 0u;
    }
    g_vc_used = 0;
    g_steps += VC_SLOTS;
}

// The leaf's candidates, built the first time the point's rays enter it; then its rays walk
// them (or, for an overflowed leaf, the whole list) from entry k on. A resumed point builds the
// candidates again, in the same order, so k means the same entry.
int leaf_walk(Ray r, int leaf, int s0, int d0, int ns, int n, int k) {
    if (n == 0) {
        return WALK_CLEAR;
    }
    int slot = leaf & (VC_SLOTS - 1);
    bool raw = n > VC_BIG_LEAF;
    if (raw) {
        if (k == 0) {
            g_overflows += 1u;
        }
    } else {
        g_bytes_candidates += 4u;
        if (g_vc_key[slot] != uint(leaf) + 1u) {
            // Building the leaf's candidates is one step per triangle; it is not split.
            if (must_stop(2 * n)) {
                g_stop_ref = 0;
                return WALK_STOP;
            }
            if (g_vc_used + n > VC_POOL) {
                voxel_cache_reset();
            }
            g_vc_key[slot] = uint(leaf) + 1u;
            g_vc_start[slot] = g_vc_used;
            g_bytes_candidates += 12u;
            int count = 0;
            for (int j = 0; j < n; ++j) {
                g_steps += 1;
                int tri = leaf_tri(j, s0, d0, ns);
                if (may_occlude_point(tri)) {
                    if (g_vc_used + count < VC_POOL) {
                        g_vc_pool[g_vc_used + count] = tri;
                        g_bytes_candidates += 4u;
                    }
                    count += 1;
                }
            }
            g_candidates += uint(count);
            if (g_vc_used + count > VC_POOL) {
                g_overflows += 1u;
                g_vc_count[slot] = -1;
            } else {
                g_vc_count[slot] = count;
                g_vc_used += count;
            }
            // Not progress: a point that stops before its first test here builds it again.
        }
        g_bytes_candidates += 8u;
        raw = g_vc_count[slot] < 0;
    }
    int count = raw ? n : g_vc_count[slot];
    int first = raw ? 0 : g_vc_start[slot];
    for (; k < count; ++k) {
        if (must_stop(1)) {
            g_stop_ref = k;
            return WALK_STOP;
        }
        g_steps += 1;
        int tri;
        if (raw) {
            tri = leaf_tri(k, s0, d0, ns);
        } else {
            g_bytes_candidates += 4u;
            tri = g_vc_pool[first + k];
        }
        if (test_tri(r, tri)) {
            return WALK_HIT;
        }
        g_progress = true;
    }
    return WALK_CLEAR;
}
#endif
