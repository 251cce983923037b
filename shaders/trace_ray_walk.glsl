// The sampled methods: one ray per sample of the light, walked through the structure (3D-DDA
// over one or two grid levels) or, for METHOD_BRUTE, over every triangle. Part of trace.comp
// (needs trace_structure.glsl and a leaf_walk).

// ---- 3D-DDA through the structure -------------------------------------------------------
// (Amanatides and Woo, "A Fast Voxel Traversal Algorithm", 1987.) The parameters where the ray
// leaves a cell are computed from the cell's own coordinates at every step, not accumulated, so
// that a walk resumed at a cell takes exactly the steps the unbroken walk would have.
vec3 g_inv;     // 1 / d of the current ray (+-inf on a zero component)
ivec3 g_step;   // sign of d

// Ray parameters of the cell's far faces along each axis (1e30 where the ray is parallel).
vec3 cell_exit(vec3 lo, vec3 size, ivec3 c, vec3 o) {
    vec3 face = lo + (vec3(c) + vec3(greaterThan(g_step, ivec3(0)))) * size;
    return mix((face - o) * g_inv, vec3(1e30), equal(g_step, ivec3(0)));
}

// Ray parameter where the ray enters the cell (the largest near-face parameter).
float cell_entry(vec3 lo, vec3 size, ivec3 c, vec3 o) {
    vec3 face = lo + (vec3(c) + vec3(lessThan(g_step, ivec3(0)))) * size;
    vec3 s = mix((face - o) * g_inv, vec3(-1e30), equal(g_step, ivec3(0)));
    return max(max(s.x, s.y), s.z);
}

int min_axis(vec3 v) {
    return (v.x < v.y) ? (v.x < v.z ? 0 : 2) : (v.y < v.z ? 1 : 2);
}

// Where a ray's walk is: the current grid (the top grid or one top cell's sub-grid) and its cell.
struct GridWalk {
    ivec3 dims;   // the grid's cells per axis
    vec3 box;     // its lower corner
    vec3 size;    // its cell size
    int first;    // leaf id of its cell 0
    ivec3 c;      // the cell
    float s_in;   // where the ray enters the cell
    bool inside;  // in a sub-grid (TWO_LEVEL)
    ivec3 top;    // the top cell the sub-grid fills (TWO_LEVEL)
};

// The ray's span [s0, s1] in the grid's box (none if s0 > s1); sets g_inv and g_step. Clipped to
// the grid's box; the binning's padding covers a float step into a neighbouring cell.
void grid_span(vec3 o, vec3 d, out float s0, out float s1) {
    vec3 lo = u_trace.grid_origin;
    vec3 hi = lo + u_trace.grid_cell * vec3(u_trace.grid_dims);
    g_inv = 1.0 / d;
    g_step = ivec3(sign(d));
    vec3 t0 = (lo - o) * g_inv, t1 = (hi - o) * g_inv;
    vec3 tn = min(t0, t1), tf = max(t0, t1);
    // A slab the ray runs parallel to: all or nothing, by whether the origin is inside it.
    bvec3 flat_axis = equal(d, vec3(0.0));
    bvec3 within = bvec3(uvec3(greaterThanEqual(o, lo)) & uvec3(lessThanEqual(o, hi)));
    tn = mix(tn, mix(vec3(1e30), vec3(-1e30), within), flat_axis);
    tf = mix(tf, mix(vec3(-1e30), vec3(1e30), within), flat_axis);
    s0 = max(max(tn.x, tn.y), max(tn.z, 0.0));
    s1 = min(min(tf.x, tf.y), min(tf.z, 1.0));
}

// The top cell where the walk starts: the cursor's (at_top >= 0), or where the ray enters the
// grid, at s0.
GridWalk grid_walk_start(vec3 o, vec3 d, float s0, int at_top) {
    vec3 lo = u_trace.grid_origin;
    GridWalk w;
    w.dims = u_trace.grid_dims;
    w.box = lo;
    w.size = u_trace.grid_cell;
    w.first = 0;
    w.s_in = s0;
    if (at_top >= 0) {
        w.c = unflatten(at_top, w.dims);
        w.s_in = max(s0, cell_entry(lo, w.size, w.c, o));
    } else {
        w.c = clamp(ivec3(floor((o + d * s0 - lo) / w.size)), ivec3(0), w.dims - 1);
    }
    w.inside = false;
    w.top = w.c;
    return w;
}

#if TWO_LEVEL
// From the subdivided top cell w.c (leaf_size n, its sub-grid's first leaf `first`) into its
// sub-grid: at the cursor's sub-cell (at_sub >= 0), or at the cell where the ray enters.
void enter_sub_grid(inout GridWalk w, int n, int first, vec3 o, vec3 d, int at_sub) {
    w.inside = true;
    w.top = w.c;
    w.first = first;
    w.dims = sub_dims(n);
    w.box = u_trace.grid_origin + vec3(w.c) * u_trace.grid_cell;
    w.size = u_trace.grid_cell / vec3(w.dims);
    w.c = at_sub >= 0 ? unflatten(at_sub, w.dims)
                      : clamp(ivec3(floor((o + d * w.s_in - w.box) / w.size)), ivec3(0),
                              w.dims - 1);
}
#endif

