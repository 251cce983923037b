// Whether a triangle may touch an axis-aligned box: the separating-axis test (Akenine-Moeller
// 2001) on the box's three axes, the triangle's normal and the nine edge crosses. The analytic
// tracer walks the cells a point's light triangle may touch with it
// (shaders/trace_analytic_walk.glsl); the window's soft accumulation finds the pixels whose
// light triangle a moving walker's box may cross (shaders/soft_accumulate.frag).
// The edge axes are written out, not looped over: llvmpipe runs every trip of a loop.

// Does the axis e x (one box axis) separate the triangle (v0, v1, v2), relative to the box's
// centre, from the box of half-size h? The axis is (0, -e.z, e.y), (e.z, 0, -e.x) or
// (-e.y, e.x, 0), given as its two non-zero components j and m: (a_j, a_m).
bool edge_axis_separates(float aj, float am, int j, int m, vec3 v0, vec3 v1, vec3 v2,
                         vec3 h) {
    float p0 = aj * v0[j] + am * v0[m];
    float p1 = aj * v1[j] + am * v1[m];
    float p2 = aj * v2[j] + am * v2[m];
    float r = abs(aj) * h[j] + abs(am) * h[m];
    return min(min(p0, p1), p2) > r || max(max(p0, p1), p2) < -r;
}

bool edge_separates(vec3 e, vec3 v0, vec3 v1, vec3 v2, vec3 h) {
    return edge_axis_separates(-e.z, e.y, 1, 2, v0, v1, v2, h)
        || edge_axis_separates(e.z, -e.x, 0, 2, v0, v1, v2, h)
        || edge_axis_separates(-e.y, e.x, 0, 1, v0, v1, v2, h);
}

// Can the triangle (t0, t1, t2) touch the box centre +- half? (Akenine-Moeller 2001.)
bool triangle_may_touch_box(vec3 t0, vec3 t1, vec3 t2, vec3 centre, vec3 half_size) {
    vec3 v0 = t0 - centre, v1 = t1 - centre, v2 = t2 - centre;
    vec3 lo = min(min(v0, v1), v2), hi = max(max(v0, v1), v2);
    if (any(greaterThan(lo, half_size)) || any(lessThan(hi, -half_size))) {
        return false;
    }
    vec3 e0 = v1 - v0, e1 = v2 - v1, e2 = v0 - v2;
    vec3 n = cross(e0, e1);
    if (abs(dot(n, v0)) > dot(abs(n), half_size)) {
        return false;
    }
    return !(edge_separates(e0, v0, v1, v2, half_size)
             || edge_separates(e1, v0, v1, v2, half_size)
             || edge_separates(e2, v0, v1, v2, half_size));
}
