#version 430
// Shading pass: flat shading, the hard light's visibility from the maps, and the G-buffer the
// dumps read (position, geometric normal, object, visibility).
#include "world.glsl"
#include "lighting.glsl"
#include "shadow.glsl"

in vec3 v_world;
flat in int v_object;

layout(location = 0) out vec4 out_color;     // rgb shaded; a = (1 + maps read) / 255
#if GBUFFER
layout(location = 1) out vec4 out_position;  // xyz world position; w object index
layout(location = 2) out vec4 out_normal;    // xyz unit normal facing the camera; w visibility
#endif

vec3 heat(float t) {
    return clamp(vec3(1.5 * t, 1.5 - abs(2.0 * t - 1.0) * 1.5, 1.5 - 1.5 * t), 0.0, 1.0);
}

void main() {
    // Flat shading: the geometric normal from the screen derivatives of the world position
    // (exact for a triangle's plane), turned to face the camera.
    vec3 n = cross(dFdx(v_world), dFdy(v_world));
    float len = length(n);
    n = len > 0.0 ? n / len : normalize(u_frame.camera_pos - v_world);
    if (dot(n, u_frame.camera_pos - v_world) < 0.0) {
        n = -n;
    }
    int sampled, used;
    float vis = shadow_visibility(v_world, n, v_object, sampled, used);

    vec3 l = to_light(v_world);
    float cone = spot_cone(l);
    vec3 base = base_colour(v_object);
    vec3 colour = base * (AMBIENT + (1.0 - AMBIENT) * max(dot(n, l), 0.0) * vis * cone);
    // The debug view, like the shadow lookup's switches, is a #define (DEBUG_VIEW).
#if DEBUG_VIEW == DEBUG_MAP
    colour = (used < 0 ? vec3(0.5) : palette(used + 7)) * (0.55 + 0.45 * vis);
#elif DEBUG_VIEW == DEBUG_MAP_COUNT
    colour = heat(float(sampled) / 4.0);
#elif DEBUG_VIEW == DEBUG_CACHE
    // The map that decided the pixel: red re-rendered this frame, green from the cache.
    vec3 state = u_maps[max(used, 0)].fresh != 0 ? vec3(0.9, 0.3, 0.25) : vec3(0.3, 0.8, 0.35);
    colour = (used < 0 ? vec3(0.5) : state) * (0.55 + 0.45 * vis);
#endif
    out_color = vec4(colour, float(1 + sampled) / 255.0);
#if GBUFFER
    out_position = vec4(v_world, float(v_object));
    out_normal = vec4(n, vis);
#endif
}
