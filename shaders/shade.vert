#version 430
// Shading pass: every object seen from the camera.
#include "world.glsl"

in vec3 in_position;
in int in_object;

out vec3 v_world;
flat out int v_object;

void main() {
    v_world = world_position(in_position, in_object);
    v_object = in_object;
    gl_Position = u_frame.view_proj * vec4(v_world, 1.0);
}
