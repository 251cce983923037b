// Lighting shared by the shading pass and the soft composite (needs blocks/frame.glsl, and
// LIGHT_KIND as a #define): the objects' colours, the direction to the hard light, its cone.

const float AMBIENT = 0.25;

vec3 palette(int i) {
    // Distinct, stable colours for object and map indices.
    float h = fract(float(i) * 0.618034 + 0.11);
    vec3 k = clamp(abs(fract(h + vec3(0.0, 2.0 / 3.0, 1.0 / 3.0)) * 6.0 - 3.0) - 1.0, 0.0, 1.0);
    return mix(vec3(0.85), k, 0.55);
}

vec3 base_colour(int object) {
    bool floor_object = object < u_frame.floor_count;
    return floor_object ? vec3(0.62, 0.64, 0.58) : palette(object);
}

vec3 to_light(vec3 p) {
#if LIGHT_KIND == LIGHT_DIRECTIONAL
    return -u_frame.light_dir;
#else
    return normalize(u_frame.light_pos - p);
#endif
}

// The spot light's cone, softened over a small band of cos; 1 for other lights. ``l`` points
// from the surface to the light.
float spot_cone(vec3 l) {
    float cone = 1.0;
#if LIGHT_KIND == LIGHT_SPOT
    cone = smoothstep(u_frame.cos_half_cone, u_frame.cos_half_cone + 0.02, dot(-l, u_frame.light_dir));
#endif
    return cone;
}
