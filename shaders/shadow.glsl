// Hard-shadow lookup over the multi-map buffer (needs world.glsl and lighting.glsl).
// A fragment samples only the maps that can shadow it: those whose rectangle holds it and whose
// caster lies nearer the light. With many maps, a light-space grid lists the candidates per cell
// so the per-fragment cost stays flat (game/shadows/map_grid.py builds it). Visibility is the
// minimum. Where a directional light's statics are tiled (GRID_TILES), a cell's list names its
// one static map first: one fetch, then one depth read, as a virtual shadow map's page table.
//
// Loops over maps are do-while loops behind an if. llvmpipe runs a loop's body under a lane
// mask until no lane is left, and a for loop tests its condition at the top of the next pass:
// one more body, with every lane masked off, but paid in full. A do-while tests at the bottom.
//
// Each light has its own maps, u_maps[first_map, first_map + map_count), and its own grid.
//
// What is fixed for a whole frame arrives as #defines, and the renderer picks the program made
// for it (game/render/shading_pass.py): PCF (0 or 1), COUNT_PIXELS (0 or 1), and with one light
// (MANY_LIGHTS 0) its kind LIGHT_KIND (LIGHT_DIRECTIONAL, LIGHT_SPOT, LIGHT_POINT) and its
// grid's mode GRID (GRID_NONE, GRID_ORTHO, GRID_OCTAHEDRAL, GRID_TILES). Branching on uniforms
// instead costs more on llvmpipe, which runs both sides of a branch under a lane mask; with
// several lights those two are read per light.

uniform sampler2DArrayShadow u_shadow_maps;

// The map records the lookup reads, as texels (game/render/map_records.py): a fragment's maps
// differ from its neighbours', and llvmpipe reads a uniform-block member at a per-lane index
// one lane and one float at a time, where a texel fetch reads four floats per lane at once.
uniform sampler2D u_map_records;

// What the lookup needs of map i, fetched once per map it considers.
struct MapRef {
    int i;
    float near, inv_depth_range, texel, uv_scale;
    vec2 uv_offset;
    int layer, kind, flags;
};

// The rectangle and the matrix, read inside the branch on the light's kind. With several lights
// the kind is read, not a #define, so both sides run for every candidate, and there the block's
// members cost less than five texel fetches (docs/design/shading-variants.md).
#if MANY_LIGHTS
vec4 record_bounds(int i) {
    return u_maps[i].bounds;
}

mat4 record_view_proj(int i) {
    return u_maps[i].view_proj;
}
#else
vec4 record_bounds(int i) {
    return texelFetch(u_map_records, ivec2(RECORD_BOUNDS, i), 0);
}

mat4 record_view_proj(int i) {
    return mat4(texelFetch(u_map_records, ivec2(RECORD_VIEW_PROJ, i), 0),
                texelFetch(u_map_records, ivec2(RECORD_VIEW_PROJ + 1, i), 0),
                texelFetch(u_map_records, ivec2(RECORD_VIEW_PROJ + 2, i), 0),
                texelFetch(u_map_records, ivec2(RECORD_VIEW_PROJ + 3, i), 0));
}
#endif

MapRef map_ref(int i) {
    vec4 a = texelFetch(u_map_records, ivec2(RECORD_DEPTH, i), 0);
    vec4 b = texelFetch(u_map_records, ivec2(RECORD_LAYER, i), 0);
    int code = int(b.w);
    return MapRef(i, a.x, a.y, a.z, a.w, b.xy, int(b.z), code / RECORD_FLAG_CODES,
                  code % RECORD_FLAG_CODES);
}

// COUNT_PIXELS (a #define) counts, per map, the pixels that read it within a texel of one of its
// shadow edges, where its texels' size moves the shadow: view-sized maps are sized by them
// (game/shadows/view_budget.py).
#if COUNT_PIXELS
#include "blocks/map_pixels.glsl"
bool g_on_edge;  // set by lookup(): the 2 x 2 texels around the sample do not all agree
// A shader that writes to a buffer is run for hidden fragments too, unless told to test depth
// first: that counted every hidden fragment, and on llvmpipe shaded them all. Fragments drawn
// over later in the pass are still counted.
layout(early_fragment_tests) in;
#endif

