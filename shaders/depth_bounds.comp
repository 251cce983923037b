#version 430
// The depth bounds of one map's square: per block of BLOCK x BLOCK depth texels, their nearest
// and farthest depth (game/gpu/depth_bounds.py). The shading pass reads a block's bounds before
// its texel: a fragment nearer than the whole block is lit, one farther than all of it is in
// shadow, whichever texel its lookup would pick (shaders/shadow.glsl).
layout(local_size_x = 8, local_size_y = 8) in;

uniform sampler2DArray u_depth;   // the depth array, read through a sampler that does not compare
layout(rg32f) uniform writeonly image2DArray u_bounds;
uniform ivec3 u_square;           // the square's first block (x, y) and its layer
uniform int u_side;               // blocks per side of the square

void main() {
    ivec2 b = ivec2(gl_GlobalInvocationID.xy);
    if (b.x >= u_side || b.y >= u_side) {
        return;
    }
    b += u_square.xy;
    // Four texels a read: a gather at the corner the 2 x 2 texels share.
    vec2 texel = 1.0 / vec2(textureSize(u_depth, 0).xy);
    vec2 first = vec2(b * BLOCK + 1) * texel;
    vec4 nearest = vec4(1.0), farthest = vec4(0.0);
    for (int y = 0; y < BLOCK; y += 2) {
        for (int x = 0; x < BLOCK; x += 2) {
            vec4 d = textureGather(u_depth, vec3(first + vec2(x, y) * texel, float(u_square.z)));
            nearest = min(nearest, d);
            farthest = max(farthest, d);
        }
    }
    imageStore(u_bounds, ivec3(b, u_square.z),
               vec4(min(min(nearest.x, nearest.y), min(nearest.z, nearest.w)),
                    max(max(farthest.x, farthest.y), max(farthest.z, farthest.w)), 0.0, 0.0));
}
