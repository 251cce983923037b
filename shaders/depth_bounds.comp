#version 430
// The depth bounds of one map's square: per block of BOUNDS_BLOCK x BOUNDS_BLOCK depth texels,
// their nearest and farthest depth, or a plane and how far the texels lie from it, whichever is
// the tighter (shaders/depth_bounds.glsl, game/gpu/depth_bounds.py). The shading pass reads a
// block's bounds before its texels: a fragment nearer the light than they allow at the texels
// it would read is lit, one farther is in shadow (shaders/shadow.glsl).
layout(local_size_x = 8, local_size_y = 8) in;
#include "depth_bounds.glsl"

uniform sampler2DArray u_depth;   // the depth array, read through a sampler that does not compare
layout(rg32ui) uniform writeonly uimage2DArray u_bounds;
uniform ivec3 u_square;           // the square's first block (x, y) and its layer
uniform int u_side;               // blocks per side of the square

// Added to every spread: the shading pass evaluates the plane in its own float arithmetic, which
// may round otherwise than this pass's by a few units in the last place of a depth in [0, 1].
const float MARGIN = 1.0 / 2097152.0;   // 2^-21: four units in the last place at 1.0, eight below
// The sum of the squared offsets from the centre along one axis, over the block's texels.
const float SQUARES = float(BOUNDS_BLOCK * BOUNDS_BLOCK * (BOUNDS_BLOCK * BOUNDS_BLOCK - 1)) / 12.0;

// The four texels a gather at the corner after texel (x, y) reads, as offsets from (x, y), in
// the gather's order: (x, y+1), (x+1, y+1), (x+1, y), (x, y).
const vec4 GATHER_X = vec4(0.0, 1.0, 1.0, 0.0);
const vec4 GATHER_Y = vec4(1.0, 1.0, 0.0, 0.0);

// The least code whose spread is at least e (rounded up: the mantissa bits below the three kept
// carry one into them); above 255 where the code cannot hold it.
uint spread_code(float e) {
    uint bits = floatBitsToUint(max(e, 0.0));
    uint top = (bits >> 20) + ((bits & 0xFFFFFu) != 0u ? 1u : 0u);
    return uint(max(int(top) - int(BOUNDS_SPREAD_FIRST), 0));
}

// The smallest normal half: a slope below it would be stored as a subnormal half, which a
// device may flush to zero when it packs or unpacks, and read as another plane than the one the
// spread was measured from.
const float HALF_NORMAL = 1.0 / 16384.0;

// A plane in the sloped form (shaders/depth_bounds.glsl), its spread's code left at 0.
uvec2 plane_form(float mid, vec2 slope) {
    uint m = uint(clamp(mid, 0.0, 1.0) * BOUNDS_MID_SCALE + 0.5);
    slope = mix(slope, vec2(0.0), lessThan(abs(slope), vec2(HALF_NORMAL)));
    return uvec2(m << 8, packHalf2x16(slope));
}

vec4 texels(vec2 first, vec2 texel, int x, int y) {
    return textureGather(u_depth, vec3(first + vec2(x, y) * texel, float(u_square.z)));
}

void main() {
    ivec2 b = ivec2(gl_GlobalInvocationID.xy);
    if (b.x >= u_side || b.y >= u_side) {
        return;
    }
    b += u_square.xy;
    // Four texels a read: a gather at the corner the 2 x 2 texels share.
    vec2 texel = 1.0 / vec2(textureSize(u_depth, 0).xy);
    vec2 first = vec2(b * BOUNDS_BLOCK + 1) * texel;
    vec4 nearest = vec4(1.0), farthest = vec4(0.0), sum = vec4(0.0), sum_x = vec4(0.0),
         sum_y = vec4(0.0);
    for (int y = 0; y < BOUNDS_BLOCK; y += 2) {
        for (int x = 0; x < BOUNDS_BLOCK; x += 2) {
            vec4 d = texels(first, texel, x, y);
            nearest = min(nearest, d);
            farthest = max(farthest, d);
            sum += d;
            sum_x += d * (float(x) - BOUNDS_CENTRE + GATHER_X);
            sum_y += d * (float(y) - BOUNDS_CENTRE + GATHER_Y);
        }
    }
    float lo = min(min(nearest.x, nearest.y), min(nearest.z, nearest.w));
    float hi = max(max(farthest.x, farthest.y), max(farthest.z, farthest.w));
    vec4 ones = vec4(1.0);
    // The least-squares plane (the offsets are centred, so its terms part), made as the shading
    // pass will read it, then its texels' greatest distance from it.
    uvec2 fit = plane_form(dot(sum, ones) / float(BOUNDS_BLOCK * BOUNDS_BLOCK),
                           vec2(dot(sum_x, ones), dot(sum_y, ones)) / SQUARES);
    vec4 off = vec4(0.0);
    // A block of one depth (open sky, or a caster's flat face square to the light) keeps the
    // level form, which is exact: its texels need no second walk.
    int rows = hi > lo ? BOUNDS_BLOCK : 0;
    for (int y = 0; y < rows; y += 2) {
        for (int x = 0; x < BOUNDS_BLOCK; x += 2) {
            vec4 d = texels(first, texel, x, y);
            vec2 c = vec2(x, y) - BOUNDS_CENTRE;
            vec4 plane = vec4(bounds_plane(fit, c + vec2(GATHER_X.x, GATHER_Y.x)),
                              bounds_plane(fit, c + vec2(GATHER_X.y, GATHER_Y.y)),
                              bounds_plane(fit, c + vec2(GATHER_X.z, GATHER_Y.z)),
                              bounds_plane(fit, c + vec2(GATHER_X.w, GATHER_Y.w)));
            off = max(off, abs(d - plane));
        }
    }
    // The plane's own bits, so that the spread holds of the plane as stored.
    uint code = spread_code(max(max(off.x, off.y), max(off.z, off.w)) + MARGIN);
    uvec2 sloped = uvec2(fit.x | min(code, 255u), fit.y);
    // The level form is exact and kept unless the plane's band is the narrower.
    uvec2 level = uvec2(floatBitsToUint(lo) | BOUNDS_LEVEL, floatBitsToUint(hi));
    uvec2 kept = code <= 255u && 2.0 * bounds_spread(sloped) < hi - lo ? sloped : level;
    imageStore(u_bounds, ivec3(b, u_square.z), uvec4(kept, 0u, 0u));
}
