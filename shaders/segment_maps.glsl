// segment-maps: the linear light's visibility as the mean, over K points along the segment, of
// a depth-map test from each (brute accumulation of point-light shadow maps; Heidrich, Brabec
// and Seidel, "Soft Shadow Maps for Linear Lights", 2000, sample the same maps). A point below
// the receiver's horizon is hidden, as the tracer's samples are. Read by the lookup pass
// (segment_maps.frag) and by the soft composite (composite.frag).
#include "soft_maps.glsl"

// Map k's share: its test, or 0 where its point is below the receiver's horizon.
float segment_step(int k, vec3 p, vec3 n) {
    vec3 to_light = u_map_eye[k].xyz - p;
    float cos_n = dot(n, to_light) / max(length(to_light), 1e-9);
    return cos_n > 0.0 ? map_test(k, p, n, cos_n) : 0.0;
}

// The visibility of the segment from p (unit normal n facing the camera).
float segment_visibility(vec3 p, vec3 n) {
    float sum = 0.0;
    for (int k = 0; k < u_map_count; ++k) {
        sum += segment_step(k, p, n);
    }
    return sum / float(u_map_count);
}
