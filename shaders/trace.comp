#version 430
// The soft-shadow compute pass: one invocation per pixel of the G-buffer, one shaded point each.
// METHOD (a #define from game/soft/methods.py) picks how occluders are found; all methods share the
// samples, the 3D-DDA and the ray-triangle test, so the accelerated ones equal METHOD_BRUTE.
#include "blocks/trace.glsl"
#include "trace.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

uniform sampler2D u_position;  // xyz world position
uniform sampler2D u_normal;    // xyz unit normal facing the camera
uniform sampler2D u_colour;    // a > 0 where geometry covers the pixel

// Per-point counters (this invocation's shaded point).
uint g_ray_tri;
uint g_tri_tri;
uint g_voxels;
uint g_candidates;
uint g_overflows;

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

bool may_occlude_point(int tri) {
    g_tri_tri += 1u;
    return triangles_may_meet(g_apex, g_la, g_lb, tri_vertex(tri, 0), tri_vertex(tri, 1),
                              tri_vertex(tri, 2));
}

int cell_size(int c, out int s0, out int d0, out int ns) {
    s0 = u_static_cells[c];
    ns = u_static_cells[c + 1] - s0;
    d0 = u_dynamic_cells[c];
    return ns + u_dynamic_cells[c + 1] - d0;
}

int cell_tri(int k, int s0, int d0, int ns) {
    return k < ns ? u_static_cells[s0 + k] : u_dynamic_cells[d0 + k - ns];
}

bool test_tri(Ray r, int tri) {
    if (mailbox_seen(tri)) {
        return false;
    }
    g_ray_tri += 1u;
    return ray_hits_triangle(r, tri);
}

bool cell_all_tris(Ray r, int c) {
    int s0, d0, ns;
    int n = cell_size(c, s0, d0, ns);
    for (int k = 0; k < n; ++k) {
        if (test_tri(r, cell_tri(k, s0, d0, ns))) {
            return true;
        }
    }
    return false;
}

#if METHOD == METHOD_TRI_CACHE
uint g_ray_id;

// The per-triangle scheme that "Some Ideas on Shadow Algorithms" cites as [643]: a ray id and a
// flag per triangle. They share one 32-bit word, so a word another invocation overwrote only
// costs a repeated test, never a wrong flag.
bool tri_cache_may_occlude(int tri) {
    uint state = u_tri_state[tri];
    if ((state >> 1u) == g_ray_id) {
        return (state & 1u) == 0u;
    }
    bool may = may_occlude_point(tri);
    u_tri_state[tri] = (g_ray_id << 1u) | (may ? 0u : 1u);
    return may;
}

bool cell_occludes(Ray r, int c) {
    int s0, d0, ns;
    int n = cell_size(c, s0, d0, ns);
    for (int k = 0; k < n; ++k) {
        int tri = cell_tri(k, s0, d0, ns);
        if (tri_cache_may_occlude(tri) && test_tri(r, tri)) {
            return true;
        }
    }
    return false;
}
#elif METHOD == METHOD_VOXEL_CACHE
// The per-voxel scheme of "Some Ideas on Shadow Algorithms", with per-invocation state: a direct-mapped table of VC_SLOTS voxels whose
// candidate lists (the voxel's triangles that may meet the light triangle) sit in a pool of
// VC_POOL triangle ids, bump-allocated. It is reset per shaded point (the scheme's global ray id)
// and lives in the invocation's private memory, so no other invocation can race on it. A slot
// that is re-used leaks its pool space until the pool is full; then the whole table is flushed.
// A voxel whose candidates alone exceed the pool overflows: counted, and its rays test every
// triangle of the voxel (the grid method there).
uint g_vc_key[VC_SLOTS];        // cell + 1; 0 = empty
int g_vc_start[VC_SLOTS];       // first candidate in the pool
int g_vc_count[VC_SLOTS];       // candidates; -1 = overflowed
int g_vc_pool[VC_POOL];
int g_vc_used;

void voxel_cache_reset() {
    for (int i = 0; i < VC_SLOTS; ++i) {
        g_vc_key[i] = 0u;
    }
    g_vc_used = 0;
}

