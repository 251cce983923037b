// The frame's blocks (generated from game/gpu/blocks.py), the world position of a vertex and the
// world direction of its normal, and the objects' palette.
#include "blocks/frame.glsl"

vec3 world_position(vec3 position, int object) {
    int character = object - u_frame.first_character;
    if (character < 0) {
        return position;   // floors and statics are stored in world space
    }
    return (u_models[character] * vec4(position, 1.0)).xyz;
}

// A character's model matrix is a turn and a move (rigid), so its 3x3 part turns normals too.
vec3 world_direction(vec3 direction, int object) {
    int character = object - u_frame.first_character;
    if (character < 0) {
        return direction;
    }
    return mat3(u_models[character]) * direction;
}

vec3 palette(int i) {
    // Distinct, stable colours for object and map indices.
    float h = fract(float(i) * 0.618034 + 0.11);
    vec3 k = clamp(abs(fract(h + vec3(0.0, 2.0 / 3.0, 1.0 / 3.0)) * 6.0 - 3.0) - 1.0, 0.0, 1.0);
    return mix(vec3(0.85), k, 0.55);
}

// The base colour of an object the scene gave no colour, as linear RGB: floors a stone grey,
// everything else a stronger shade of the palette's colour (sRGB values, hence the square).
vec3 base_colour(int object) {
    bool floor_object = object < u_frame.floor_count;
    vec3 srgb = floor_object ? vec3(0.60, 0.60, 0.56) : mix(vec3(0.85), palette(object), 1.25);
    return srgb * srgb;
}
