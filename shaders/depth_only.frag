#version 430
// The camera pass's depth, drawn before the shading pass (game/render/shading_pass.py): no
// colour, so llvmpipe runs no shader work per fragment beyond the depth test.
void main() {
}
