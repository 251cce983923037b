#version 430
// Shading pass: flat shading, the hard light's visibility from the maps, and the G-buffer the
// dumps read (position, geometric normal, object, visibility).
#include "blocks.glsl"
#include "shadow.glsl"

in vec3 v_world;
flat in int v_object;

layout(location = 0) out vec4 out_color;     // rgb shaded; a = (1 + maps read) / 255
#if GBUFFER
layout(location = 1) out vec4 out_position;  // xyz world position; w object index
layout(location = 2) out vec4 out_normal;    // xyz unit normal facing the camera; w visibility
#endif

const float AMBIENT = 0.25;

#if SOFT
uniform sampler2D u_soft;   // the linear light's traced visibility per pixel (game/tracer.py)
uniform vec3 u_soft_light;  // the segment's midpoint: the soft light's direction for N.L
uniform bool u_soft_hard;   // true: u_soft is the hard light's traced visibility instead
#endif

vec3 palette(int i) {
    // Distinct, stable colours for object and map indices.
    float h = fract(float(i) * 0.618034 + 0.11);
    vec3 k = clamp(abs(fract(h + vec3(0.0, 2.0 / 3.0, 1.0 / 3.0)) * 6.0 - 3.0) - 1.0, 0.0, 1.0);
    return mix(vec3(0.85), k, 0.55);
}

vec3 heat(float t) {
    return clamp(vec3(1.5 * t, 1.5 - abs(2.0 * t - 1.0) * 1.5, 1.5 - 1.5 * t), 0.0, 1.0);
}

void main() {
    // Flat shading: the geometric normal from the screen derivatives of the world position
    // (exact for a triangle's plane), turned to face the camera.
    vec3 n = cross(dFdx(v_world), dFdy(v_world));
    float len = length(n);
    n = len > 0.0 ? n / len : normalize(u_camera_pos.xyz - v_world);
    if (dot(n, u_camera_pos.xyz - v_world) < 0.0) {
        n = -n;
    }
    int sampled, used;
    float vis = shadow_visibility(v_world, n, sampled, used);

    vec3 l = to_light(v_world);
    float cone = 1.0;
#if LIGHT_KIND == LIGHT_SPOT
    cone = smoothstep(u_light_pos.w, u_light_pos.w + 0.02, dot(-l, u_light_dir.xyz));
#endif
    bool floor_object = v_object < u_options.w;
    vec3 base = floor_object ? vec3(0.62, 0.64, 0.58) : palette(v_object);
    vec3 colour = base * (AMBIENT + (1.0 - AMBIENT) * max(dot(n, l), 0.0) * vis * cone);
#if SOFT
    float soft = texelFetch(u_soft, ivec2(gl_FragCoord.xy), 0).r;
    vec3 ls = u_soft_hard ? l : normalize(u_soft_light - v_world);
    colour = base * (AMBIENT + (1.0 - AMBIENT) * max(dot(n, ls), 0.0) * soft
                     * (u_soft_hard ? cone : 1.0));
#endif
    // The debug view, like the shadow lookup's switches, is a #define (DEBUG_VIEW).
#if DEBUG_VIEW == DEBUG_MAP
    colour = (used < 0 ? vec3(0.5) : palette(used + 7)) * (0.55 + 0.45 * vis);
#elif DEBUG_VIEW == DEBUG_MAP_COUNT
    colour = heat(float(sampled) / 4.0);
#elif DEBUG_VIEW == DEBUG_CACHE
    // The map that decided the pixel: red re-rendered this frame, green from the cache.
    vec3 state = u_maps[max(used, 0)].depth.z > 0.5 ? vec3(0.9, 0.3, 0.25) : vec3(0.3, 0.8, 0.35);
    colour = (used < 0 ? vec3(0.5) : state) * (0.55 + 0.45 * vis);
#endif
    out_color = vec4(colour, float(1 + sampled) / 255.0);
#if GBUFFER
    out_position = vec4(v_world, float(v_object));
    out_normal = vec4(n, vis);
#endif
}
