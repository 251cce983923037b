#version 430
// Shadow-map pass: casters into one layer of the depth array.
#include "world.glsl"

uniform int u_map;   // index into u_maps

in vec3 in_position;
in int in_object;

void main() {
    gl_Position = u_maps[u_map].view_proj * vec4(world_position(in_position, in_object), 1.0);
}
