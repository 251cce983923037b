// What the raster soft methods' lookups share (segment_maps.glsl, pcss.glsl): the maps' records
// (game/soft/raster.py sets them from game/soft/map_frusta.py), perspective depth in and out of
// the window's [0, 1], and a map's lookup, 1.0 outside its bounds.
// Needs MAX_SOFT_MAPS, NORMAL_BIAS_TEXELS, DEPTH_BIAS_TEXELS, SLOPE_BIAS_TEXELS and MAX_SLOPE.

uniform sampler2DArrayShadow u_maps_compare;  // the depth array, bilinear depth compare

uniform mat4 u_view_proj[MAX_SOFT_MAPS];  // world -> map k's clip space
uniform vec4 u_map_eye[MAX_SOFT_MAPS];    // xyz the light point; w metres per texel per metre
uniform vec2 u_map_range[MAX_SOFT_MAPS];  // near, far
uniform int u_map_count;   // K: layers 0..K-1 hold the statics
uniform bool u_dynamic;   // layers K..2K-1 hold the statics and the walkers (read those)

// PCG hash (Jarzynski and Olano, "Hash Functions for GPU Rendering", JCGT 2020).
uint soft_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// A value in [0, 1) per pixel, for the filters' jitter.
float pixel_jitter(ivec2 px) {
    return float(soft_hash(uint(px.x) * 65521u + uint(px.y)) >> 8u) * (1.0 / 16777216.0);
}

// Depth along the map's axis (metres) of a depth-buffer value in [0, 1].
float linear_depth(float d, vec2 range) {
    return range.x * range.y / (range.y - d * (range.y - range.x));
}

// The depth-buffer value of a depth along the map's axis.
float window_depth(float z, vec2 range) {
    float n = range.x, f = range.y;
    return clamp(f / (f - n) - f * n / ((f - n) * max(z, n)), 0.0, 1.0);
}

// Where a clip-space point falls in its map, or false outside it (behind the eye included).
bool map_uv(vec4 clip, out vec2 uv) {
    uv = clip.xy / clip.w * 0.5 + 0.5;
    return clip.w > 0.0 && all(lessThanEqual(abs(clip.xy), vec2(clip.w)));
}

// The depth bias of a receiver whose normal makes cos_n with the way to the light, in metres,
// for texels of texel_m metres: constant plus slope-scaled, as the hard maps bias theirs.
float receiver_bias(float cos_n, float texel_m) {
    float tan_n = sqrt(max(1.0 - cos_n * cos_n, 0.0)) / max(cos_n, 1e-6);
    return (DEPTH_BIAS_TEXELS + SLOPE_BIAS_TEXELS * min(tan_n, MAX_SLOPE)) * texel_m;
}

// The layer that holds every caster seen from point k.
int map_layer(int k) {
    return u_dynamic ? u_map_count + k : k;
}

// Map k's test of receiver p (normal n, cos_n toward the map's eye) against the statics' layer
// (the walkers' layer when there are walkers): 1 lit, 0 hidden, a fraction on an edge; 1.0 outside the map.
float map_test(int k, vec3 p, vec3 n, float cos_n) {
    float texel_m = u_map_eye[k].w * max((u_view_proj[k] * vec4(p, 1.0)).w, 0.0);
    vec4 clip = u_view_proj[k] * vec4(p + n * (NORMAL_BIAS_TEXELS * texel_m), 1.0);
    vec2 uv;
    if (!map_uv(clip, uv)) {
        return 1.0;
    }
    float ref = window_depth(clip.w - receiver_bias(cos_n, texel_m), u_map_range[k]);
    return texture(u_maps_compare, vec4(uv, float(map_layer(k)), ref));
}
