#version 430
// Joint bilateral upsampling of a traced visibility (Kopf, Cohen, Lischinski and Uyttendaele,
// "Joint Bilateral Upsampling", SIGGRAPH 2007), guided by the full-resolution G-buffer: every
// pixel averages the traced samples around it, each weighted by its distance on the screen and
// by how well its surface continues the pixel's own (the same plane, the same facing). A sample
// across a depth or normal edge gets next to no weight, so a shadow stops where the geometry
// changes instead of bleeding across, as a plain bilinear upscale would.
//
// The samples are the last trace's, one per block of u_divisor x u_divisor pixels
// (subsample.frag picked them: texel x of row y holds block (x + u_shift) mod u_cells.x), the
// GATHER x GATHER blocks around the pixel; in two draws, PART 0 and PART 1 (below). The
// accumulation over frames is soft_accumulate.frag's and soft_resolve.frag's.
// Constants (game/soft/upsample.py): PLANE_SIGMA, NORMAL_POWER, SPATIAL_SIGMA_CELLS,
// MIN_WEIGHT, GATHER, NO_SAMPLE, OWN_ENOUGH.

uniform sampler2D u_position;   // full resolution: xyz world position
uniform sampler2D u_normal;     // xyz geometric unit normal facing the camera
uniform sampler2D u_colour;     // a > 0 where geometry covers the pixel
uniform sampler2D u_samples;    // per block: xyz its traced pixel's position, w the visibility
                                // (NO_SAMPLE: no geometry)
uniform sampler2D u_sample_normals;  // per block: rgb its normal * 0.5 + 0.5
uniform sampler2D u_agreed;     // per block: the value all the samples agree on that the
                                // filter weighs where this block is the first (first_cell),
                                // or NO_SAMPLE
uniform int u_divisor;          // block side, pixels
uniform ivec2 u_phase;          // the traced pixel of each block, from its corner
uniform int u_shift;            // see subsample.frag
uniform ivec2 u_cells;          // blocks per row and column
uniform sampler2D u_history;    // the accumulation's (mean, samples, ...) per pixel

layout(location = 0) out vec4 out_visibility;

// How well a sample at q (normal m) continues the pixel's surface at p (normal n): the sine of
// the angle between the step p -> q and p's tangent plane (0 on the same plane, whatever its
// slant on the screen), and the agreement of the normals.
float geometry_weight(vec3 p, vec3 n, vec3 q, vec3 m) {
    vec3 step = q - p;
    float len = length(step);
    float off_plane = len > 0.0 ? abs(dot(step, n)) / len : 0.0;
    float plane = exp(-(off_plane * off_plane) / (PLANE_SIGMA * PLANE_SIGMA));
    return plane * pow(max(dot(n, m), 0.0), NORMAL_POWER);
}

// The texel of the reduced trace that holds block ``cell`` (see subsample.frag; 0 <= u_shift <
// u_cells.x). Without an integer modulo, which llvmpipe computes lane by lane.
ivec2 texel_of(ivec2 cell) {
    int x = cell.x - u_shift;
    return ivec2(x < 0 ? x + u_cells.x : x, cell.y);
}

// The first of the GATHER blocks per side that the filter weighs at px: those around px, the
// same number on each side (GATHER even) or centred on the nearest (GATHER odd).
ivec2 first_cell(ivec2 px) {
    vec2 at = vec2(px - u_phase) / float(u_divisor) + 0.5 * float(GATHER % 2);
    return ivec2(floor(at)) - (GATHER - 1) / 2;
}

// The value all the samples the filter would weigh at px agree on, or NO_SAMPLE.
float agreed(ivec2 px) {
    ivec2 cell = first_cell(px);
    if (any(lessThan(cell, ivec2(0))) || any(greaterThanEqual(cell, u_cells))) {
        return NO_SAMPLE;
    }
    return texelFetch(u_agreed, texel_of(cell), 0).r;
}

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    // No geometry: 1, and the composite shows the sky as it is.
    bool sky = texelFetch(u_colour, px, 0).a == 0.0;
    // Where all the samples agree (most of a frame: wholly lit or in the umbra), any weighting
    // gives that value. The sky and those pixels are one draw (PART 0), the filter over the
    // others a second (PART 1), each discarding the other's pixels: llvmpipe runs both sides of
    // a branch under a mask, but stops a batch of pixels once all of them are discarded, so
    // the filter costs only where it is needed.
    float same = sky ? 1.0 : agreed(px);
    // A pixel with OWN_ENOUGH samples of its own shows its own mean (soft_resolve.frag):
    // nothing to upsample.
    if (texelFetch(u_history, px, 0).y >= OWN_ENOUGH) {
        discard;
    }
#if PART == 0
    if (same == NO_SAMPLE) {
        discard;
    }
    out_visibility = vec4(same);
}
#else
    if (same != NO_SAMPLE) {
        discard;
    }
#endif
#if PART == 1
    ivec2 size = textureSize(u_colour, 0);
    vec3 p = texelFetch(u_position, px, 0).xyz;
    vec3 n = texelFetch(u_normal, px, 0).xyz;
    float total = 0.0;
    float sum = 0.0;
    float best_weight = -1.0;   // the sample that continues the surface best: the fallback
    float best = 1.0;
    float sigma = SPATIAL_SIGMA_CELLS * float(u_divisor);
    ivec2 first = first_cell(px);
    for (int j = 0; j < GATHER; ++j) {
        for (int i = 0; i < GATHER; ++i) {
            ivec2 cell = first + ivec2(i, j);
            ivec2 q = cell * u_divisor + u_phase;
            if (any(lessThan(cell, ivec2(0))) || any(greaterThanEqual(cell, u_cells))) {
                continue;
            }
            ivec2 texel = texel_of(cell);
            vec4 sample_ = texelFetch(u_samples, texel, 0);
            float v = sample_.w;
            if (v == NO_SAMPLE) {
                continue;   // no geometry there, or its pixel outside the frame
            }
            vec3 q_position = sample_.xyz;
            vec3 q_normal = texelFetch(u_sample_normals, texel, 0).xyz * 2.0 - 1.0;
            float g = geometry_weight(p, n, q_position, q_normal);
            vec2 d = vec2(q - px);
            float w = g * exp(-dot(d, d) / (2.0 * sigma * sigma));
            total += w;
            sum += w * v;
            if (g > best_weight) {
                best_weight = g;
                best = v;
            }
        }
    }
    out_visibility = vec4(total > MIN_WEIGHT ? sum / total : best);
}
#endif
