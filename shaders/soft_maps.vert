#version 430
// The raster soft methods' depth maps (game/soft/light_maps.py): casters already in world space,
// seen from one point of the linear light. The fragment stage is depth.frag.
uniform mat4 u_view_proj;  // world -> the map's clip space

in vec3 in_position;

void main() {
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