// On to the next cell along the ray; false once the ray is past s1 or out of the grid.
bool next_cell(inout GridWalk w, vec3 o, float s1) {
    vec3 nxt = cell_exit(w.box, w.size, w.c, o);
    int a = min_axis(nxt);
    if (nxt[a] > s1) {
        return false;
    }
    w.s_in = nxt[a];
    w.c[a] += g_step[a];
    if (w.c[a] < 0 || w.c[a] >= w.dims[a]) {
#if TWO_LEVEL
        if (!w.inside) {
            return false;
        }
        // Out of the sub-grid is out of its top cell, through the same face.
        w.inside = false;
        w.c = w.top;
        w.c[a] += g_step[a];
        w.dims = u_trace.grid_dims;
        w.box = u_trace.grid_origin;
        w.size = u_trace.grid_cell;
        w.first = 0;
        if (w.c[a] < 0 || w.c[a] >= w.dims[a]) {
            return false;
        }
#else
        return false;
#endif
    }
    return true;
}

// The leaves along the ray, from the cursor (top cell, sub-cell, entry k) on.
int grid_walk(Ray r, vec3 o, vec3 d, int at_top, int at_sub, int k) {
    float s0, s1;
    grid_span(o, d, s0, s1);
    if (s0 > s1) {
        return WALK_CLEAR;
    }
    // One loop and one leaf walk for both levels, and one cell-exit computation per step:
    // llvmpipe runs every branch of a loop body under a lane mask, so whatever a step might do
    // costs on every step. The current grid is the top grid or one top cell's sub-grid.
    GridWalk w = grid_walk_start(o, d, s0, at_top);
    for (;;) {
        int id = flatten(w.c, w.dims);
#if TWO_LEVEL
        int top_id = w.inside ? flatten(w.top, u_trace.grid_dims) : id;
        int sub = w.inside ? id : -1;
#else
        int top_id = id, sub = -1;
#endif
        if (must_stop(1)) {
            g_stop_top = top_id;
            g_stop_sub = sub;
            g_stop_ref = 0;
            return WALK_STOP;
        }
        g_steps += 1;
        int leaf = w.first + id;
        int s0_, d0, ns;
        int n = leaf_size(leaf, s0_, d0, ns);
#if TWO_LEVEL
        if (n < 0) {
            // A subdivided top cell: on into its sub-grid, at the cell where the ray enters.
            enter_sub_grid(w, n, s0_, o, d, at_sub);
            at_sub = -1;
            continue;
        }
#endif
        g_voxels += 1u;
        int walked = leaf_walk(r, leaf, s0_, d0, ns, n, k);
        if (walked == WALK_STOP) {
            g_stop_top = top_id;
            g_stop_sub = sub;
        }
        if (walked != WALK_CLEAR) {
            return walked;
        }
        k = 0;
        g_progress = true;
        if (!next_cell(w, o, s1)) {
            return WALK_CLEAR;
        }
    }
}

// Every triangle, from triangle k on; four per iteration: a quarter of the steps.
int brute_walk(Ray r, int k) {
    int n = u_trace.triangles;
    for (int tri = k; tri < n; tri += 4) {
        if (must_stop(1)) {
            g_stop_top = 0;
            g_stop_sub = -1;
            g_stop_ref = tri;
            return WALK_STOP;
        }
        g_steps += 1;
        int m = min(4, n - tri);
        g_ray_tri += uint(m);
        g_bytes_triangles += uint(m * TRIANGLE_BYTES);
        if (ray_hits_triangle(r, tri)
            || (m > 1 && ray_hits_triangle(r, tri + 1))
            || (m > 2 && ray_hits_triangle(r, tri + 2))
            || (m > 3 && ray_hits_triangle(r, tri + 3))) {
            return WALK_HIT;
        }
        g_progress = true;
    }
    return WALK_CLEAR;
}

// One ray from o to o + d, resumed at the cursor (g_at_*), which it then clears.
int walk_ray(vec3 o, vec3 d) {
    Ray r = make_ray(o, d);
    mailbox_reset();
    int at_top = g_at_top, at_sub = g_at_sub, k = g_at_ref;
    g_at_top = -1;
    g_at_sub = -1;
    g_at_ref = 0;
#if METHOD == METHOD_BRUTE
    return brute_walk(r, k);
#else
    return grid_walk(r, o, d, at_top, at_sub, k);
#endif
}

vec3 light_point(vec3 o, float t) {
    if (u_trace.light_mode == TRACE_LIGHT_POINT) {
        return u_trace.light_a;
    }
    if (u_trace.light_mode == TRACE_LIGHT_DIRECTIONAL) {
        return o + u_trace.light_a * u_trace.directional_far;
    }
    return mix(u_trace.light_a, u_trace.light_b, t);
}

// The samples from `at` on; counts the visible ones. WALK_STOP: `at` is where to resume.
int sampled_walk(vec3 o, vec3 nrm, uint point, inout int at, inout uint visible) {
    int n = u_trace.samples;
    for (; at < n; ++at) {
        if (must_stop(1)) {
            g_stop_top = -1;
            g_stop_sub = -1;
            g_stop_ref = 0;
            return WALK_STOP;
        }
        g_steps += 1;
        vec3 target = light_point(o, sample_t(point, at, n));
        vec3 d = target - o;
        if (dot(d, nrm) <= 0.0) {
            g_progress = true;
            continue;  // below the receiver's horizon: the receiver hides it
        }
        int walked = walk_ray(o, d);
        if (walked == WALK_STOP) {
            return WALK_STOP;
        }
        if (walked == WALK_CLEAR) {
            visible += 1u;
        }
        g_progress = true;
    }
    return WALK_CLEAR;
}
