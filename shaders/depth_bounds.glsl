// Depth bounds of a block of BOUNDS_BLOCK x BOUNDS_BLOCK depth texels (game/gpu/depth_bounds.py),
// two uints in one of two forms, told apart by x's top bit (a depth is never negative):
// - level (top bit set): the nearest and the farthest depth of the block, x's other bits and y
//   being their float bits;
// - sloped: a plane through the block's depths and its spread: every texel's depth, at offset c
//   in texels from the block's centre, lies in plane(c) +- spread. Kept where it is tighter than
//   the level form: on a caster's own sloped surface, whose fragments lie the bias nearer the
//   light than its texels, but within its nearest and farthest. x holds the plane's depth at the
//   centre as a 23-bit fraction of [0, 1], then the spread's code in the low 8 bits: the bits of
//   a float with a 5-bit exponent and 3 bits of mantissa, which decodes exactly on any device,
//   and to at least the spread it was made from; y holds the slopes, depth per texel along x and
//   y, as two halves.

const uint BOUNDS_LEVEL = 0x80000000u;
const float BOUNDS_CENTRE = 0.5 * float(BOUNDS_BLOCK - 1);
const float BOUNDS_MID_SCALE = 8388607.0;    // 2^23 - 1
const uint BOUNDS_SPREAD_FIRST = 800u;       // (127 - 27) << 3: the least spread is 2^-27

float bounds_mid(uvec2 q) {
    return float(q.x >> 8) * (1.0 / BOUNDS_MID_SCALE);
}

vec2 bounds_slope(uvec2 q) {
    return unpackHalf2x16(q.y);
}

float bounds_spread(uvec2 q) {
    return uintBitsToFloat(((q.x & 255u) + BOUNDS_SPREAD_FIRST) << 20);
}

// A sloped form's plane at c, texels from the block's centre.
float bounds_plane(uvec2 q, vec2 c) {
    return bounds_mid(q) + dot(bounds_slope(q), c);
}

// The nearest and farthest depth the bounds allow to the texels within `reach` texels, along
// each axis, of the one at c.
vec2 bounds_range(uvec2 q, vec2 c, float reach) {
    vec2 slope = bounds_slope(q);
    float plane = bounds_plane(q, c);
    float spread = bounds_spread(q) + reach * (abs(slope.x) + abs(slope.y));
    return q.x >= BOUNDS_LEVEL ? vec2(uintBitsToFloat(q.x & ~BOUNDS_LEVEL), uintBitsToFloat(q.y))
                               : vec2(plane - spread, plane + spread);
}
