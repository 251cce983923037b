#version 430
// Shading pass: every object seen from the camera.
#include "world.glsl"

in vec3 in_position;
in int in_object;
in vec3 in_normal;   // the shading normal (game/scene/normals.py)
in vec3 in_colour;   // the object's base colour, linear RGB; negative: the palette's

out vec3 v_world;
out vec3 v_normal;
flat out int v_object;
flat out vec3 v_colour;
// The depth pass (depth_only.frag) runs this shader too, and must find the same depths to the
// bit: it stores each a step farther, and the shading pass's nearest fragments pass against
// that step alone (game/render/shading_pass.py, _depth_pass).
invariant gl_Position;

void main() {
    v_world = world_position(in_position, in_object);
    v_normal = world_direction(in_normal, in_object);
    v_object = in_object;
    v_colour = in_colour.r < 0.0 ? base_colour(in_object) : in_colour;
    gl_Position = u_frame.view_proj * vec4(v_world, 1.0);
}
