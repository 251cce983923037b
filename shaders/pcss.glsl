// pcss: percentage-closer soft shadows (Fernando, "Percentage-Closer Soft Shadows", 2005) for a
// linear light, from one map at the segment's centre (map 0). Seen from the centre, the
// triangle that the receiver and the segment span is a line through the receiver's texel along
// the segment's image, so the blocker search and the filter run along that line:
//   1. blocker search: BLOCKER_TAPS taps between the receiver and where the triangle reaches
//      the map's near plane, half to each side; a tap is a blocker where the map is nearer than
//      the receiver's plane there (with IN_TRIANGLE, only where that depth lies inside the
//      triangle);
//   2. the penumbra from the blockers' mean depth, by similar triangles;
//   3. FILTER_TAPS bilinear depth compares along the line over that penumbra.
// The part of the segment below the receiver's horizon is hidden exactly. Read by the lookup
// pass (pcss.frag) and by the soft composite (composite.frag).
#include "soft_maps.glsl"

uniform sampler2DArray u_maps_depth;  // the same array, read as depth
uniform mat4 u_inv_view_proj;         // map 0's clip space -> world
uniform vec3 u_light_a;
uniform vec3 u_light_b;

// Map 0's uv of a world point.
vec2 uv_of(vec3 q) {
    vec4 clip = u_view_proj[0] * vec4(q, 1.0);
    return clip.xy / clip.w * 0.5 + 0.5;
}

// Depth along map 0's axis of a world point.
float depth_of(vec3 q) {
    return (u_view_proj[0] * vec4(q, 1.0)).w;
}

// Depth of the receiver's plane (p, n) along the map's ray through uv; -1 where the ray runs
// along the plane or meets it behind the eye.
float plane_depth(vec2 uv, vec3 p, vec3 n) {
    vec4 far_point = u_inv_view_proj * vec4(uv * 2.0 - 1.0, 1.0, 1.0);
    vec3 eye = u_map_eye[0].xyz;
    vec3 dir = far_point.xyz / far_point.w - eye;   // the ray to the far plane: depth = far
    float across = dot(dir, n);
    if (abs(across) < 1e-12) {
        return -1.0;
    }
    float s = dot(p - eye, n) / across;
    return s > 0.0 ? s * u_map_range[0].y : -1.0;
}

// The casters' depth at uv (the walkers' layer holds the statics too), in metres.
float map_depth(vec2 uv) {
    return linear_depth(texture(u_maps_depth, vec3(uv, float(map_layer(0)))).r, u_map_range[0]);
}

// The point at depth z on the way from p (depth zr) to the light point s.
vec3 toward(vec3 p, float zr, vec3 s, float z) {
    float lambda = clamp((zr - z) / max(zr - depth_of(s), 1e-6), 0.0, 1.0);
    return mix(p, s, lambda);
}

// Whether the point q lies inside the triangle of p and the segment's part [t0, t1].
bool in_triangle(vec3 p, vec3 q, float t0, float t1) {
    vec3 w = q - p, e = u_light_b - u_light_a, r = u_light_a - p;
    float ww = dot(w, w), we = dot(w, e), ee = dot(e, e);
    float det = we * we - ww * ee;
    if (abs(det) < 1e-12 * ww * ee) {
        return false;
    }
    float mu = (we * dot(e, r) - dot(w, r) * ee) / det;
    float t = (ww * dot(e, r) - we * dot(w, r)) / det;
    return mu >= 1.0 && t >= t0 && t <= t1;
}

// Metres per texel at depth z.
float texel_at(float z) {
    return u_map_eye[0].w * z;
}

// How far along d the map goes from uv (inside it): the largest f <= 1 with uv + f d inside.
float inside_share(vec2 uv, vec2 d) {
    vec2 room = mix(-uv, vec2(1.0) - uv, greaterThan(d, vec2(0.0)));
    vec2 f = mix(vec2(1.0), room / d, greaterThan(abs(d), vec2(1e-12)));
    return clamp(min(f.x, f.y), 0.0, 1.0);
}

