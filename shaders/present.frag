#version 430
// The scene frame, scaled to the window with the texture's linear filter. Alpha (the renderer's
// maps-per-pixel count) is not shown.
uniform sampler2D u_frame;
in vec2 v_uv;
out vec4 f_color;

void main() {
    f_color = vec4(texture(u_frame, v_uv).rgb, 1.0);
}