// COUNT_CANDIDATES (a #define) counts the map records a fragment considers, sampled or not: what
// finding its maps costs (the frame's map_candidates_per_fragment; shaders/shade.frag writes it).
#if COUNT_CANDIDATES
int g_candidates = 0;
#endif

// KIND_CASCADE (a #define from game/shadows/plan.py) marks csm cascades. They are listed
// finest first, and the first one that holds the fragment decides (coarser ones would only add
// their larger error under the minimum). KIND_FALLBACK marks clumped's coarse maps of long faces,
// listed after the clump maps: every clump map holds the long faces that cross it, so a fallback
// map is read only where no clump map held the fragment (its coarse texels would only add error).

bool decided(MapRef m, int sampled_before, int sampled) {
    return sampled > sampled_before && m.kind == KIND_CASCADE;
}

#if DEPTH_BOUNDS
#include "depth_bounds.glsl"
// The depth bounds of the cached maps, one texel per block of BOUNDS_BLOCK x BOUNDS_BLOCK depth
// texels: the nearest and farthest, or a plane and its spread (shaders/depth_bounds.glsl,
// game/gpu/depth_bounds.py).
uniform usampler2DArray u_shadow_bounds;

// The compare in map i at layer uv as its block's bounds settle it: 1 lit (nearer than every
// texel it would read), 0 shadowed (farther than every one), -1 not settled, where the texels
// must be read. The texels read are those within `reach` of the one at uv (1 with PCF's 3 x 3
// taps), all in its block or not settled.
float settled(MapRef m, vec2 uv, float depth, int reach) {
    if ((m.flags & MAP_BOUNDED) == 0) {
        return -1.0;
    }
    ivec2 size = textureSize(u_shadow_maps, 0).xy;
    ivec2 t = clamp(ivec2(uv * vec2(size)), ivec2(0), size - 1);
    ivec2 inner = t % BOUNDS_BLOCK;
    if (any(lessThan(inner, ivec2(reach)))
        || any(greaterThanEqual(inner, ivec2(BOUNDS_BLOCK - reach)))) {
        return -1.0;
    }
    uvec2 q = texelFetch(u_shadow_bounds, ivec3(t / BOUNDS_BLOCK, m.layer), 0).rg;
    vec2 b = bounds_range(q, vec2(inner) - BOUNDS_CENTRE, float(reach));
    return depth <= b.x ? 1.0 : (depth > b.y ? 0.0 : -1.0);
}
#endif

// Depth compare (or 3x3 PCF) in map m at uv in [0, 1] over the map, whose square is the share
// uv_scale of its layer from uv_offset (character maps share layers).
float lookup(MapRef m, vec2 uv, float depth) {
    float layer = float(m.layer);
    vec2 offset = m.uv_offset;
    uv = offset + uv * m.uv_scale;
#if COUNT_PIXELS
    // The 2 x 2 texels around uv, kept inside the map's own square: near its border they would
    // read the next square's, another map's depths, and find an edge all along the border.
    vec2 texel = 1.0 / vec2(textureSize(u_shadow_maps, 0).xy);
    vec2 inside = clamp(uv, offset + texel, offset + vec2(m.uv_scale) - texel);
    vec4 taps = textureGather(u_shadow_maps, vec3(inside, layer), depth);
    g_on_edge = any(notEqual(taps, taps.xxxx));
#endif
#if DEPTH_BOUNDS
    // Where the bounds settle it, the texels are still read (a lane masked off is paid for in
    // full on llvmpipe), but all at one place, which stays in the cache.
    float known = settled(m, uv, depth, PCF);
    if (known >= 0.0) {
        uv = vec2(0.0);
        layer = 0.0;
    }
#else
    float known = -1.0;
#endif
#if !PCF
    // Read at the centre of the texel that settled() took the bounds of: a device may snap a
    // coordinate near a texel's edge to its neighbour, whose depth a plane's band does not hold.
    vec2 texels = vec2(textureSize(u_shadow_maps, 0).xy);
    float v = texture(u_shadow_maps, vec4((floor(uv * texels) + 0.5) / texels, layer, depth));
#else
    // The 3 x 3 texels around uv's, each index held inside the map's own square (first to
    // last), read as one tap and three 2 x 2 gathers: nine taps' texels and mean in four
    // sampler calls, each of which llvmpipe pays for per lane. A gather at the corner after
    // texel a reads a and a + 1 on each axis; its x, y, z, w are (column, row) (a, a+1),
    // (a+1, a+1), (a+1, a), (a, a). Where the third index is held at the square's edge, it is
    // the middle one again, and the gather's a is read in place of its a + 1.
    vec2 size = vec2(textureSize(u_shadow_maps, 0).xy);
    vec2 first = floor(offset * size + 0.5);
    vec2 last = first + floor(vec2(m.uv_scale) * size + 0.5) - 1.0;
    vec2 t = clamp(floor(uv * size), first, last);
    vec2 a0 = max(t - 1.0, first), a2 = min(t + 1.0, last);
    bvec2 next = greaterThan(a2, t);   // the third index is t + 1, not t again
    float corner = texture(u_shadow_maps, vec4((a0 + 0.5) / size, layer, depth));
    vec4 g10 = textureGather(u_shadow_maps, vec3((vec2(t.x, a0.y) + 1.0) / size, layer), depth);
    vec4 g01 = textureGather(u_shadow_maps, vec3((vec2(a0.x, t.y) + 1.0) / size, layer), depth);
    vec4 g11 = textureGather(u_shadow_maps, vec3((t + 1.0) / size, layer), depth);
    float sum = corner + g10.w + (next.x ? g10.z : g10.w)
        + g01.w + g11.w + (next.x ? g11.z : g11.w)
        + (next.y ? g01.x : g01.w) + (next.y ? g11.x : g11.w)
        + (next.x ? (next.y ? g11.y : g11.z) : (next.y ? g11.x : g11.w));
    float v = sum / 9.0;
#endif
    return known >= 0.0 ? known : v;
}