// The blockers' depth sum and count along one half of the search, from the receiver's texel uv
// toward the end where the triangle meets the near plane, clipped to the map. Taps crowd toward
// uv as the share to the power SEARCH_POWER: blockers near the receiver, whose shadows are the
// sharp ones, cover only the part of the line near it.
vec2 search_half(vec3 p, vec3 n, vec2 uv, vec2 end, float t0, float t1, float jitter) {
    vec3 eye = u_map_eye[0].xyz;
    vec2 d = end - uv;
    float reach = inside_share(uv, d);
    vec2 found = vec2(0.0);
    for (int i = 0; i < BLOCKER_TAPS / 2; ++i) {
        float f = reach * pow((float(i) + jitter) / float(BLOCKER_TAPS / 2), SEARCH_POWER);
        vec2 at = uv + f * d;
        float zp = plane_depth(at, p, n);
        float zb = map_depth(at);
        if (zp <= 0.0 || zb >= zp - DEPTH_BIAS_TEXELS * texel_at(zp)) {
            continue;
        }
        vec4 far_point = u_inv_view_proj * vec4(at * 2.0 - 1.0, 1.0, 1.0);
        vec3 q = eye + (far_point.xyz / far_point.w - eye) * (zb / u_map_range[0].y);
        if (bool(IN_TRIANGLE) && !in_triangle(p, q, t0, t1)) {
            continue;
        }
        found += vec2(zb, 1.0);
    }
    return found;
}

// The share of FILTER_TAPS bilinear compares along uv0..uv1 that see past the map's depth.
float filtered(vec3 p, vec3 n, float cos_n, vec2 uv0, vec2 uv1, float jitter) {
    float lit = 0.0;
    for (int i = 0; i < FILTER_TAPS; ++i) {
        vec2 uv = mix(uv0, uv1, (float(i) + jitter) / float(FILTER_TAPS));
        float zp = plane_depth(uv, p, n);
        if (zp <= 0.0 || any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)))) {
            lit += 1.0;
            continue;
        }
        float ref = window_depth(zp - receiver_bias(cos_n, texel_at(zp)), u_map_range[0]);
        lit += texture(u_maps_compare, vec4(uv, float(map_layer(0)), ref));
    }
    return lit / float(FILTER_TAPS);
}

// The visibility of the segment from p (unit normal n facing the camera), at pixel px (the
// taps' jitter).
float pcss_visibility(ivec2 px, vec3 p, vec3 n) {
    // The part [t0, t1] of the segment above the receiver's horizon.
    float ha = dot(u_light_a - p, n), hb = dot(u_light_b - p, n);
    if (ha <= 0.0 && hb <= 0.0) {
        return 0.0;
    }
    float cross_t = ha / (ha - hb);
    float t0 = ha > 0.0 ? 0.0 : cross_t;
    float t1 = hb > 0.0 ? 1.0 : cross_t;
    vec3 s0 = mix(u_light_a, u_light_b, t0), s1 = mix(u_light_a, u_light_b, t1);
    vec3 centre = u_map_eye[0].xyz;
    vec3 to_light = centre - p;
    float cos_n = max(dot(n, to_light) / max(length(to_light), 1e-9), 0.0);
    float texel_m = texel_at(max(depth_of(p), 0.0));
    vec3 q = p + n * (NORMAL_BIAS_TEXELS * texel_m);
    float zr = depth_of(q);
    vec2 uv;
    if (!map_uv(u_view_proj[0] * vec4(q, 1.0), uv)) {
        return t1 - t0;
    }
    float jitter = bool(JITTER) ? pixel_jitter(px) : 0.5;
    float near = u_map_range[0].x;
    vec2 found = search_half(q, n, uv, uv_of(toward(q, zr, s0, near)), t0, t1, jitter)
               + search_half(q, n, uv, uv_of(toward(q, zr, s1, near)), t0, t1, jitter);
    if (found.y == 0.0) {
        return t1 - t0;
    }
    float zb = found.x / found.y;
    vec2 uv0 = uv_of(toward(q, zr, s0, zb)), uv1 = uv_of(toward(q, zr, s1, zb));
    return (t1 - t0) * filtered(q, n, cos_n, uv0, uv1, jitter);
}
