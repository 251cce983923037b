#version 430
// segment-maps: the linear light's visibility as the mean, over K points along the segment, of
// a depth-map test from each (brute accumulation of point-light shadow maps; Heidrich, Brabec
// and Seidel, "Soft Shadow Maps for Linear Lights", 2000, sample the same maps). A point below
// the receiver's horizon is hidden, as the tracer's samples are.
#include "soft_maps.glsl"

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    if (texelFetch(u_colour, px, 0).a <= 0.0) {
        f_visibility = -1.0;
        return;
    }
    vec3 p = texelFetch(u_position, px, 0).xyz;
    vec3 n = normalize(texelFetch(u_normal, px, 0).xyz);
    float sum = 0.0;
    for (int k = 0; k < u_maps; ++k) {
        vec3 to_light = u_map_eye[k].xyz - p;
        float cos_n = dot(n, to_light) / max(length(to_light), 1e-9);
        if (cos_n > 0.0) {
            sum += map_test(k, p, n, cos_n);
        }
    }
    f_visibility = sum / float(u_maps);
}
