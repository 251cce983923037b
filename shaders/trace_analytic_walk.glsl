// METHOD_ANALYTIC's walk: every leaf the point's light triangle may touch, and every triangle in
// them that may meet it, each adding the interval it hides. Part of trace.comp (needs
// trace_analytic_intervals.glsl).
#if METHOD == METHOD_ANALYTIC

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
// call of analytic_leaf (see grid_walk). WALK_STOP saves the cursors (top, sub) and the entry.
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
