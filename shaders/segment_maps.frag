#version 430
// segment-maps' lookup over a G-buffer into an R32F target (segment_maps.glsl).
#include "segment_maps.glsl"

uniform sampler2D u_position;  // xyz world position
uniform sampler2D u_normal;    // xyz unit normal facing the camera
uniform sampler2D u_colour;    // a > 0 where geometry covers the pixel

layout(location = 0) out float f_visibility;   // -1 where no geometry

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    if (texelFetch(u_colour, px, 0).a <= 0.0) {
        f_visibility = -1.0;
        return;
    }
    vec3 p = texelFetch(u_position, px, 0).xyz;
    f_visibility = segment_visibility(p, normalize(texelFetch(u_normal, px, 0).xyz));
}
