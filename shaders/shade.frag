#version 430
// Shading pass: each hard light's visibility from its maps, the surface lit by every light
// with its shading normal, and the G-buffer the dumps and the soft composite read. The dumps'
// normal and the shadow lookup's bias use the geometric normal, so shading cannot move a shadow.
// GBUFFER_LEAN (the window's raster soft shadows, game/soft/direct.py): the linear light is one
// more light, its visibility given per block (u_soft_blocks); where a block's pixels look it up,
// the composite adds the light after this pass, from the lean G-buffer. UNLIT: the G-buffer
// alone (the soft shadows' points).
#include "world.glsl"
#include "lighting.glsl"
#include "shadow.glsl"
#if GBUFFER == GBUFFER_LEAN
// The image store (mark_block) would otherwise have every fragment shaded before its depth test.
layout(early_fragment_tests) in;
#include "soft_blocks.glsl"
uniform sampler2D u_soft_blocks;  // each block's value (soft_blocks.glsl)
uniform vec3 u_soft_light;        // the segment's midpoint
uniform vec3 u_soft_radiance;     // the linear light's radiance, linear RGB
#endif

in vec3 v_world;
in vec3 v_normal;
flat in int v_object;
flat in vec3 v_colour;

layout(location = 0) out vec4 out_color;     // rgb shown; a = (1 + maps read) / 255, or with
                                             // COUNT_CANDIDATES (1 + map records considered) / 255
#if GBUFFER == GBUFFER_FULL
layout(location = 1) out vec4 out_position;  // xyz world position; w object index
layout(location = 2) out vec4 out_normal;    // xyz geometric normal, facing the camera; w vis.
layout(location = 3) out vec4 out_shading;   // xyz shading normal
layout(location = 4) out vec4 out_albedo;    // rgb sqrt of the linear base colour
#elif GBUFFER == GBUFFER_LEAN
layout(location = 1) out vec4 out_packed_normal;  // the geometric normal (pack_normal)
layout(location = 2) out vec4 out_light;     // rgb sqrt of the linear light's diffuse factor
#endif

vec3 heat(float t) {
    return clamp(vec3(1.5 * t, 1.5 - abs(2.0 * t - 1.0) * 1.5, 1.5 - 1.5 * t), 0.0, 1.0);
}

// What the lights leave at a fragment: its colour, the maps read, the map that decided light 0
// (-1: none), the visibility of light 0 (debug views) and of u_frame.dump_light (G-buffer), and
// the lights that reach it but are blocked.
struct Shaded {
    vec3 colour;
    int sampled, used;
    float kept, shown;
    int shadowed;
};

// Light k's share at the fragment, with g its geometric normal and n its shading normal.
void add_light(int k, vec3 g, vec3 n, inout Shaded o) {
    LightRecord light = u_lights[k];
    vec3 l = to_light(light, v_world);
    float reached = reach(light, v_world, l);
    int decider = -1;
    float vis = 0.0;
    // A light that cannot reach the fragment reads no map (its visibility counts as 0).
    if (reached > 0.0) {
        vis = shadow_visibility(light, v_world, g, v_object, o.sampled, decider);
    }
    o.colour += light_colour(v_colour, n, l, direct_light(g, l, vis, reached), light.radiance);
    o.shadowed += reached > 0.0 && dot(g, l) > 0.0 && vis < 0.5 ? 1 : 0;
    if (k == u_frame.dump_light) {
        o.kept = vis;
    }
    if (k == 0) {
        o.used = decider;
        o.shown = vis;
    }
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
    Shaded o;
    o.sampled = 0;
    o.used = -1;
    vec3 n = shading_normal(v_normal, g);
    o.colour = ambient_colour(v_colour, n);
    o.kept = 0.0;
    o.shown = 1.0;
    o.shadowed = 0;
#if UNLIT
#elif MANY_LIGHTS
    // Only the lights that can reach the fragment's screen tile (game/render/frame_blocks.py).
    // The count is read, not a #define: a loop of known length would be unrolled into one
    // copy of the lookup per light, a long shader to compile anew for each count. A do-while,
    // as in shaders/shadow.glsl: a for loop would pay for one more light, masked off.
    ivec2 tile = ivec2(gl_FragCoord.xy) / u_frame.tile_size;
    int t = u_frame.tile_base + tile.y * u_frame.tiles_x + tile.x;
    int j = u_grid[t], end = u_grid[t + 1];
    if (j < end) {
        do {
            add_light(u_grid[j], g, n, o);
            ++j;
        } while (j < end);
    }
#else
    add_light(0, g, n, o);
#endif
#if GBUFFER == GBUFFER_LEAN
    // The linear light's diffuse factor: what its visibility and radiance multiply.
    vec3 soft_l = normalize(u_soft_light - v_world);
    vec3 soft_factor = light_colour(v_colour, n, soft_l, direct_light(g, soft_l, 1.0, 1.0),
                                    vec3(1.0));
    ivec2 px = ivec2(gl_FragCoord.xy);
    float value = texelFetch(u_soft_blocks, px / int(u_point_at.x), 0).r;
    o.colour += soft_factor * max(block_visibility(px, value), 0.0) * u_soft_radiance;
    if (value == BLOCK_SKY) {
        mark_block(px);
    }
#endif
    vec3 colour = display(o.colour);
    // The debug view, like the shadow lookup's switches, is a #define (DEBUG_VIEW).
#if DEBUG_VIEW == DEBUG_MAP
    colour = (o.used < 0 ? vec3(0.5) : palette(o.used + 7)) * (0.55 + 0.45 * o.shown);
#elif DEBUG_VIEW == DEBUG_MAP_COUNT
    colour = heat(float(o.sampled) / 4.0);
#elif DEBUG_VIEW == DEBUG_SHADOWED_LIGHTS
    colour = o.shadowed == 0 ? vec3(0.25) : heat(float(o.shadowed - 1) / 3.0);
#elif DEBUG_VIEW == DEBUG_CACHE
    // The map that decided the pixel: red re-rendered this frame, green from the cache.
    bool fresh = (map_ref(max(o.used, 0)).flags & MAP_FRESH) != 0;
    vec3 state = fresh ? vec3(0.9, 0.3, 0.25) : vec3(0.3, 0.8, 0.35);
    colour = (o.used < 0 ? vec3(0.5) : state) * (0.55 + 0.45 * o.shown);
#endif
    out_color = vec4(colour, float(1 + o.sampled) / 255.0);
#if COUNT_CANDIDATES
    out_color.a = float(1 + min(g_candidates, 254)) / 255.0;
#endif
#if GBUFFER == GBUFFER_FULL
    out_position = vec4(v_world, float(v_object));
    out_normal = vec4(g, o.kept);
    out_shading = vec4(n, 0.0);
    out_albedo = vec4(sqrt(v_colour), 1.0);
#elif GBUFFER == GBUFFER_LEAN
    out_packed_normal = pack_normal(g);
    out_light = vec4(sqrt(clamp(soft_factor, 0.0, 1.0)), 1.0);
#endif
}
