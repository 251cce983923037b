#version 430
// One triangle over the whole viewport (no vertex buffer): vertices 0, 1, 2 land on
// (0, 0), (2, 0), (0, 2) in UV, so the visible square is UV 0..1.
out vec2 v_uv;

void main() {
    vec2 uv = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    v_uv = uv;
    gl_Position = vec4(uv * 2.0 - 1.0, 0.0, 1.0);
}
