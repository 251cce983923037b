#version 430
// The scene frame, scaled to the window with the texture's linear filter and, with FXAA 1,
// anti-aliased on the way: edges are found by the luma of the four diagonal neighbours and the
// pixel is blurred along them (the "FXAA console" scheme of Timothy Lottes, NVIDIA 2011). Only
// the picture changes: the frame's own target and G-buffer are read, never written. Alpha (the
// renderer's maps-per-pixel count) is not shown.
uniform sampler2D u_frame;
in vec2 v_uv;
out vec4 f_color;

#if FXAA
const float EDGE_REDUCE_MIN = 1.0 / 128.0;  // keeps flat areas from being blurred
const float EDGE_REDUCE_MUL = 1.0 / 8.0;
const float SPAN_MAX = 8.0;                 // source pixels the blur may reach along an edge

float luma(vec3 c) {
    return dot(c, vec3(0.299, 0.587, 0.114));
}

vec3 antialiased(vec2 uv) {
    ivec2 size = textureSize(u_frame, 0);
    vec2 texel = 1.0 / vec2(size);
    // The neighbourhood is read unfiltered (cheaper on a software rasteriser), from the source
    // pixel under this one.
    ivec2 px = clamp(ivec2(uv * vec2(size)), ivec2(1), size - 2);
    vec3 centre = texture(u_frame, uv).rgb;
    float nw = luma(texelFetch(u_frame, px + ivec2(-1, -1), 0).rgb);
    float ne = luma(texelFetch(u_frame, px + ivec2(1, -1), 0).rgb);
    float sw = luma(texelFetch(u_frame, px + ivec2(-1, 1), 0).rgb);
    float se = luma(texelFetch(u_frame, px + ivec2(1, 1), 0).rgb);
    float m = luma(centre);
    float lo = min(m, min(min(nw, ne), min(sw, se)));
    float hi = max(m, max(max(nw, ne), max(sw, se)));
    // The edge runs across the luma gradient.
    vec2 dir = vec2(-((nw + ne) - (sw + se)), (nw + sw) - (ne + se));
    float reduce = max((nw + ne + sw + se) * 0.25 * EDGE_REDUCE_MUL, EDGE_REDUCE_MIN);
    float scale = 1.0 / (min(abs(dir.x), abs(dir.y)) + reduce);
    dir = clamp(dir * scale, vec2(-SPAN_MAX), vec2(SPAN_MAX)) * texel;
    vec3 near = 0.5 * (texture(u_frame, uv + dir * (1.0 / 3.0 - 0.5)).rgb
                       + texture(u_frame, uv + dir * (2.0 / 3.0 - 0.5)).rgb);
    vec3 wide = 0.5 * near + 0.25 * (texture(u_frame, uv - dir * 0.5).rgb
                                     + texture(u_frame, uv + dir * 0.5).rgb);
    // The wide blur crossed another edge when it leaves the neighbourhood's luma range.
    float w = luma(wide);
    return (w < lo || w > hi) ? near : wide;
}
#endif

void main() {
#if FXAA
    f_color = vec4(antialiased(v_uv), 1.0);
#else
    f_color = vec4(texture(u_frame, v_uv).rgb, 1.0);
#endif
}
