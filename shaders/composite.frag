#version 430
// The soft composite: the frame lit again through a traced visibility, from its G-buffer alone
// (the scene is not drawn again). HARD 0: the linear light is one more light. The shading pass's
// picture, every scene light with its hard shadows, is taken back to linear radiance
// (undisplay), and the linear light's diffuse term, through its soft visibility, is added to
// it; its direction is taken from the segment's midpoint, its radiance is u_soft_radiance.
// HARD 1: the first hard light's exact shadows (the traced method) replace its maps'.
// The arithmetic is the shading pass's (shade.frag, lighting.glsl), so a pixel lit by the same
// visibility gets the same colour.
// Where the visibility comes from (VIS_SOURCE): VIS_TEXTURE, a texture of the frame's size (the
// tracer's, or the window's accumulation), with the full G-buffer; or VIS_RUNS, drawn over runs
// of blocks (soft_blocks.vert, game/soft/direct.py) with the lean G-buffer, by what the run
// says: its blocks' value (soft_blocks.glsl); or, with LOOKUP_RUNS, the raster method's own
// lookup at the pixel (LOOKUP 0: segment-maps, segment_maps.glsl; 1: pcss, pcss.glsl), at the
// world position the depth gives back.
// OUT_VISIBILITY writes the visibility instead of the colour (to measure it). REFINE (lookup runs
// over the blocks a still view kept, game/soft/still_lookups.py) adds the lookup, made with maps
// from other points of the segment, to the pixel's kept mean and leaves the picture as it is.
#define VIS_TEXTURE 0
#define VIS_RUNS 1
#include "blocks/frame.glsl"
#include "lighting.glsl"
#if LOOKUP_RUNS && LOOKUP == 0
#include "segment_maps.glsl"
#elif LOOKUP_RUNS
#include "pcss.glsl"
#endif

uniform sampler2D u_colour;      // the shaded frame: a > 0 where geometry covers the pixel
#if VIS_SOURCE == VIS_TEXTURE
uniform sampler2D u_position;    // xyz world position; w object index
uniform sampler2D u_normal;      // xyz geometric unit normal facing the camera
uniform sampler2D u_shading;     // xyz shading normal
uniform sampler2D u_albedo;      // rgb sqrt of the linear base colour
uniform sampler2D u_visibility;  // the traced visibility of the pixel's surface point
#else
#include "soft_blocks.glsl"
flat in float v_vis;             // the run's blocks' value
uniform sampler2D u_depth;       // the frame's depth
uniform sampler2D u_packed_normal;  // the geometric normal (pack_normal)
uniform sampler2D u_light;       // rgb sqrt of the linear light's diffuse factor
uniform mat4 u_clip_to_world;   // the frame's clip space -> world
#if LOOKUP_RUNS && !OUT_VISIBILITY
// What a still view keeps of each looked-up pixel (game/soft/still_lookups.py): the mean of
// its lookups, and how many sets of maps it holds (apart: the shading pass reads the mean).
#if REFINE
layout(r32f) uniform image2D u_soft_kept;
layout(r32f) uniform image2D u_soft_sets;
#else
layout(r32f) uniform writeonly image2D u_soft_kept;
layout(r32f) uniform writeonly image2D u_soft_sets;
#endif
#endif

// The world position of the surface at pixel px, from its depth.
vec3 world_at(ivec2 px) {
    vec2 ndc = (vec2(px) + 0.5) / vec2(textureSize(u_depth, 0)) * 2.0 - 1.0;
    vec4 w = u_clip_to_world * vec4(ndc, texelFetch(u_depth, px, 0).r * 2.0 - 1.0, 1.0);
    return w.xyz / w.w;
}
#endif
#if !HARD
uniform vec3 u_soft_light;       // the segment's midpoint
uniform vec3 u_soft_radiance;    // the linear light's radiance, linear RGB

// The inverse of ``display`` (lighting.glsl): the sRGB transfer undone, then the tone map's
// quadratic solved for its non-negative root. A value at the tone map's ceiling stays there:
// adding light to it cannot show.
vec3 undisplay(vec3 shown) {
    vec3 y = mix(shown / 12.92, pow((shown + 0.055) / 1.055, vec3(2.4)),
                 step(0.04045, shown));
    y = min(y, vec3(0.999));
    vec3 a = 2.43 * y - 2.51;
    vec3 b = 0.59 * y - 0.03;
    vec3 c = 0.14 * y;
    return max((-b - sqrt(b * b - 4.0 * a * c)) / (2.0 * a), vec3(0.0));
}
#endif

out vec4 out_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 frame = texelFetch(u_colour, px, 0);
    if (frame.a == 0.0) {
#if OUT_VISIBILITY
        out_color = vec4(-1.0);
        return;
#endif
        out_color = frame;   // no geometry: the sky, as the shading pass cleared it
        return;
    }
#if VIS_SOURCE == VIS_TEXTURE
    vec3 p = texelFetch(u_position, px, 0).xyz;
    vec3 g = texelFetch(u_normal, px, 0).xyz;
    vec3 n = texelFetch(u_shading, px, 0).xyz;
    vec3 albedo = texelFetch(u_albedo, px, 0).rgb;
    float vis = texelFetch(u_visibility, px, 0).r;
#elif LOOKUP_RUNS && LOOKUP == 0
    float vis = segment_visibility(world_at(px),
                                   unpack_normal(texelFetch(u_packed_normal, px, 0)));
#elif LOOKUP_RUNS
    float vis = pcss_visibility(px, world_at(px),
                                unpack_normal(texelFetch(u_packed_normal, px, 0)));
#else
    float vis = max(block_visibility(px, v_vis), 0.0);
#endif
#if OUT_VISIBILITY
    out_color = vec4(vis, 0.0, 0.0, 1.0);
    return;
#elif REFINE
    float sets = v_vis == BLOCK_REFINE_START ? 0.0 : imageLoad(u_soft_sets, px).r;
    float kept = v_vis == BLOCK_REFINE_START ? 0.0 : imageLoad(u_soft_kept, px).r;
    imageStore(u_soft_kept, px, vec4((kept * sets + vis) / (sets + 1.0)));
    imageStore(u_soft_sets, px, vec4(sets + 1.0));
    out_color = frame;
    return;
#elif LOOKUP_RUNS
    imageStore(u_soft_kept, px, vec4(vis));
    imageStore(u_soft_sets, px, vec4(1.0));
#endif
#if HARD
    LightRecord light = u_lights[0];
    vec3 l = to_light(light, p);
    float reached = reach(light, p, l);
    albedo *= albedo;
    vec3 colour = ambient_colour(albedo, n)
        + light_colour(albedo, n, l, direct_light(g, l, vis, reached), light.radiance);
#elif VIS_SOURCE == VIS_TEXTURE
    vec3 l = normalize(u_soft_light - p);
    albedo *= albedo;
    vec3 colour = undisplay(frame.rgb)
        + light_colour(albedo, n, l, direct_light(g, l, vis, 1.0), u_soft_radiance);
#else
    vec3 factor = texelFetch(u_light, px, 0).rgb;
    vec3 colour = undisplay(frame.rgb) + factor * factor * vis * u_soft_radiance;
#endif
    out_color = vec4(display(colour), frame.a);
}