// Bias in texel units, times the texel's world size at p: a normal offset that grows towards
// grazing light, and a slope-scaled offset towards the light. Returns (normal, light) offsets.
vec2 bias_offsets(float texel, float sin_t, float tan_t) {
    return vec2(u_frame.normal_bias * sin_t, u_frame.depth_bias + u_frame.slope_bias * tan_t) * texel;
}

// Whether map m may hold the receiver's own surface. The bias is there so that a surface does
// not shadow itself through its own depth texels; in a map it is not drawn into, a receiver
// is compared unbiased, and its contact shadows stay whole. Floors are in no map, a character
// only in its own map or in a map of everything, a static in no character map.
bool holds_receiver(LightRecord light, MapRef m, int object) {
    int kind = m.kind;
    if (object < u_frame.floor_count) {
        return false;
    }
    if (object >= u_frame.first_character) {
        return kind == KIND_CHARACTER
            ? u_character_maps[light.first_character_map + object - u_frame.first_character] == m.i
            : kind == KIND_ALL || kind == KIND_CASCADE;
    }
    return kind != KIND_CHARACTER;
}

// Visibility of p in orthographic map m (directional light); 1.0 outside the map's rectangle or
// nearer the light than its caster, with `sampled` false. Works in the common light space:
// lp and ln are p and its normal there, where light-space +z points at the light.
float sample_ortho(MapRef m, vec3 lp, vec3 ln, float sin_t, float tan_t, float biased,
                   out bool sampled) {
    sampled = false;
    vec2 offset = bias_offsets(m.texel, sin_t, tan_t) * biased;
    vec3 q = lp + ln * offset.x + vec3(0.0, 0.0, offset.y);
    vec4 b = record_bounds(m.i);
    vec2 uv = (q.xy - b.xy) / (b.zw - b.xy);
    // Depth in [0, 1] as the orthographic projection stores it: distance along -z from near.
    float depth = (-q.z - m.near) * m.inv_depth_range;
    if (any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0))) || depth < 0.0) {
        return 1.0;
    }
    sampled = true;
    // Beyond the caster's far side the fragment is shadowed wherever the caster covers the texel.
    return lookup(m, uv, min(depth, 1.0));
}

