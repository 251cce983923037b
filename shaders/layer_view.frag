#version 430
// One layer of the shadow-map depth array as grey levels (near the light = bright), for the
// overlay's layer viewer. Sampled through a sampler object with depth compare off.
uniform sampler2DArray u_maps;
uniform int u_layer;
uniform float u_extent;   // the share of the layer's side the map's square takes
uniform vec2 u_offset;    // where that square starts (uv)
in vec2 v_uv;
out vec4 f_color;

const vec3 EMPTY = vec3(0.05, 0.05, 0.25);   // cleared texels: no caster

void main() {
    float depth = texture(u_maps, vec3(u_offset + v_uv * u_extent, float(u_layer))).r;
    f_color = vec4(depth >= 1.0 ? EMPTY : vec3(1.0 - depth), 1.0);
}
