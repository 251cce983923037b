#version 430
// The window's soft accumulation: a running mean of the traced visibility per pixel, over the
// frames of a still view (game/soft/accumulate.py). Ping-pong: reads the last history, writes
// the next. A history texel is (mean, samples, object index, distance from the camera).
//
// A pixel starts again (samples 0) when the view changed (u_reset), when its surface is no
// longer the one its history was taken on (another object, or another distance: a walker
// moved in front or away), or when its light triangle (the pixel's point and the segment) may
// cross a box that a walker moved through since the last frame: its shadow may have changed.
// This frame's traced pixels (one per block, shaders/subsample.frag) then add their value.
// Constants: NO_SAMPLE, MAX_BOXES, DEPTH_TOLERANCE.
#include "triangle_box.glsl"

uniform sampler2D u_history;    // the last frame's history
uniform sampler2D u_position;   // full resolution: xyz world position; w object index
uniform sampler2D u_colour;     // a > 0 where geometry covers the pixel
uniform sampler2D u_samples;    // per block: xyz the traced pixel's position, w its visibility
uniform int u_divisor;
uniform ivec2 u_phase;          // the traced pixel of each block, from its corner
uniform int u_shift;            // see subsample.frag
uniform ivec2 u_cells;
uniform bool u_traced;          // whether this frame traced anything
uniform bool u_reset;           // the view changed: every pixel starts again
uniform vec3 u_camera;
uniform vec3 u_light_a;
uniform vec3 u_light_b;
uniform int u_boxes;            // boxes in use
uniform vec3 u_box_centre[MAX_BOXES];
uniform vec3 u_box_half[MAX_BOXES];

layout(location = 0) out vec4 out_history;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    if (texelFetch(u_colour, px, 0).a == 0.0) {
        out_history = vec4(NO_SAMPLE, 0.0, -1.0, 0.0);
        return;
    }
    vec4 position = texelFetch(u_position, px, 0);
    vec3 p = position.xyz;
    float distance = length(p - u_camera);
    vec4 last = texelFetch(u_history, px, 0);
    bool fresh = u_reset || last.z != position.w
        || abs(last.w - distance) > DEPTH_TOLERANCE * distance;
    for (int i = 0; i < u_boxes && !fresh; ++i) {
        fresh = triangle_may_touch_box(p, u_light_a, u_light_b, u_box_centre[i],
                                          u_box_half[i]);
    }
    float mean = fresh ? 0.0 : last.x;
    float count = fresh ? 0.0 : last.y;
    ivec2 offset = px - u_phase;
    ivec2 cell = offset / u_divisor;
    if (u_traced && all(greaterThanEqual(offset, ivec2(0))) && cell * u_divisor == offset
            && all(lessThan(cell, u_cells))) {
        int x = cell.x - u_shift;
        float v = texelFetch(u_samples, ivec2(x < 0 ? x + u_cells.x : x, cell.y), 0).w;
        if (v != NO_SAMPLE) {
            count += 1.0;
            mean += (v - mean) / count;
        }
    }
    out_history = vec4(count > 0.0 ? mean : NO_SAMPLE, count, position.w, distance);
}
