// The frame's blocks (generated from game/gpu/blocks.py) and the world position of a vertex.
#include "blocks/frame.glsl"

vec3 world_position(vec3 position, int object) {
    int character = object - u_frame.first_character;
    if (character < 0) {
        return position;   // floors and statics are stored in world space
    }
    return (u_models[character] * vec4(position, 1.0)).xyz;
}
