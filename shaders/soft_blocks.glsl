// The window's raster soft shadows (game/soft/direct.py): the linear light's visibility given
// per block of the frame, and the lean G-buffer the composite reads where a pixel looks it up.
// Read by the shading pass (shade.frag, GBUFFER_LEAN) and by the composite (composite.frag,
// VIS_RUNS). Needs the BLOCK_* values (game/soft/block_values.py): a block's value is the
// visibility its points agree on (>= 0), or one of them.

uniform sampler2D u_soft_points;  // the points' visibility, one texel per block, bilinear
uniform vec2 u_point_at;          // the block's side, and where its point lies from its corner

// A block whose point lies in the sky, marked where a fragment of it shows geometry (a thin
// caster against the sky): its pixels look the light up in the composite. The shading pass
// alone writes it.
layout(r8) uniform writeonly image2D u_soft_marks;

void mark_block(ivec2 px) {
    imageStore(u_soft_marks, px / int(u_point_at.x), vec4(1.0));
}

// The points' visibility interpolated bilinearly at pixel px.
float interpolated_visibility(ivec2 px) {
    vec2 cell = (vec2(px) - u_point_at.y) / u_point_at.x + 0.5;
    return texture(u_soft_points, cell / vec2(textureSize(u_soft_points, 0))).r;
}

uniform sampler2D u_soft_history;  // the visibility a still view kept (BLOCK_CACHED)

// The visibility at pixel px of a block whose value is ``value``: -1 where the pixel looks it up.
float block_visibility(ivec2 px, float value) {
    if (value == BLOCK_LOOKUP) {
        return -1.0;
    }
    float smooth_vis = interpolated_visibility(px);
    float kept = texelFetch(u_soft_history, px, 0).r;
    return value >= 0.0 ? value
        : (value == BLOCK_INTERPOLATE ? smooth_vis : (value == BLOCK_CACHED ? kept : 0.0));
}

// A unit vector in 4 bytes: its octahedral coordinates at 16 bits each (Cigolle et al., "A
// Survey of Efficient Representations for Independent Unit Vectors", JCGT 2014).
vec4 pack_normal(vec3 v) {
    vec2 o = v.xy / (abs(v.x) + abs(v.y) + abs(v.z));
    if (v.z < 0.0) {
        o = (1.0 - abs(o.yx)) * mix(vec2(-1.0), vec2(1.0), greaterThanEqual(o, vec2(0.0)));
    }
    return unpackUnorm4x8(packUnorm2x16(o * 0.5 + 0.5));
}

vec3 unpack_normal(vec4 stored) {
    vec2 o = unpackUnorm2x16(packUnorm4x8(stored)) * 2.0 - 1.0;
    vec3 v = vec3(o, 1.0 - abs(o.x) - abs(o.y));
    if (v.z < 0.0) {
        v.xy = (1.0 - abs(v.yx)) * mix(vec2(-1.0), vec2(1.0), greaterThanEqual(v.xy, vec2(0.0)));
    }
    return normalize(v);
}
