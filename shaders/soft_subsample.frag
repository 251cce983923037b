#version 430
// The raster soft methods' points in the window (game/soft/direct.py): one full-resolution
// G-buffer pixel per block of u_divisor x u_divisor, always the same one (u_phase), copied as it
// is, so that the maps' frusta, planned around these points, stay put while the view does.
// The colour's red channel says whether the block's coverage is mixed: some of its pixels show
// geometry and some the sky (a thin caster against the sky can fall between the points).

uniform sampler2D u_position;   // full resolution: xyz world position; w object index
uniform sampler2D u_normal;     // xyz geometric unit normal facing the camera
uniform sampler2D u_colour;     // a > 0 where geometry covers the pixel
uniform int u_divisor;          // block side, pixels
uniform ivec2 u_phase;          // the pixel of each block copied, from its corner

layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out vec4 out_colour;

void main() {
    ivec2 corner = ivec2(gl_FragCoord.xy) * u_divisor;
    ivec2 size = textureSize(u_colour, 0);
    ivec2 px = min(corner + u_phase, size - 1);
    int covered = 0, seen = 0;
    for (int y = 0; y < u_divisor; ++y) {
        for (int x = 0; x < u_divisor; ++x) {
            ivec2 q = corner + ivec2(x, y);
            if (all(lessThan(q, size))) {
                covered += texelFetch(u_colour, q, 0).a > 0.0 ? 1 : 0;
                seen += 1;
            }
        }
    }
    out_position = texelFetch(u_position, px, 0);
    out_normal = texelFetch(u_normal, px, 0);
    vec4 colour = texelFetch(u_colour, px, 0);
    out_colour = vec4(covered > 0 && covered < seen ? 1.0 : 0.0, 0.0, 0.0, colour.a);
}