// Visibility of p in perspective map m (spot and point lights), as sample_ortho.
float sample_perspective(MapRef m, vec3 p, vec3 n, vec3 l, float sin_t, float tan_t,
                         float biased, out bool sampled) {
    sampled = false;
    mat4 view_proj = record_view_proj(m.i);
    vec4 clip = view_proj * vec4(p, 1.0);
    if (clip.w <= 0.0) {
        return 1.0;   // behind the map's eye
    }
    vec2 offset = bias_offsets(m.texel * clip.w, sin_t, tan_t) * biased;
    clip = view_proj * vec4(p + n * offset.x + l * offset.y, 1.0);
    vec3 ndc = clip.xyz / clip.w;
    if (clip.w <= 0.0 || any(greaterThan(abs(ndc.xy), vec2(1.0))) || ndc.z < -1.0) {
        return 1.0;
    }
    sampled = true;
    return lookup(m, ndc.xy * 0.5 + 0.5, min(ndc.z * 0.5 + 0.5, 1.0));
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

// Everything about the fragment that does not depend on the map.
struct Receiver {
    int object;         // the receiver's object index
    vec3 p, n, l;       // world position, normal, direction to the light
    vec3 lp, ln;        // directional light: p and n in the common light space
    float sin_t, tan_t; // of the angle between n and l
};

void consider(LightRecord light, MapRef m, Receiver r, inout float vis, inout int sampled,
              inout int used, inout int held) {
#if COUNT_CANDIDATES
    g_candidates += 1;
#endif
    if (m.kind == KIND_FALLBACK && held > 0) {
        return;
    }
    bool read;
    float biased = holds_receiver(light, m, r.object) ? 1.0 : 0.0;
    float v;
    if (KIND_OF(light) == LIGHT_DIRECTIONAL) {
        v = sample_ortho(m, r.lp, r.ln, r.sin_t, r.tan_t, biased, read);
    } else {
        v = sample_perspective(m, r.p, r.n, r.l, r.sin_t, r.tan_t, biased, read);
    }
    if (read) {
#if COUNT_PIXELS
        if (g_on_edge) {
            atomicAdd(u_map_pixels[m.i], 1u);
        }
#endif
        sampled += 1;
        held += m.kind == KIND_CLUMP ? 1 : 0;
        if (used < 0 || v < vis) {
            used = m.i;
        }
        vis = min(vis, v);
    }
}

// Visibility of `light` at p on object `object` (1 lit, 0 shadowed), the number of maps read
// (added to `sampled`), and the map that decided it (-1 when none was read).
float shadow_visibility(LightRecord light, vec3 p, vec3 n, int object, inout int sampled,
                        out int used) {
    used = -1;
    Receiver r;
    r.object = object;
    r.p = p;
    r.n = n;
    r.l = to_light(light, p);
    float ndotl = dot(n, r.l);
    if (ndotl <= 0.0) {
        return 0.0;   // the surface faces away from the light
    }
    r.sin_t = sqrt(max(0.0, 1.0 - ndotl * ndotl));
    r.tan_t = min(r.sin_t / max(ndotl, 1e-4), u_frame.max_slope);
    r.lp = (light.light_rot * vec4(p, 1.0)).xyz;
    r.ln = mat3(light.light_rot) * n;
    float vis = 1.0;
    int held = 0;   // clump maps that held the fragment
    // The candidates: every map of the light (GRID_NONE), or the list of the fragment's cell
    // of the light's grid. One walk serves both: with several lights the mode is read, not a
    // #define, and a second walk would cost one more body per light, run with every lane off.
    bool listed = GRID_OF(light) != GRID_NONE;
    int k = light.first_map, end = k + light.map_count;
    if (listed) {
        vec2 g = GRID_OF(light) != GRID_OCTAHEDRAL ? r.lp.xy
                                                    : octahedral(normalize(p - light.position));
        // Outside the grid's rectangle, the nearest edge cell: it lists every map reaching past
        // that edge (game/shadows/map_grid.py).
        vec2 f = (g - light.grid_rect.xy) / (light.grid_rect.zw - light.grid_rect.xy);
        int size = light.grid_size;
        ivec2 cell = clamp(ivec2(floor(f * float(size))), ivec2(0), ivec2(size - 1));
        int c = light.grid_base + cell.y * size + cell.x;
        k = u_grid[c];
        end = u_grid[c + 1];
    }
    // With tiles, a cell lists its one static map where that tile's casters reach the cell, then
    // its character maps: a cell on open ground lists none, and its fragments skip the walk.
    // A negative entry names no map.
    if (k < end) {
        do {
            int i = listed ? u_grid[k] : k;
            if (i >= 0) {
                int before = sampled;
                MapRef m = map_ref(i);
                consider(light, m, r, vis, sampled, used, held);
                if (decided(m, before, sampled)) {
                    break;
                }
            }
            ++k;
        } while (k < end && vis > 0.0);
    }
    return vis;
}
