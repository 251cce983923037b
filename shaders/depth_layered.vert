#version 430
#extension GL_ARB_shader_viewport_layer_array : require
// Every character's map in one draw: each vertex goes to its character's layer (gl_Layer from
// the vertex shader), so the per-frame maps cost one framebuffer, not one per character.
#include "world.glsl"

in vec3 in_position;
in int in_object;

void main() {
    int map = u_character_maps[in_object - u_frame.first_character];
    if (map < 0) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);   // no map this frame (outside a spot's cone)
        return;
    }
    vec4 clip = u_maps[map].view_proj * vec4(world_position(in_position, in_object), 1.0);
    // The map uses the corner share uv_scale of its layer: squeeze clip x, y from [-w, w] into
    // [-w, (2 share - 1) w]. What falls beyond lands in the unused rest of the layer.
    float share = u_maps[map].uv_scale;
    clip.xy = (clip.xy + clip.w) * share - clip.w;
    gl_Layer = u_maps[map].layer;
    gl_Position = clip;
}
