// Lighting shared by the shading pass and the soft composite (needs blocks/frame.glsl, and
// LIGHT_KIND as a #define): the direction to the hard light, its cone, and how a surface is lit
// and shown. Lighting is computed in linear RGB; `display` is the one output transform.

// Light reaching the scene, linear RGB. The sun is warm, the sky's ambient blue from above and
// the ground's a warm bounce from below; the tone map rolls off what exceeds 1.
const vec3 SUN_RADIANCE = vec3(1.00, 0.93, 0.82) * 1.6;
const vec3 SKY_AMBIENT = vec3(0.45, 0.55, 0.75) * 0.6;
const vec3 GROUND_AMBIENT = vec3(0.40, 0.34, 0.27) * 0.4;

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

// The shading normal made to agree with the geometric one: interpolated across a triangle it may
// tip past the surface's own side, and a surface seen from behind (an open mesh) shades as its
// side facing the camera.
vec3 shading_normal(vec3 interpolated, vec3 geometric) {
    float len = length(interpolated);
    if (len < 1e-6) {
        return geometric;
    }
    vec3 n = interpolated / len;
    return dot(n, geometric) < 0.0 ? -n : n;
}

// How much of the light reaches a surface point: its visibility times the spot's cone, and none
// where the triangle (geometric normal ``g``) faces away, whatever its shading normal says.
float direct_light(vec3 g, vec3 l, float vis, float cone) {
    return dot(g, l) > 0.0 ? vis * cone : 0.0;
}

// Linear radiance of a diffuse surface: hemispheric ambient plus the light, scaled by how much of
// the light the surface sees (`direct`: visibility times the spot's cone).
vec3 lit_colour(vec3 albedo, vec3 n, vec3 l, float direct) {
    vec3 ambient = mix(GROUND_AMBIENT, SKY_AMBIENT, 0.5 + 0.5 * n.y);
    return albedo * (ambient + SUN_RADIANCE * max(dot(n, l), 0.0) * direct);
}

// Linear radiance to the display: a filmic tone map (Narkowicz's fit of the ACES curve), then
// the sRGB transfer function.
vec3 display(vec3 x) {
    vec3 mapped = clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
    return mix(mapped * 12.92, 1.055 * pow(mapped, vec3(1.0 / 2.4)) - 0.055,
               step(0.0031308, mapped));
}
