// Every uniform and storage block, declared once.
// Keep in sync with game/gpu_blocks.py (MAP_DTYPE, FRAME_DTYPE, BINDINGS); binding points and
// MAX_MAPS arrive as #defines from Python.

struct ShadowMap {      // keep in sync with gpu_blocks.MAP_DTYPE
    mat4 view_proj;     // world -> map clip
    vec4 params;        // x layer, y texel size (ortho m; perspective per m of depth), z perspective, w uv scale
    vec4 eye;           // xyz the map's eye; w caster kind (0 clump, 1 character, 2 all)
    vec4 bounds;        // orthographic maps: light-space rectangle (xmin, ymin, xmax, ymax)
    vec4 depth;         // orthographic maps: x near distance along the light, y 1 / (far - near);
                        // z 1 re-rendered this frame, 0 cached (debug view)
};

layout(std140, binding = FRAME_BINDING) uniform Frame {   // keep in sync with gpu_blocks.FRAME_DTYPE
    mat4 u_view_proj;
    mat4 u_light_rot;
    vec4 u_camera_pos;
    vec4 u_light_dir;   // xyz travel direction, w kind: 0 directional, 1 spot, 2 point
    vec4 u_light_pos;   // xyz position, w cos(half cone)
    vec4 u_bias;        // normal offset, depth bias, slope bias (texels), max slope
    vec4 u_grid_rect;
    ivec4 u_counts;     // maps, grid mode, grid size, debug view
    ivec4 u_options;    // pcf, first character object, objects, floors (objects below are floors)
    // Grid mode, debug view, pcf and the light's kind are filled in too, but the shading
    // program takes them as #defines instead (see shadow.glsl).
};

layout(std140, binding = MAPS_BINDING) uniform ShadowMaps {
    ShadowMap u_maps[MAX_MAPS];
};

// Light-space grid of map lists: u_grid[0 .. n*n] are offsets into the same array, where the
// map indices of each cell follow (see game/map_grid.py).
layout(std430, binding = GRID_BINDING) readonly buffer MapGrid {
    int u_grid[];
};

// Model matrices of the characters, indexed by object - u_options.y.
layout(std430, binding = MODELS_BINDING) readonly buffer Models {
    mat4 u_models[];
};

// Per character, the index of its map in u_maps this frame (-1: none).
layout(std430, binding = CHARACTER_MAPS_BINDING) readonly buffer CharacterMaps {
    int u_character_maps[];
};

vec3 world_position(vec3 position, int object) {
    int character = object - u_options.y;
    if (character < 0) {
        return position;   // floors and statics are stored in world space
    }
    return (u_models[character] * vec4(position, 1.0)).xyz;
}
