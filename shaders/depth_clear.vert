#version 430
#extension GL_ARB_shader_viewport_layer_array : require
// Clears the corner share of each character map's layer to the far depth: one instanced quad
// per map, drawn with the depth test set to always pass.
#include "blocks.glsl"

void main() {
    int map = u_character_maps[gl_InstanceID];
    vec2 corner = vec2(gl_VertexID & 1, gl_VertexID >> 1);
    float share = map < 0 ? 0.0 : u_maps[map].params.w;
    gl_Position = vec4(corner * 2.0 * share - 1.0, 1.0, 1.0);
    gl_Layer = map < 0 ? 0 : int(u_maps[map].params.x);
}