bool cell_occludes(Ray r, int c) {
    int s0, d0, ns;
    int n = cell_size(c, s0, d0, ns);
    if (n == 0) {
        return false;
    }
    int slot = c & (VC_SLOTS - 1);
    if (g_vc_key[slot] != uint(c) + 1u) {
        if (g_vc_used + n > VC_POOL) {
            voxel_cache_reset();
        }
        g_vc_key[slot] = uint(c) + 1u;
        g_vc_start[slot] = g_vc_used;
        int count = 0;
        for (int k = 0; k < n; ++k) {
            int tri = cell_tri(k, s0, d0, ns);
            if (may_occlude_point(tri)) {
                if (g_vc_used + count < VC_POOL) {
                    g_vc_pool[g_vc_used + count] = tri;
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
    }
    int count = g_vc_count[slot];
    if (count < 0) {
        return cell_all_tris(r, c);
    }
    int first = g_vc_start[slot];
    for (int j = 0; j < count; ++j) {
        if (test_tri(r, g_vc_pool[first + j])) {
            return true;
        }
    }
    return false;
}
#else
bool cell_occludes(Ray r, int c) {
    return cell_all_tris(r, c);
}
#endif

// Any hit of the ray o + s d, s in (0, 1)?
bool occluded(vec3 o, vec3 d) {
    Ray r = make_ray(o, d);
    mailbox_reset();
#if METHOD == METHOD_BRUTE
    // Four triangles per iteration: a quarter of the loop budget (see loop_budget_left).
    int n = u_trace.triangles;
    for (int tri = 0; tri < n; tri += 4) {
        int m = min(4, n - tri);
        g_ray_tri += uint(m);
        if (ray_hits_triangle(r, tri)
            || (m > 1 && ray_hits_triangle(r, tri + 1))
            || (m > 2 && ray_hits_triangle(r, tri + 2))
            || (m > 3 && ray_hits_triangle(r, tri + 3))) {
            return true;
        }
    }
    return false;
#else
    // 3D-DDA (Amanatides and Woo, "A Fast Voxel Traversal Algorithm", 1987), clipped to the
    // grid's box; the binning's padding covers a float step into a neighbouring cell.
    vec3 lo = u_trace.grid_origin;
    vec3 hi = lo + u_trace.grid_cell * vec3(u_trace.grid_dims);
    vec3 inv = 1.0 / d;  // +-inf on a zero component: that slab never limits
    vec3 t0 = (lo - o) * inv, t1 = (hi - o) * inv;
    vec3 tn = min(t0, t1), tf = max(t0, t1);
    for (int a = 0; a < 3; ++a) {
        if (d[a] == 0.0) {
            tn[a] = (o[a] >= lo[a] && o[a] <= hi[a]) ? -1e30 : 1e30;
            tf[a] = (o[a] >= lo[a] && o[a] <= hi[a]) ? 1e30 : -1e30;
        }
    }
    float s0 = max(max(tn.x, tn.y), max(tn.z, 0.0));
    float s1 = min(min(tf.x, tf.y), min(tf.z, 1.0));
    if (s0 > s1) {
        return false;
    }
    vec3 start = o + d * s0;
    ivec3 cell = clamp(ivec3(floor((start - lo) / u_trace.grid_cell)), ivec3(0),
                       u_trace.grid_dims - 1);
    ivec3 step = ivec3(sign(d));
    vec3 next, delta;
    for (int a = 0; a < 3; ++a) {
        if (step[a] == 0) {
            next[a] = 1e30;
            delta[a] = 1e30;
        } else {
            float boundary = lo[a] + float(cell[a] + (step[a] > 0 ? 1 : 0)) * u_trace.grid_cell[a];
            next[a] = (boundary - o[a]) / d[a];
            delta[a] = u_trace.grid_cell[a] / abs(d[a]);
        }
    }
    for (;;) {
        g_voxels += 1u;
        if (cell_occludes(r, cell_index(cell))) {
            return true;
        }
        int a = (next.x < next.y) ? (next.x < next.z ? 0 : 2) : (next.y < next.z ? 1 : 2);
        if (next[a] > s1) {
            return false;
        }
        cell[a] += step[a];
        if (cell[a] < 0 || cell[a] >= u_trace.grid_dims[a]) {
            return false;
        }
        next[a] += delta[a];
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

// The interval of the segment that triangle tri hides from the apex, as (l, r); empty if r <= l.
vec2 hidden_interval(int tri) {
    vec3 n = cross(g_la - g_apex, g_lb - g_apex);
    vec3 q[3] = vec3[3](tri_vertex(tri, 0), tri_vertex(tri, 1), tri_vertex(tri, 2));
    float dist[3];
    for (int k = 0; k < 3; ++k) {
        dist[k] = dot(q[k] - g_apex, n);
    }
    if (dist[0] == 0.0 && dist[1] == 0.0 && dist[2] == 0.0) {
        return vec2(1.0, 0.0);  // coplanar: rays graze it, as the ray-triangle test says
    }
    // Where the triangle crosses the light triangle's plane: a segment x0-x1.
    vec3 pts[2];
    int np = 0;
    for (int k = 0; k < 3; ++k) {
        int j = (k + 1) % 3;
        if (dist[k] == 0.0 && np < 2) {
            pts[np++] = q[k];
        }
        if ((dist[k] < 0.0 && dist[j] > 0.0) || (dist[k] > 0.0 && dist[j] < 0.0)) {
            if (np < 2) {
                pts[np++] = q[k] + (q[j] - q[k]) * (dist[k] / (dist[k] - dist[j]));
            }
        }
    }
    if (np < 2) {
        return vec2(1.0, 0.0);
    }
    // Clip it to the light triangle (Liang-Barsky against the three edges).
    float lo = 0.0, hi = 1.0;
    vec3 ev[4] = vec3[4](g_apex, g_la, g_lb, g_apex);
    for (int k = 0; k < 3; ++k) {
        float e0 = edge_fn(ev[k], ev[k + 1], pts[0], n);
        float e1 = edge_fn(ev[k], ev[k + 1], pts[1], n);
        if (e0 < 0.0 && e1 < 0.0) {
            return vec2(1.0, 0.0);
        }
        if (e0 < 0.0) {
            lo = max(lo, e0 / (e0 - e1));
        } else if (e1 < 0.0) {
            hi = min(hi, e0 / (e0 - e1));
        }
    }
    if (!(hi > lo)) {
        return vec2(1.0, 0.0);
    }
    bool ok0, ok1;
    float t0 = param_of(mix(pts[0], pts[1], lo), n, ok0);
    float t1 = param_of(mix(pts[0], pts[1], hi), n, ok1);
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

float analytic_visibility(vec3 o, vec3 nrm) {
    g_niv = 0;
    vec3 tn = cross(g_la - o, g_lb - o);
    g_collinear = length(tn) <= 1e-6 * length(g_la - o) * length(g_lb - o);
    if (g_collinear) {
        vec3 far_end = distance(g_la, o) > distance(g_lb, o) ? g_la : g_lb;
        g_line = make_ray(o, far_end - o);
        g_near_hit = 2.0;
    }
    // The part of the segment below the receiver's horizon is hidden by the receiver itself.
    float h0 = dot(g_la - o, nrm), h1 = dot(g_lb - o, nrm);
    if (h0 <= 0.0 && h1 <= 0.0) {
        return 0.0;
    }
    if (h0 <= 0.0) {
        add_interval(0.0, h0 / (h0 - h1));
    } else if (h1 <= 0.0) {
        add_interval(h0 / (h0 - h1), 1.0);
    }
    // Every cell the light triangle touches, every triangle there that may meet it.
    vec3 lo = min(min(g_apex, g_la), g_lb), hi = max(max(g_apex, g_la), g_lb);
    vec3 pad = u_trace.grid_cell * BIN_PAD_CELLS;
    ivec3 c0 = clamp(ivec3(floor((lo - pad - u_trace.grid_origin) / u_trace.grid_cell)), ivec3(0),
                     u_trace.grid_dims - 1);
    ivec3 c1 = clamp(ivec3(floor((hi + pad - u_trace.grid_origin) / u_trace.grid_cell)), ivec3(0),
                     u_trace.grid_dims - 1);
    vec3 half_size = u_trace.grid_cell * (0.5 + BIN_PAD_CELLS);
    mailbox_reset();
    for (int z = c0.z; z <= c1.z; ++z) {
        for (int y = c0.y; y <= c1.y; ++y) {
            for (int x = c0.x; x <= c1.x; ++x) {
                ivec3 cell = ivec3(x, y, z);
                int c = cell_index(cell);
                int s0, d0, ns;
                int n = cell_size(c, s0, d0, ns);
                if (n == 0) {
                    continue;
                }
                g_voxels += 1u;
                if (!triangle_may_touch_box(g_apex, g_la, g_lb, cell_centre(cell), half_size)) {
                    continue;
                }
                for (int k = 0; k < n; ++k) {
                    int tri = cell_tri(k, s0, d0, ns);
                    if (mailbox_seen(tri) || !may_occlude_point(tri)) {
                        continue;
                    }
                    g_candidates += 1u;
                    if (g_collinear) {
                        collinear_candidate(tri);
                    } else {
                        vec2 iv = hidden_interval(tri);
                        add_interval(iv.x, iv.y);
                    }
                }
            }
        }
    }
    if (g_collinear) {
        collinear_finish(o);
    }
    float hidden = 0.0;
    for (int i = 0; i < g_niv; ++i) {
        hidden += g_iv[i].y - g_iv[i].x;
    }
    return clamp(1.0 - hidden, 0.0, 1.0);
}
#endif

// Mesa's llvmpipe (22.3) stops every loop of an invocation once their iterations add up to 65535
// (one shared counter, LP_MAX_TGSI_LOOP_ITERATIONS): the work left is silently skipped. A loop
// of u_trace.loop_probe_trips = 2 trips then runs once; that flags the point as truncated, and
// game/soft/tracer.py re-runs such traces with fewer samples per dispatch.
bool loop_budget_left() {
    int trips = 0;
    for (int i = 0; i < u_trace.loop_probe_trips; ++i) {
        trips += 1;
    }
    return trips == u_trace.loop_probe_trips;
}

uint sampled_visible(vec3 o, vec3 nrm, uint point) {
    int n = u_trace.samples;
    uint visible = 0u;
    for (int i = u_trace.first_sample; i < u_trace.first_sample + u_trace.sample_count; ++i) {
        vec3 target = light_point(o, sample_t(point, i, n));
        vec3 d = target - o;
        if (dot(d, nrm) <= 0.0) {
            continue;  // below the receiver's horizon: the receiver hides it
        }
        if (!occluded(o, d)) {
            visible += 1u;
        }
    }
    return visible;
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (px.x >= u_trace.width || px.y >= u_trace.height) {
        return;
    }
    int index = px.y * u_trace.width + px.x;
    g_ray_tri = 0u;
    g_tri_tri = 0u;
    g_voxels = 0u;
    g_candidates = 0u;
    g_overflows = 0u;
    float vis = -1.0;  // no geometry
    uint visible = 0u;
    if (texelFetch(u_colour, px, 0).a > 0.0) {
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
#if METHOD == METHOD_ANALYTIC
        if (u_trace.light_mode == TRACE_LIGHT_SEGMENT) {
            vis = analytic_visibility(o, nrm);
        } else {
            visible = sampled_visible(o, nrm, uint(index));
        }
#else
        visible = sampled_visible(o, nrm, uint(index));
#endif
    }
    uint truncated = loop_budget_left() ? 0u : 1u;
    if (u_trace.accumulate != 0) {
        PointResult before = u_results[index];
        g_ray_tri += before.ray_triangle_tests;
        g_tri_tri += before.triangle_triangle_tests;
        g_voxels += before.voxels_visited;
        g_candidates += before.candidates;
        g_overflows += before.overflows;
        truncated = max(truncated, before.truncated);
        visible += before.visible;
    }
    bool exact = METHOD == METHOD_ANALYTIC && u_trace.light_mode == TRACE_LIGHT_SEGMENT;
    if (texelFetch(u_colour, px, 0).a > 0.0 && !exact) {
        vis = float(visible) / float(u_trace.samples);
    }
    u_results[index] = PointResult(vis, g_ray_tri, g_tri_tri, g_voxels, g_candidates,
                                   g_overflows, truncated, visible);
}
