#version 430
// The soft-shadow compute pass: one invocation per pixel of the G-buffer, one shaded point each.
// METHOD (a #define from game/soft/methods.py) picks how occluders are found; all methods share the
// samples, the leaf walk and the ray-triangle test, so the accelerated ones equal METHOD_BRUTE.
//
// Every point's work is split into dispatches ("rounds") by a step budget: each loop iteration
// costs a step, and a point whose steps reach u_trace.step_budget saves where it is (its
// cursor, in its PointResult) and resumes there in the next round. Mesa's llvmpipe stops all
// loops of an invocation after 65,535 iterations in all (see loop_budget_left); the budget keeps
// every invocation well below that, whatever the method, scene or grid.
#include "blocks/trace.glsl"
#include "trace.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

uniform sampler2D u_position;  // xyz world position
uniform sampler2D u_normal;    // xyz unit normal facing the camera
uniform sampler2D u_colour;    // a > 0 where geometry covers the pixel

// What a walk (a ray through the structure, a leaf's list, an enumeration) ended with.
const int WALK_CLEAR = 0;  // finished, nothing hit
const int WALK_HIT = 1;    // a triangle hides the sample
const int WALK_STOP = 2;   // the step budget ran out: resume at the saved cursor

// Per-dispatch counters of the current point, added to its PointResult at the end.
uint g_ray_tri;
uint g_tri_tri;
uint g_voxels;
uint g_candidates;
uint g_overflows;
uint g_bytes_triangles;   // read from the Triangles buffer
uint g_bytes_cells;       // read from the structure: top table, sub-grid table, leaf offsets, ids
uint g_bytes_candidates;  // candidate state read and written: voxel cache, tri-cache words

// The step budget: steps taken in this dispatch, and whether anything was done since the point
// resumed (a point may only stop after some progress, so every round moves it on).
int g_steps;
bool g_progress;

bool must_stop(int cost) {
    return g_progress && g_steps + cost > u_trace.step_budget;
}

// The cursor: where the current point resumes (read at the start of a dispatch) and where it
// stopped (written on WALK_STOP). top/sub are cells (sampled methods) or enumeration indices
// (analytic); -1 means from the start; ref is the entry of the leaf's list (brute: the triangle).
int g_at_top;
int g_at_sub;
int g_at_ref;
int g_stop_top;
int g_stop_sub;
int g_stop_ref;

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

// ---- Sampled methods: which triangles of a leaf a ray tests -------------------------------
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
#elif METHOD == METHOD_VOXEL_CACHE
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
#else
int leaf_walk(Ray r, int leaf, int s0, int d0, int ns, int n, int k) {
    return list_walk(r, s0, d0, ns, n, k);
}
#endif

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

