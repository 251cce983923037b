// Shared code of the soft-shadow tracer: sample positions, the watertight ray-triangle test,
// the conservative triangle-triangle and triangle-box tests, and cell access.
// Needs blocks/trace.glsl. Mirrors: game/reference/soft.py (sample positions, for Embree).

// Relative tolerance of the conservative tests: a separating gap must exceed this share of the
// coordinates' magnitude before a triangle is dropped (float32 rounding of the rays is ~1e-7).
const float CONSERVATIVE_EPS = 1e-4;

// PCG hash (Jarzynski and Olano, "Hash Functions for GPU Rendering", JCGT 2020).
uint pcg(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Sample i of n along the segment: stratified, jittered per point, the same for every method.
float sample_t(uint point, int i, int n) {
    uint h = pcg((point * 2654435769u) ^ pcg(uint(i)));
    float jitter = float(h >> 8u) * (1.0 / 16777216.0);
    return (float(i) + jitter) / float(n);
}

vec3 tri_vertex(int tri, int k) {
    return u_tri[3 * tri + k].xyz;
}

// ---- Watertight ray-triangle intersection (Woop, Benthin and Wald, JCGT 2013) --------------
// The ray is o + s d, s in (0, 1): d reaches the light sample, so hits beyond it do not count.
struct Ray {
    vec3 o;
    vec3 d;
    ivec3 k;     // kx, ky, kz
    vec3 shear;  // Sx, Sy, Sz
};

Ray make_ray(vec3 o, vec3 d) {
    Ray r;
    r.o = o;
    r.d = d;
    vec3 a = abs(d);
    int kz = (a.x > a.y) ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
    int kx = (kz + 1) % 3;
    int ky = (kx + 1) % 3;
    if (d[kz] < 0.0) {
        int t = kx;
        kx = ky;
        ky = t;
    }
    r.k = ivec3(kx, ky, kz);
    r.shear = vec3(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    return r;
}

// The one watertight ray-triangle test (Woop, Benthin and Wald 2013). Returns (T, det) with
// det > 0 where the ray's line crosses the triangle: the hit lies at ray parameter T / det.
// det = 0: no crossing (outside an edge, or the ray in the triangle's plane).
vec2 ray_triangle_crossing(Ray r, int tri) {
    vec3 A = tri_vertex(tri, 0) - r.o;
    vec3 B = tri_vertex(tri, 1) - r.o;
    vec3 C = tri_vertex(tri, 2) - r.o;
    int kx = r.k.x, ky = r.k.y, kz = r.k.z;
    float Ax = A[kx] - r.shear.x * A[kz];
    float Ay = A[ky] - r.shear.y * A[kz];
    float Bx = B[kx] - r.shear.x * B[kz];
    float By = B[ky] - r.shear.y * B[kz];
    float Cx = C[kx] - r.shear.x * C[kz];
    float Cy = C[ky] - r.shear.y * C[kz];
    float U = Cx * By - Cy * Bx;
    float V = Ax * Cy - Ay * Cx;
    float W = Bx * Ay - By * Ax;
    if ((U < 0.0 || V < 0.0 || W < 0.0) && (U > 0.0 || V > 0.0 || W > 0.0)) {
        return vec2(0.0);
    }
    float det = U + V + W;
    float T = U * (r.shear.z * A[kz]) + V * (r.shear.z * B[kz]) + W * (r.shear.z * C[kz]);
    return det < 0.0 ? vec2(-T, -det) : vec2(T, det);
}

// Does the ray hit the triangle strictly between its origin (s = 0) and its end (s = 1)?
bool ray_hits_triangle(Ray r, int tri) {
    vec2 h = ray_triangle_crossing(r, tri);
    return h.y > 0.0 && h.x > 0.0 && h.x < h.y;
}

// The ray parameter s of the hit, or -1 if none (analytic's collinear case needs the distance).
float ray_triangle_s(Ray r, int tri) {
    vec2 h = ray_triangle_crossing(r, tri);
    if (h.y == 0.0) {
        return -1.0;
    }
    float s = h.x / h.y;
    return s > 0.0 ? s : -1.0;
}

// ---- Conservative separating-axis tests -----------------------------------------------------
// True unless an axis separates the two sets by more than the tolerance; axes that degenerate
// (zero cross products: coplanar or degenerate triangles) are skipped, which only keeps more.
bool separated_on(vec3 axis, vec3 p0, vec3 p1, vec3 p2, vec3 q0, vec3 q1, vec3 q2, float scale) {
    float len2 = dot(axis, axis);
    if (len2 <= 1e-30 * scale * scale * scale * scale) {
        return false;
    }
    float a0 = dot(axis, p0), a1 = dot(axis, p1), a2 = dot(axis, p2);
    float b0 = dot(axis, q0), b1 = dot(axis, q1), b2 = dot(axis, q2);
    float tol = CONSERVATIVE_EPS * sqrt(len2) * scale;
    return min(min(b0, b1), b2) > max(max(a0, a1), a2) + tol
        || max(max(b0, b1), b2) < min(min(a0, a1), a2) - tol;
}

// Can triangle Q = (q0, q1, q2) meet triangle P = (p0, p1, p2)? Coordinates relative to p0.
// The eleven axes are written out: llvmpipe does not unroll a loop that can return early, and
// each of its trips would count against the invocation's loop budget.
bool triangles_may_meet(vec3 p0, vec3 p1, vec3 p2, vec3 q0, vec3 q1, vec3 q2) {
    p1 -= p0;
    p2 -= p0;
    q0 -= p0;
    q1 -= p0;
    q2 -= p0;
    p0 = vec3(0.0);
    float scale = max(max(max(length(p1), length(p2)), max(length(q0), length(q1))),
                      length(q2));
    vec3 ep0 = p1 - p0, ep1 = p2 - p1, ep2 = p0 - p2;
    vec3 eq0 = q1 - q0, eq1 = q2 - q1, eq2 = q0 - q2;
    return !(separated_on(cross(ep0, ep1), p0, p1, p2, q0, q1, q2, scale)
             || separated_on(cross(eq0, eq1), p0, p1, p2, q0, q1, q2, scale)
             || separated_on(cross(ep0, eq0), p0, p1, p2, q0, q1, q2, scale)
             || separated_on(cross(ep0, eq1), p0, p1, p2, q0, q1, q2, scale)
             || separated_on(cross(ep0, eq2), p0, p1, p2, q0, q1, q2, scale)
             || separated_on(cross(ep1, eq0), p0, p1, p2, q0, q1, q2, scale)
             || separated_on(cross(ep1, eq1), p0, p1, p2, q0, q1, q2, scale)
             || separated_on(cross(ep1, eq2), p0, p1, p2, q0, q1, q2, scale)
             || separated_on(cross(ep2, eq0), p0, p1, p2, q0, q1, q2, scale)
             || separated_on(cross(ep2, eq1), p0, p1, p2, q0, q1, q2, scale)
             || separated_on(cross(ep2, eq2), p0, p1, p2, q0, q1, q2, scale));
}

#include "triangle_box.glsl"

// ---- Cells ----------------------------------------------------------------------------------
int cell_index(ivec3 c) {
    return c.x + u_trace.grid_dims.x * (c.y + u_trace.grid_dims.y * c.z);
}

vec3 cell_centre(ivec3 c) {
    return u_trace.grid_origin + (vec3(c) + 0.5) * u_trace.grid_cell;
}
