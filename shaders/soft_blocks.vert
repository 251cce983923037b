#version 430
// The soft composite drawn over runs of blocks (game/soft/direct.py): each run is a rectangle of
// the frame in pixels, with the visibility its blocks agree on (or -1 where each pixel looks it
// up), handed to composite.frag as a flat input.
uniform vec2 u_size;    // the frame, pixels

in vec2 in_pixel;       // a corner of the run, pixels from the frame's bottom-left
in float in_vis;

flat out float v_vis;

void main() {
    v_vis = in_vis;
    gl_Position = vec4(in_pixel / u_size * 2.0 - 1.0, 0.0, 1.0);
}