int walk_ray(vec3 o, vec3 d) {
    Ray r = make_ray(o, d);
    mailbox_reset();
    int at_top = g_at_top, at_sub = g_at_sub, k = g_at_ref;
    g_at_top = -1;
    g_at_sub = -1;
    g_at_ref = 0;
#if METHOD == METHOD_BRUTE
    // Four triangles per iteration: a quarter of the steps.
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
#else
    // Clipped to the grid's box; the binning's padding covers a float step into a neighbouring
    // cell.
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
    float s0 = max(max(tn.x, tn.y), max(tn.z, 0.0));
    float s1 = min(min(tf.x, tf.y), min(tf.z, 1.0));
    if (s0 > s1) {
        return WALK_CLEAR;
    }
    // One loop and one leaf walk for both levels, and one cell-exit computation per step:
    // llvmpipe runs every branch of a loop body under a lane mask, so whatever a step might do
    // costs on every step. The current grid is the top grid or one top cell's sub-grid.
    ivec3 dims = u_trace.grid_dims;
    vec3 box = lo, size = u_trace.grid_cell;
    int first = 0;  // leaf id of the current grid's cell 0
    ivec3 c;
    float s_in = s0;  // where the ray enters the current cell
    if (at_top >= 0) {
        c = unflatten(at_top, dims);
        s_in = max(s0, cell_entry(lo, size, c, o));
    } else {
        c = clamp(ivec3(floor((o + d * s0 - lo) / size)), ivec3(0), dims - 1);
    }
#if TWO_LEVEL
    bool inside = false;
    ivec3 top = c;
#endif
    for (;;) {
        int id = flatten(c, dims);
#if TWO_LEVEL
        int top_id = inside ? flatten(top, u_trace.grid_dims) : id;
        int sub = inside ? id : -1;
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
        int leaf = first + id;
        int s0_, d0, ns;
        int n = leaf_size(leaf, s0_, d0, ns);
#if TWO_LEVEL
        if (n < 0) {
            // A subdivided top cell: on into its sub-grid, at the cell where the ray enters.
            inside = true;
            top = c;
            first = s0_;
            dims = sub_dims(n);
            box = lo + vec3(c) * u_trace.grid_cell;
            size = u_trace.grid_cell / vec3(dims);
            c = at_sub >= 0 ? unflatten(at_sub, dims)
                            : clamp(ivec3(floor((o + d * s_in - box) / size)), ivec3(0), dims - 1);
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
        vec3 nxt = cell_exit(box, size, c, o);
        int a = min_axis(nxt);
        if (nxt[a] > s1) {
            return WALK_CLEAR;
        }
        s_in = nxt[a];
        c[a] += g_step[a];
        if (c[a] < 0 || c[a] >= dims[a]) {
#if TWO_LEVEL
            if (!inside) {
                return WALK_CLEAR;
            }
            // Out of the sub-grid is out of its top cell, through the same face.
            inside = false;
            c = top;
            c[a] += g_step[a];
            dims = u_trace.grid_dims;
            box = lo;
            size = u_trace.grid_cell;
            first = 0;
            if (c[a] < 0 || c[a] >= dims[a]) {
                return WALK_CLEAR;
            }
#else
            return WALK_CLEAR;
#endif
        }
    }
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

#if METHOD == METHOD_ANALYTIC
// Union of occluded intervals of the segment parameter, kept disjoint.
vec2 g_iv[MAX_INTERVALS];
int g_niv;

void add_interval(float l, float r) {
    l = max(l, 0.0);
    r = min(r, 1.0);
    if (!(r > l)) {
        return;
    }
    g_steps += g_niv;
    for (int i = 0; i < g_niv; ) {
        if (l <= g_iv[i].y && r >= g_iv[i].x) {
            l = min(l, g_iv[i].x);
            r = max(r, g_iv[i].y);
            g_niv -= 1;
            g_iv[i] = g_iv[g_niv];
        } else {
            ++i;
        }
    }
    if (g_niv == MAX_INTERVALS) {
        // Full: merge with the nearest interval (covers its gap too; counted, never silent).
        g_overflows += 1u;
        g_steps += g_niv;
        int best = 0;
        float gap = 1e30;
        for (int i = 0; i < g_niv; ++i) {
            float g = max(g_iv[i].x - r, l - g_iv[i].y);
            if (g < gap) {
                gap = g;
                best = i;
            }
        }
        g_iv[best] = vec2(min(l, g_iv[best].x), max(r, g_iv[best].y));
        return;
    }
    g_iv[g_niv] = vec2(l, r);
    g_niv += 1;
}

// A point that stops keeps its union in its PointResult: at most ANALYTIC_KEPT intervals. More
// are merged first, closing the smallest gaps (counted in overflows, as a full list is).
void keep_intervals(inout PointResult res) {
    g_steps += g_niv * g_niv;
    // Insertion sort by start (the list is disjoint, so ends follow).
    for (int i = 1; i < g_niv; ++i) {
        vec2 v = g_iv[i];
        int j = i - 1;
        for (; j >= 0 && g_iv[j].x > v.x; --j) {
            g_iv[j + 1] = g_iv[j];
        }
        g_iv[j + 1] = v;
    }
    while (g_niv > ANALYTIC_KEPT) {
        g_overflows += 1u;
        int best = 0;
        float gap = 1e30;
        for (int i = 0; i + 1 < g_niv; ++i) {
            float g = g_iv[i + 1].x - g_iv[i].y;
            if (g < gap) {
                gap = g;
                best = i;
            }
        }
        g_iv[best].y = max(g_iv[best].y, g_iv[best + 1].y);
        for (int i = best + 1; i + 1 < g_niv; ++i) {
            g_iv[i] = g_iv[i + 1];
        }
        g_niv -= 1;
    }
    for (int i = 0; i < g_niv; ++i) {
        res.kept_intervals[i >> 1][2 * (i & 1)] = g_iv[i].x;
        res.kept_intervals[i >> 1][2 * (i & 1) + 1] = g_iv[i].y;
    }
    res.intervals = g_niv;
}

void restore_intervals(PointResult res) {
    g_niv = res.intervals;
    for (int i = 0; i < g_niv; ++i) {
        g_iv[i] = vec2(res.kept_intervals[i >> 1][2 * (i & 1)],
                       res.kept_intervals[i >> 1][2 * (i & 1) + 1]);
    }
}

// Edge function of x against the edge (u -> v) of the light triangle, >= 0 inside.
float edge_fn(vec3 u, vec3 v, vec3 x, vec3 n) {
    return dot(cross(v - u, x - u), n);
}

// Segment parameter of the ray from the apex through x (x inside the light triangle).
float param_of(vec3 x, vec3 n, out bool ok) {
    float wa = edge_fn(g_lb, g_apex, x, n);
    float wb = edge_fn(g_apex, g_la, x, n);
    ok = wa + wb > 0.0;
    return ok ? wb / (wa + wb) : 0.0;
}

// Appends x to the crossing (x0, x1), of which np points are set (at most two are kept).
void add_point(vec3 x, inout vec3 x0, inout vec3 x1, inout int np) {
    if (np == 0) {
        x0 = x;
    } else if (np == 1) {
        x1 = x;
    }
    np = min(np + 1, 2);
}

// Where the edge (qa, qb), with signed distances (da, db) from the light triangle's plane,
// meets the plane: its first corner if on the plane, and a crossing if the edge changes side.
void plane_crossing(vec3 qa, vec3 qb, float da, float db, inout vec3 x0, inout vec3 x1,
                    inout int np) {
    if (da == 0.0) {
        add_point(qa, x0, x1, np);
    }
    if ((da < 0.0 && db > 0.0) || (da > 0.0 && db < 0.0)) {
        add_point(qa + (qb - qa) * (da / (da - db)), x0, x1, np);
    }
}

// Liang-Barsky against one edge (u -> v) of the light triangle: narrows [lo, hi] of the
// segment x0-x1; false if the segment lies wholly outside the edge.
bool clip_edge(vec3 u, vec3 v, vec3 x0, vec3 x1, vec3 n, inout float lo, inout float hi) {
    float e0 = edge_fn(u, v, x0, n);
    float e1 = edge_fn(u, v, x1, n);
    if (e0 < 0.0 && e1 < 0.0) {
        return false;
    }
    if (e0 < 0.0) {
        lo = max(lo, e0 / (e0 - e1));
    } else if (e1 < 0.0) {
        hi = min(hi, e0 / (e0 - e1));
    }
    return true;
}

// The interval of the segment that the triangle (q0, q1, q2) hides from the apex, as (l, r);
// empty if r <= l. (Written without loops, as triangles_may_meet is.)
vec2 hidden_interval(vec3 q0, vec3 q1, vec3 q2) {
    vec3 n = cross(g_la - g_apex, g_lb - g_apex);
    float d0 = dot(q0 - g_apex, n), d1 = dot(q1 - g_apex, n), d2 = dot(q2 - g_apex, n);
    if (d0 == 0.0 && d1 == 0.0 && d2 == 0.0) {
        return vec2(1.0, 0.0);  // coplanar: rays graze it, as the ray-triangle test says
    }
    // Where the triangle crosses the light triangle's plane: a segment x0-x1.
    vec3 x0 = vec3(0.0), x1 = vec3(0.0);
    int np = 0;
    plane_crossing(q0, q1, d0, d1, x0, x1, np);
    plane_crossing(q1, q2, d1, d2, x0, x1, np);
    plane_crossing(q2, q0, d2, d0, x0, x1, np);
    if (np < 2) {
        return vec2(1.0, 0.0);
    }
    // Clip it to the light triangle (Liang-Barsky against the three edges).
    float lo = 0.0, hi = 1.0;
    if (!clip_edge(g_apex, g_la, x0, x1, n, lo, hi) || !clip_edge(g_la, g_lb, x0, x1, n, lo, hi)
        || !clip_edge(g_lb, g_apex, x0, x1, n, lo, hi) || !(hi > lo)) {
        return vec2(1.0, 0.0);
    }
    bool ok0, ok1;
    float t0 = param_of(mix(x0, x1, lo), n, ok0);
    float t1 = param_of(mix(x0, x1, hi), n, ok1);
    if (!ok0) {
        t0 = t1;
    }
    if (!ok1) {
        t1 = t0;
    }
    return vec2(min(t0, t1), max(t0, t1));
}

// The light triangle has no area (the point is on the segment's line, or the segment has no
// length): every ray has the same direction, so the nearest hit along it hides the farther part.
bool g_collinear;
Ray g_line;         // from the apex to the farther end
float g_near_hit;   // nearest hit distance along g_line, as a share of it

void collinear_candidate(int tri) {
    g_bytes_triangles += uint(TRIANGLE_BYTES);
    float s = ray_triangle_s(g_line, tri);
    if (s > 0.0) {
        g_near_hit = min(g_near_hit, s);
    }
}

void collinear_finish(vec3 o) {
    if (g_near_hit > 1.0) {
        return;
    }
    // Distances of the ends along the line; the hidden part is where the distance exceeds the hit.
    float len = length(g_line.d);
    vec3 u = g_line.d / len;
    float da = dot(g_la - o, u), db = dot(g_lb - o, u);
    float hit = g_near_hit * len;
    if (da == db) {
        add_interval(da > hit ? 0.0 : 1.0, da > hit ? 1.0 : 0.0);
    } else {
        float th = (hit - da) / (db - da);
        if (db > da) {
            add_interval(th, 1.0);
        } else {
            add_interval(0.0, th);
        }
    }
}

// Cost in steps of one entry of a list (its interval may walk the whole union twice), and room
// for keep_intervals, which runs when the point stops.
const int ANALYTIC_ENTRY_STEPS = 2 * MAX_INTERVALS + 2 + MAX_INTERVALS * MAX_INTERVALS;

// The triangles of a leaf (whose cell may touch the light triangle), from entry k on.
int analytic_leaf(int s0, int d0, int ns, int n, int k) {
    if (k == 0) {
        g_voxels += 1u;
    }
    for (; k < n; ++k) {
        if (must_stop(ANALYTIC_ENTRY_STEPS)) {
            g_stop_ref = k;
            return WALK_STOP;
        }
        g_steps += 1;
        int tri = leaf_tri(k, s0, d0, ns);
        if (!mailbox_seen(tri)) {
            g_tri_tri += 1u;
            vec3 v0, v1, v2;
            load_triangle(tri, v0, v1, v2);
            if (triangles_may_meet(g_apex, g_la, g_lb, v0, v1, v2)) {
                g_candidates += 1u;
                if (g_collinear) {
                    collinear_candidate(tri);
                } else {
                    vec2 iv = hidden_interval(v0, v1, v2);
                    add_interval(iv.x, iv.y);
                }
            }
        }
        g_progress = true;
    }
    return WALK_CLEAR;
}

// ---- The leaves the light triangle may touch ------------------------------------------------
// A box of cells of one grid (the top grid, or one top cell's sub-grid), walked column by column
// along the light triangle's dominant axis k: in each column only the cells that the triangle's
// plane can reach there, so a large slanted light triangle costs about the cells it crosses, not
// its bounding box's volume.
struct Cells {
    vec3 origin;   // the grid's lower corner
    vec3 size;     // its cell size
    ivec3 dims;    // its cells per axis
    int first;     // leaf id of its cell 0
    ivec3 c0;      // the box: cells c0 .. c0 + span - 1
    ivec3 span;
    int col;       // the column (over axes i, j)
    int k;         // the cell along k in it, and the column's last
    int kb;
};

ivec3 g_axes;     // (i, j, k): k is the light triangle's dominant normal axis
vec3 g_plane;     // the plane x_k = z + x * x_i + y * x_j
bool g_flat;      // no usable plane (a degenerate light triangle): whole columns
float g_margin;   // float tolerance of the plane's bounds, metres
vec3 g_tri_lo;    // the light triangle's bounding box
vec3 g_tri_hi;

void light_plane() {
    vec3 n = cross(g_la - g_apex, g_lb - g_apex);
    vec3 an = abs(n);
    int k = an.x > an.y ? (an.x > an.z ? 0 : 2) : (an.y > an.z ? 1 : 2);
    g_axes = ivec3((k + 1) % 3, (k + 2) % 3, k);
    g_tri_lo = min(min(g_apex, g_la), g_lb);
    g_tri_hi = max(max(g_apex, g_la), g_lb);
    g_flat = g_collinear || !(an[k] > 0.0);
    float nk = g_flat ? 1.0 : n[k];
    g_plane = vec3(-n[g_axes.x] / nk, -n[g_axes.y] / nk, dot(n, g_apex) / nk);
    vec3 far_corner = max(abs(g_tri_lo), abs(g_tri_hi));
    g_margin = 1e-4 * (abs(g_plane.z) + abs(g_plane.x) * far_corner[g_axes.x]
                       + abs(g_plane.y) * far_corner[g_axes.y]);
}

int cells_columns(Cells e) {
    return e.span[g_axes.x] * e.span[g_axes.y];
}

// The cells of column e.col that the light triangle's plane can reach: e.k .. e.kb.
void cells_column(inout Cells e) {
    int ai = g_axes.x, aj = g_axes.y, ak = g_axes.z;
    e.k = e.c0[ak];
    e.kb = e.c0[ak] + e.span[ak] - 1;
    if (g_flat) {
        return;
    }
    vec3 pad = e.size * BIN_PAD_CELLS;
    int ci = e.c0[ai] + e.col % e.span[ai], cj = e.c0[aj] + e.col / e.span[ai];
    float i0 = max(e.origin[ai] + float(ci) * e.size[ai] - pad[ai], g_tri_lo[ai]);
    float i1 = min(e.origin[ai] + float(ci + 1) * e.size[ai] + pad[ai], g_tri_hi[ai]);
    float j0 = max(e.origin[aj] + float(cj) * e.size[aj] - pad[aj], g_tri_lo[aj]);
    float j1 = min(e.origin[aj] + float(cj + 1) * e.size[aj] + pad[aj], g_tri_hi[aj]);
    float m = pad[ak] + g_margin;
    float k0 = g_plane.z + min(g_plane.x * i0, g_plane.x * i1)
               + min(g_plane.y * j0, g_plane.y * j1) - m;
    float k1 = g_plane.z + max(g_plane.x * i0, g_plane.x * i1)
               + max(g_plane.y * j0, g_plane.y * j1) + m;
    k0 = max(k0, g_tri_lo[ak] - pad[ak]);
    k1 = min(k1, g_tri_hi[ak] + pad[ak]);
    if (!(k1 >= k0)) {
        e.kb = e.k - 1;  // empty
        return;
    }
    e.k = max(e.k, int(floor((k0 - e.origin[ak]) / e.size[ak])));
    e.kb = min(e.kb, int(floor((k1 - e.origin[ak]) / e.size[ak])));
}

// Cells of the box of light-triangle-bounding cells in grid (origin, size, dims), from the
// cursor `at` (a position col * span_k + k - c0_k; 0: the start).
Cells cells_start(vec3 origin, vec3 size, ivec3 dims, int first, int at) {
    vec3 pad = size * BIN_PAD_CELLS;
    ivec3 c0 = clamp(ivec3(floor((g_tri_lo - pad - origin) / size)), ivec3(0), dims - 1);
    ivec3 c1 = clamp(ivec3(floor((g_tri_hi + pad - origin) / size)), ivec3(0), dims - 1);
    Cells e = Cells(origin, size, dims, first, c0, c1 - c0 + 1, 0, 0, 0);
    int sk = e.span[g_axes.z];
    e.col = at / sk;
    cells_column(e);
    e.k = max(e.k, c0[g_axes.z] + at % sk);
    return e;
}

int cells_cursor(Cells e) {
    return e.col * e.span[g_axes.z] + e.k - e.c0[g_axes.z];
}

ivec3 cells_cell(Cells e) {
    ivec3 c;
    c[g_axes.x] = e.c0[g_axes.x] + e.col % e.span[g_axes.x];
    c[g_axes.y] = e.c0[g_axes.y] + e.col / e.span[g_axes.x];
    c[g_axes.z] = e.k;
    return c;
}

// Every leaf that the light triangle may touch, each kept if the light triangle may touch its
// (padded) cell; in a subdivided top cell, its sub-cells. One loop walks both levels, with one
// call of analytic_leaf (see walk_ray). WALK_STOP saves the cursors (top, sub) and the entry.
int analytic_walk() {
    light_plane();
    Cells cur = cells_start(u_trace.grid_origin, u_trace.grid_cell, u_trace.grid_dims, 0,
                            max(g_at_top, 0));
    int k = g_at_ref;
#if TWO_LEVEL
    Cells top = cur;
    bool inside = false;
    int at_sub = g_at_sub;
#endif
    while (cur.col < cells_columns(cur)) {
#if TWO_LEVEL
        int top_at = inside ? cells_cursor(top) : cells_cursor(cur);
        int sub = inside ? cells_cursor(cur) : -1;
#else
        int top_at = cells_cursor(cur), sub = -1;
#endif
        if (must_stop(1)) {
            g_stop_top = top_at;
            g_stop_sub = sub;
            g_stop_ref = 0;
            return WALK_STOP;
        }
        g_steps += 1;
        if (cur.k > cur.kb) {
            // The column is done: the next one, or at the sub-grid's end, back to the top.
            g_progress = true;
            cur.col += 1;
            if (cur.col < cells_columns(cur)) {
                cells_column(cur);
            }
#if TWO_LEVEL
            else if (inside) {
                inside = false;
                cur = top;
                cur.k += 1;
            }
#endif
            continue;
        }
        ivec3 c = cells_cell(cur);
        int leaf = cur.first + flatten(c, cur.dims);
        // The box test first: it reads nothing.
        int s0 = 0, e0 = 0, ns = 0, n = 0;
        bool walk = triangle_may_touch_box(g_apex, g_la, g_lb, cur.origin + (vec3(c) + 0.5)
                                           * cur.size, cur.size * (0.5 + BIN_PAD_CELLS));
        if (walk) {
            n = leaf_size(leaf, s0, e0, ns);
            walk = n != 0;
        }
#if TWO_LEVEL
        if (walk && n < 0) {
            // A subdivided top cell the light triangle may touch: on into its sub-cells.
            top = cur;
            inside = true;
            ivec3 dims = sub_dims(n);
            cur = cells_start(cur.origin + vec3(c) * cur.size, cur.size / vec3(dims), dims, s0,
                              max(at_sub, 0));
            at_sub = -1;
            continue;
        }
#endif
        if (walk) {
            int walked = analytic_leaf(s0, e0, ns, n, k);
            if (walked == WALK_STOP) {
                g_stop_top = top_at;
                g_stop_sub = sub;
                return walked;
            }
        }
        k = 0;
        g_progress = true;
        cur.k += 1;
    }
    return WALK_CLEAR;
}

// Exact visibility of the segment: WALK_CLEAR with `vis` set, or WALK_STOP (the union and the
// cursor are kept in `res`).
int analytic_visibility(vec3 o, vec3 nrm, inout PointResult res, out float vis) {
    vis = 0.0;
    restore_intervals(res);
    vec3 tn = cross(g_la - o, g_lb - o);
    g_collinear = length(tn) <= 1e-6 * length(g_la - o) * length(g_lb - o);
    if (g_collinear) {
        vec3 far_end = distance(g_la, o) > distance(g_lb, o) ? g_la : g_lb;
        g_line = make_ray(o, far_end - o);
        g_near_hit = res.near_hit;
    }
    // The part of the segment below the receiver's horizon is hidden by the receiver itself.
    // (Adding it again on a resumed point changes nothing: the union already holds it.)
    float h0 = dot(g_la - o, nrm), h1 = dot(g_lb - o, nrm);
    if (h0 <= 0.0 && h1 <= 0.0) {
        return WALK_CLEAR;
    }
    if (h0 <= 0.0) {
        add_interval(0.0, h0 / (h0 - h1));
    } else if (h1 <= 0.0) {
        add_interval(h0 / (h0 - h1), 1.0);
    }
    mailbox_reset();
    int walked = analytic_walk();
    if (walked == WALK_STOP) {
        res.near_hit = g_near_hit;
        keep_intervals(res);
        return walked;
    }
    if (g_collinear) {
        collinear_finish(o);
    }
    float hidden = 0.0;
    for (int i = 0; i < g_niv; ++i) {
        hidden += g_iv[i].y - g_iv[i].x;
    }
    vis = clamp(1.0 - hidden, 0.0, 1.0);
    return WALK_CLEAR;
}
#endif

// Mesa's llvmpipe (22.3) stops every loop of an invocation once their iterations add up to 65535
// (one shared counter, LP_MAX_TGSI_LOOP_ITERATIONS): the work left is silently skipped. A loop
// of u_trace.loop_probe_trips = 2 trips then runs once; that flags the point as truncated, and
// game/soft/tracer.py runs such traces again with a smaller step budget.
bool loop_budget_left() {
    int trips = 0;
    for (int i = 0; i < u_trace.loop_probe_trips; ++i) {
        trips += 1;
    }
    return trips == u_trace.loop_probe_trips;
}

// A 64-bit counter kept as (low, high) words.
uvec2 add64(uvec2 total, uint v) {
    uint carry;
    uint low = uaddCarry(total.x, v, carry);
    return uvec2(low, total.y + carry);
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (px.x >= u_trace.width || px.y >= u_trace.height) {
        return;
    }
    int index = px.y * u_trace.width + px.x;
    int summary = u_trace.width * u_trace.height;  // the record after the points: totals
    PointResult res;
    if (u_trace.round_index == 0) {
        res.visibility = -1.0;  // no geometry
        res.ray_triangle_tests = 0u;
        res.triangle_triangle_tests = 0u;
        res.voxels_visited = 0u;
        res.candidates = 0u;
        res.overflows = 0u;
        res.truncated = 0u;
        res.visible = 0u;
        res.bytes_triangles = uvec2(0u);
        res.bytes_cells = uvec2(0u);
        res.bytes_candidates = uvec2(0u);
        res.dispatches = 0u;
        res.pending = 0u;
        res.at_sample = 0;
        res.at_top = -1;
        res.at_sub = -1;
        res.at_ref = 0;
        res.near_hit = 2.0;
        res.intervals = 0;
        res.kept_intervals = mat4(0.0);
        if (texelFetch(u_colour, px, 0).a <= 0.0) {
            u_results[index] = res;
            return;
        }
    } else {
        res = u_results[index];
        if (res.pending == 0u) {
            return;  // finished in an earlier round, or no geometry
        }
    }
    g_ray_tri = 0u;
    g_tri_tri = 0u;
    g_voxels = 0u;
    g_candidates = 0u;
    g_overflows = 0u;
    g_bytes_triangles = 0u;
    g_bytes_cells = 0u;
    g_bytes_candidates = 0u;
    g_steps = 0;
    g_progress = false;
    g_at_top = res.at_top;
    g_at_sub = res.at_sub;
    g_at_ref = res.at_ref;
    g_stop_top = -1;
    g_stop_sub = -1;
    g_stop_ref = 0;

    vec3 p = texelFetch(u_position, px, 0).xyz;
    vec3 nrm = normalize(texelFetch(u_normal, px, 0).xyz);
    // Receiver self-occlusion: start the rays off the surface along its normal.
    vec3 o = p + nrm * (u_trace.ray_offset + u_trace.ray_offset_per_metre * length(p));
    g_apex = o;
    g_la = u_trace.light_a;
    g_lb = u_trace.light_b;
#if METHOD == METHOD_TRI_CACHE
    g_ray_id = uint(u_trace.ray_id_base + index) & 0x7fffffffu;
#elif METHOD == METHOD_VOXEL_CACHE
    voxel_cache_reset();
#endif
    int walked;
#if METHOD == METHOD_ANALYTIC
    if (u_trace.light_mode == TRACE_LIGHT_SEGMENT) {
        float vis;
        walked = analytic_visibility(o, nrm, res, vis);
        if (walked == WALK_CLEAR) {
            res.visibility = vis;
        }
    } else
#endif
    {
        int at = res.at_sample;
        uint visible = res.visible;
        walked = sampled_walk(o, nrm, uint(index), at, visible);
        res.at_sample = at;
        res.visible = visible;
        if (walked == WALK_CLEAR) {
            res.visibility = float(visible) / float(u_trace.samples);
        }
    }
    res.at_top = g_stop_top;
    res.at_sub = g_stop_sub;
    res.at_ref = g_stop_ref;
    res.ray_triangle_tests += g_ray_tri;
    res.triangle_triangle_tests += g_tri_tri;
    res.voxels_visited += g_voxels;
    res.candidates += g_candidates;
    res.overflows += g_overflows;
    res.bytes_triangles = add64(res.bytes_triangles, g_bytes_triangles);
    res.bytes_cells = add64(res.bytes_cells, g_bytes_cells);
    res.bytes_candidates = add64(res.bytes_candidates, g_bytes_candidates);
    res.dispatches += 1u;
    res.pending = walked == WALK_STOP ? 1u : 0u;
    if (!loop_budget_left()) {
        res.truncated = 1u;
        atomicAdd(u_results[summary].truncated, 1u);
    }
    if (walked == WALK_STOP) {
        atomicAdd(u_results[summary].pending, 1u);
    }
    u_results[index] = res;
}
