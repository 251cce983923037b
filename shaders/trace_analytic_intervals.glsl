// METHOD_ANALYTIC's exact visibility of the segment: the union of the hidden intervals of its
// parameter, the interval one triangle hides, and the collinear case. Part of trace.comp
// (needs trace_structure.glsl).
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
#endif
