// Hard-shadow lookup over the multi-map buffer (needs blocks.glsl).
// A fragment samples only the maps that can shadow it: those whose rectangle holds it and whose
// caster lies nearer the light. With many maps, a light-space grid lists the candidates per cell
// so the per-fragment cost stays flat (game/map_grid.py builds it). Visibility is the minimum.

uniform sampler2DArrayShadow u_shadow_maps;

vec3 to_light(vec3 p) {
    return u_light_dir.w < 0.5 ? -u_light_dir.xyz : normalize(u_light_pos.xyz - p);
}

// Visibility of p in map i; 1.0 outside the map's bounds or nearer the light than its caster.
// `sampled` tells whether the map was read. `light_xy` is p in the common light space of a
// directional light, where an orthographic map's bounds reject most candidates cheaply.
float sample_map(int i, vec3 p, vec2 light_xy, vec3 n, vec3 l, float ndotl, out bool sampled) {
    sampled = false;
    if (u_maps[i].params.z < 0.5) {
        float reach = (u_bias.x + u_bias.y + u_bias.z * u_bias.w) * u_maps[i].params.y;
        vec4 b = u_maps[i].bounds + vec4(-reach, -reach, reach, reach);
        if (any(lessThan(light_xy, b.xy)) || any(greaterThan(light_xy, b.zw))) {
            return 1.0;
        }
    }
    vec4 clip = u_maps[i].view_proj * vec4(p, 1.0);
    if (clip.w <= 0.0) {
        return 1.0;   // behind a perspective map's eye
    }
    // Bias in texel units, scaled by the texel's world size at p: a normal offset that grows
    // towards grazing light, and a slope-scaled offset towards the light.
    float texel = u_maps[i].params.y * clip.w;
    float sin_t = sqrt(max(0.0, 1.0 - ndotl * ndotl));
    float tan_t = min(sin_t / max(ndotl, 1e-4), u_bias.w);
    vec3 q = p + n * (u_bias.x * texel * sin_t) + l * ((u_bias.y + u_bias.z * tan_t) * texel);
    clip = u_maps[i].view_proj * vec4(q, 1.0);
    vec3 ndc = clip.xyz / clip.w;
    if (clip.w <= 0.0 || any(greaterThan(abs(ndc.xy), vec2(1.0))) || ndc.z < -1.0) {
        return 1.0;
    }
    sampled = true;
    float layer = u_maps[i].params.x;
    vec2 uv = (ndc.xy * 0.5 + 0.5) * u_maps[i].params.w;
    // Beyond the caster's far side the fragment is shadowed wherever the caster covers the texel.
    float depth = min(ndc.z * 0.5 + 0.5, 1.0);
    if (u_options.x == 0) {
        return texture(u_shadow_maps, vec4(uv, layer, depth));
    }
    vec2 step = 1.0 / vec2(textureSize(u_shadow_maps, 0).xy);
    vec2 lo = vec2(0.0), hi = vec2(u_maps[i].params.w);
    float sum = 0.0;
    for (int y = -1; y <= 1; ++y) {
        for (int x = -1; x <= 1; ++x) {
            vec2 tap = clamp(uv + vec2(x, y) * step, lo, hi);
            sum += texture(u_shadow_maps, vec4(tap, layer, depth));
        }
    }
    return sum / 9.0;
}

// Octahedral coordinates of a direction, in [-1, 1]^2: the light-space of point and spot grids.
vec2 octahedral(vec3 d) {
    d /= abs(d.x) + abs(d.y) + abs(d.z);
    vec2 e = d.xy;
    if (d.z < 0.0) {
        e = (1.0 - abs(d.yx)) * vec2(d.x >= 0.0 ? 1.0 : -1.0, d.y >= 0.0 ? 1.0 : -1.0);
    }
    return e;
}

void consider(int i, vec3 p, vec2 light_xy, vec3 n, vec3 l, float ndotl, inout float vis,
              inout int sampled, inout int used) {
    bool read;
    float v = sample_map(i, p, light_xy, n, l, ndotl, read);
    if (read) {
        sampled += 1;
        if (used < 0 || v < vis) {
            used = i;
        }
        vis = min(vis, v);
    }
}

// Visibility of the hard light at p (1 lit, 0 shadowed), the number of maps read, and the
// map that decided it (-1 when none was read).
float shadow_visibility(vec3 p, vec3 n, out int sampled, out int used) {
    sampled = 0;
    used = -1;
    vec3 l = to_light(p);
    float ndotl = dot(n, l);
    if (ndotl <= 0.0) {
        return 0.0;   // the surface faces away from the light
    }
    float vis = 1.0;
    vec2 light_xy = (u_light_rot * vec4(p, 1.0)).xy;
    if (u_counts.y == GRID_NONE) {
        for (int i = 0; i < u_counts.x && vis > 0.0; ++i) {
            consider(i, p, light_xy, n, l, ndotl, vis, sampled, used);
        }
        return vis;
    }
    vec2 g = u_counts.y == GRID_ORTHO ? light_xy : octahedral(normalize(p - u_light_pos.xyz));
    vec2 f = (g - u_grid_rect.xy) / (u_grid_rect.zw - u_grid_rect.xy);
    if (any(lessThan(f, vec2(0.0))) || any(greaterThan(f, vec2(1.0)))) {
        return vis;
    }
    int size = u_counts.z;
    ivec2 cell = min(ivec2(f * float(size)), ivec2(size - 1));
    int c = cell.y * size + cell.x;
    for (int k = u_grid[c]; k < u_grid[c + 1] && vis > 0.0; ++k) {
        consider(u_grid[k], p, light_xy, n, l, ndotl, vis, sampled, used);
    }
    return vis;
}
