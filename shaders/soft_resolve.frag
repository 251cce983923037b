#version 430
// The window's soft picture (game/soft/accumulate.py): the accumulated means of the pixel and
// its 3 x 3 neighbours, each weighted by its samples and by how well its surface continues the
// pixel's own (the depth and normal weights of upsample.frag), and this frame's upsampled
// trace with the weight of one sample, less as the pixel's own samples grow. A pixel of a
// still view thus starts from the few-frame picture, filtered along the geometry, and ends at
// its own mean; a pixel that started again (a walker moved) shows this frame's trace.
// A pixel with OWN_ENOUGH samples of its own shows its own mean: the neighbours and the
// current trace are then skipped, which llvmpipe turns into saved work wherever a whole batch
// of pixels has that many (a still view, away from the walkers).
// Constants: PLANE_SIGMA, NORMAL_POWER, NO_SAMPLE, NEIGHBOUR_FADE, OWN_ENOUGH.

uniform sampler2D u_history;    // (mean, samples, object, distance) per pixel
uniform sampler2D u_current;    // this frame's trace, upsampled
uniform sampler2D u_position;
uniform sampler2D u_normal;
uniform sampler2D u_colour;

layout(location = 0) out vec4 out_visibility;

float geometry_weight(vec3 p, vec3 n, vec3 q, vec3 m) {
    vec3 step = q - p;
    float len = length(step);
    float off_plane = len > 0.0 ? abs(dot(step, n)) / len : 0.0;
    float plane = exp(-(off_plane * off_plane) / (PLANE_SIGMA * PLANE_SIGMA));
    return plane * pow(max(dot(n, m), 0.0), NORMAL_POWER);
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    if (texelFetch(u_colour, px, 0).a == 0.0) {
        out_visibility = vec4(1.0);
        return;
    }
    ivec2 size = textureSize(u_colour, 0);
    vec3 p = texelFetch(u_position, px, 0).xyz;
    vec3 n = texelFetch(u_normal, px, 0).xyz;
    vec4 mine = texelFetch(u_history, px, 0);
    float own = mine.y;
    if (own >= OWN_ENOUGH) {
        out_visibility = vec4(mine.x);
        return;
    }
    // Neighbours count less as the pixel's own samples grow: the picture converges to the
    // pixel's own mean, not to a blur of it.
    float spread = 1.0 / (1.0 + own / NEIGHBOUR_FADE);
    float current = 1.0 / (1.0 + own * own);
    float total = current;
    float sum = current * texelFetch(u_current, px, 0).r;
    for (int j = -1; j <= 1; ++j) {
        for (int i = -1; i <= 1; ++i) {
            ivec2 q = px + ivec2(i, j);
            if (any(lessThan(q, ivec2(0))) || any(greaterThanEqual(q, size))) {
                continue;
            }
            vec4 h = texelFetch(u_history, q, 0);
            if (h.y == 0.0) {
                continue;
            }
            float w = h.y;
            if (i != 0 || j != 0) {
                w *= spread * exp(-0.5 * float(i * i + j * j)) * geometry_weight(
                    p, n, texelFetch(u_position, q, 0).xyz, texelFetch(u_normal, q, 0).xyz);
            }
            total += w;
            sum += w * h.x;
        }
    }
    out_visibility = vec4(sum / total);
}
