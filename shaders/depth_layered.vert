#version 430
#extension GL_ARB_shader_viewport_layer_array : require
// Every character's map of one light in one draw: each vertex goes to its character's layer
// (gl_Layer from the vertex shader), so the per-frame maps cost one framebuffer, not one per
// character. With several lights, one draw per light that has character maps this frame.
#include "world.glsl"

uniform int u_light;  // whose character maps: index into u_lights

in vec3 in_position;
in int in_object;

// The map's own square of the layer: the four sides of its clip volume, kept as clip planes
// because the layer's other squares hold other maps (GL_CLIP_DISTANCE0..3, enabled by
// game/render/shadow_pass.py).
out float gl_ClipDistance[4];

void main() {
    int map = u_character_maps[u_lights[u_light].first_character_map + in_object
                               - u_frame.first_character];
    if (map < 0) {
        gl_Position = vec4(2.0, 2.0, 2.0, 1.0);   // no map this frame (outside a spot's cone)
        return;
    }
    vec4 clip = u_maps[map].view_proj * vec4(world_position(in_position, in_object), 1.0);
    gl_ClipDistance[0] = clip.w - clip.x;
    gl_ClipDistance[1] = clip.w + clip.x;
    gl_ClipDistance[2] = clip.w - clip.y;
    gl_ClipDistance[3] = clip.w + clip.y;
    // The map takes the share uv_scale of its layer's side from uv_offset: squeeze clip x, y
    // from [-w, w] into [(2 offset - 1) w, (2 (offset + share) - 1) w].
    float share = u_maps[map].uv_scale;
    clip.xy = (clip.xy + clip.w) * share + (2.0 * u_maps[map].uv_offset - 1.0) * clip.w;
    gl_Layer = u_maps[map].layer;
    gl_Position = clip;
}
