#version 430
// Shading pass: the hard light's visibility from the maps, the surface lit with its shading
// normal, and the G-buffer the dumps and the soft composite read. The dumps' normal and the
// shadow lookup's bias use the geometric normal, so shading cannot move a shadow.
#include "world.glsl"
#include "lighting.glsl"
#include "shadow.glsl"

in vec3 v_world;
in vec3 v_normal;
flat in int v_object;
flat in vec3 v_colour;

layout(location = 0) out vec4 out_color;     // rgb shown; a = (1 + maps read) / 255
#if GBUFFER
layout(location = 1) out vec4 out_position;  // xyz world position; w object index
layout(location = 2) out vec4 out_normal;    // xyz geometric normal, facing the camera; w vis.
layout(location = 3) out vec4 out_shading;   // xyz shading normal
layout(location = 4) out vec4 out_albedo;    // rgb sqrt of the linear base colour
#endif

vec3 heat(float t) {
    return clamp(vec3(1.5 * t, 1.5 - abs(2.0 * t - 1.0) * 1.5, 1.5 - 1.5 * t), 0.0, 1.0);
}

void main() {
    // The geometric normal from the screen derivatives of the world position (exact for a
    // triangle's plane), turned to face the camera.
    vec3 g = cross(dFdx(v_world), dFdy(v_world));
    float len = length(g);
    g = len > 0.0 ? g / len : normalize(u_frame.camera_pos - v_world);
    if (dot(g, u_frame.camera_pos - v_world) < 0.0) {
        g = -g;
    }
    int sampled, used;
    float vis = shadow_visibility(v_world, g, v_object, sampled, used);

    vec3 n = shading_normal(v_normal, g);
    vec3 l = to_light(v_world);
    vec3 colour = display(lit_colour(v_colour, n, l, direct_light(g, l, vis, spot_cone(l))));
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
    out_normal = vec4(g, vis);
    out_shading = vec4(n, 0.0);
    out_albedo = vec4(sqrt(v_colour), 1.0);
#endif
}
