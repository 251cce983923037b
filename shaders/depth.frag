#version 430
// Depth only: the rasteriser writes gl_FragCoord.z.
void main() {
}
