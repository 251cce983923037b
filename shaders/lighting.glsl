// Lighting shared by the shading pass and the soft composite (needs blocks/frame.glsl, and
// LIGHT_KIND, GRID and MANY_LIGHTS as #defines): the lights' records, the direction to a light, its
// cone and range, and how a surface is lit and shown. Lighting is computed in linear RGB;
// `display` is the one output transform.

// The sky's ambient is blue from above and the ground's a warm bounce from below, both scaled by
// u_frame.ambient (the sky lights' brightness); the tone map rolls off what exceeds 1.
const vec3 SKY_AMBIENT = vec3(0.45, 0.55, 0.75) * 0.6;
const vec3 GROUND_AMBIENT = vec3(0.40, 0.34, 0.27) * 0.4;

// With one light its kind and map-grid mode are #defines, so every test of them below folds
// away; with several (MANY_LIGHTS 1) they are read from each light's record.
#if MANY_LIGHTS
#define KIND_OF(light) (light).kind
#define GRID_OF(light) (light).grid_mode
#else
#define KIND_OF(light) LIGHT_KIND
#define GRID_OF(light) GRID
#endif

vec3 to_light(LightRecord light, vec3 p) {
    return KIND_OF(light) == LIGHT_DIRECTIONAL ? -light.direction : normalize(light.position - p);
}

// How much of the light its spot cone (softened over a small band of cos) and its range let
// reach p: 1 inside, 0 beyond. A light with a range fades smoothly to nothing at it.
// ``l`` points from the surface to the light.
float reach(LightRecord light, vec3 p, vec3 l) {
    float r = 1.0;
    if (KIND_OF(light) == LIGHT_SPOT) {
        r = smoothstep(light.cos_half_cone, light.cos_half_cone + 0.02, dot(-l, light.direction));
    }
    if (KIND_OF(light) != LIGHT_DIRECTIONAL && light.range > 0.0) {
        float d = length(light.position - p) / light.range;
        float window = clamp(1.0 - d * d * d * d, 0.0, 1.0);
        r *= window * window;
    }
    return r;
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

// How much of a light reaches a surface point: its visibility times its reach, and none where
// the triangle (geometric normal ``g``) faces away, whatever its shading normal says.
float direct_light(vec3 g, vec3 l, float vis, float reached) {
    return dot(g, l) > 0.0 ? vis * reached : 0.0;
}

// Linear radiance of the hemispheric ambient light on a diffuse surface.
vec3 ambient_colour(vec3 albedo, vec3 n) {
    return albedo * mix(GROUND_AMBIENT, SKY_AMBIENT, 0.5 + 0.5 * n.y) * u_frame.ambient;
}

// Linear radiance one light adds to a diffuse surface: ``direct`` is how much of it the surface
// sees (visibility times reach).
vec3 light_colour(vec3 albedo, vec3 n, vec3 l, float direct, vec3 radiance) {
    return albedo * radiance * max(dot(n, l), 0.0) * direct;
}

// Linear radiance to the display: a filmic tone map (Narkowicz's fit of the ACES curve), then
// the sRGB transfer function.
vec3 display(vec3 x) {
    vec3 mapped = clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
    return mix(mapped * 12.92, 1.055 * pow(mapped, vec3(1.0 / 2.4)) - 0.055,
               step(0.0031308, mapped));
}
