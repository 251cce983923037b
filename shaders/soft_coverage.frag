#version 430
// The window's raster soft shadows (game/soft/direct.py): whether any pixel of each block of
// u_divisor x u_divisor shows geometry, from the shaded frame's colour (a > 0 where it does).
// A block whose point lies in the sky but whose pixels do not all (a thin caster against the
// sky) looks the light up at each pixel.

uniform sampler2D u_colour;
uniform int u_divisor;

out vec4 out_covered;

void main() {
    ivec2 corner = ivec2(gl_FragCoord.xy) * u_divisor;
    ivec2 size = textureSize(u_colour, 0);
    float covered = 0.0;
    for (int y = 0; y < u_divisor; ++y) {
        for (int x = 0; x < u_divisor; ++x) {
            ivec2 q = min(corner + ivec2(x, y), size - 1);
            covered = max(covered, texelFetch(u_colour, q, 0).a);
        }
    }
    out_covered = vec4(covered > 0.0 ? 1.0 : 0.0);
}
