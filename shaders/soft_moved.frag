#version 430
// The window's raster soft shadows in a still view (game/soft/still_lookups.py): whether the
// light triangle of each point (the point and the linear light's segment) may cross a box
// that a walker moved through since the last frame: its shadow there may have changed.
// Constants: MAX_BOXES.
#include "triangle_box.glsl"

uniform sampler2D u_position;    // the points' G-buffer: xyz world position
uniform sampler2D u_colour;      // a > 0 where the point shows geometry
uniform vec3 u_light_a;
uniform vec3 u_light_b;
uniform int u_boxes;             // boxes in use
uniform vec3 u_box_centre[MAX_BOXES];
uniform vec3 u_box_half[MAX_BOXES];

out vec4 out_moved;

void main() {
    ivec2 cell = ivec2(gl_FragCoord.xy);
    vec3 p = texelFetch(u_position, cell, 0).xyz;
    bool moved = false;
    for (int i = 0; i < u_boxes && !moved; ++i) {
        moved = triangle_may_touch_box(p, u_light_a, u_light_b, u_box_centre[i], u_box_half[i]);
    }
    out_moved = vec4(moved && texelFetch(u_colour, cell, 0).a > 0.0 ? 1.0 : 0.0);
}
