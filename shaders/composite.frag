#version 430
// The soft composite: the frame lit again through a traced visibility, from its G-buffer alone
// (the scene is not drawn again). HARD 0: the linear light's soft shadows, its direction taken
// from the segment's midpoint, in the first light's colour; HARD 1: the first hard light's exact
// shadows (the traced method).
// The arithmetic is the shading pass's (shade.frag, lighting.glsl), so a pixel lit by the same
// visibility gets the same colour.
#include "blocks/frame.glsl"
#include "lighting.glsl"

uniform sampler2D u_position;    // xyz world position; w object index
uniform sampler2D u_normal;      // xyz geometric unit normal facing the camera
uniform sampler2D u_colour;      // the shaded frame: a > 0 where geometry covers the pixel
uniform sampler2D u_shading;     // xyz shading normal
uniform sampler2D u_albedo;      // rgb sqrt of the linear base colour
uniform sampler2D u_visibility;  // the traced visibility of the pixel's surface point
#if !HARD
uniform vec3 u_soft_light;       // the segment's midpoint
#endif

out vec4 out_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 frame = texelFetch(u_colour, px, 0);
    if (frame.a == 0.0) {
        out_color = frame;   // no geometry: the sky, as the shading pass cleared it
        return;
    }
    vec3 p = texelFetch(u_position, px, 0).xyz;
    vec3 g = texelFetch(u_normal, px, 0).xyz;
    vec3 n = texelFetch(u_shading, px, 0).xyz;
    vec3 albedo = texelFetch(u_albedo, px, 0).rgb;
    float vis = texelFetch(u_visibility, px, 0).r;
    LightRecord light = u_lights[0];
#if HARD
    vec3 l = to_light(light, p);
    float reached = reach(light, p, l);
#else
    vec3 l = normalize(u_soft_light - p);
    float reached = 1.0;
#endif
    albedo *= albedo;
    vec3 colour = ambient_colour(albedo, n)
        + light_colour(albedo, n, l, direct_light(g, l, vis, reached), light.radiance);
    out_color = vec4(display(colour), frame.a);
}
