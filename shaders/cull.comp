#version 430
// The camera pass's triangle culling (game/render/cull.py): drop the triangles that cannot
// cover a pixel centre, keep the others in their order. STAGE picks one of three dispatches:
//   STAGE_MASK:  one invocation per chunk of 32 triangles; one bit per triangle that may show.
//   STAGE_SCAN:  one workgroup; each chunk's first output slot (exclusive prefix sum of the
//                chunks' bit counts) and the two indirect draw commands.
//   STAGE_WRITE: one invocation per chunk; copies the kept triangles' indices to their slots.
// Chunks never straddle the closed/open boundary: closed volumes (drawn with back faces culled)
// fill the first u_cull.closed_chunks chunks, open meshes the rest.
#include "blocks/frame.glsl"
#include "blocks/cull.glsl"

#define CHUNK 32

// The mask stage reads each triangle's corners from u_corners, in sequence: following the index
// and vertex buffers instead was markedly slower on llvmpipe.

// The chunk's triangle range [first, end).
ivec2 chunk_range(int chunk) {
    if (chunk < u_cull.closed_chunks) {
        int first = chunk * CHUNK;
        return ivec2(first, min(first + CHUNK, u_cull.closed_triangles));
    }
    int first = u_cull.closed_triangles + (chunk - u_cull.closed_chunks) * CHUNK;
    return ivec2(first, min(first + CHUNK, u_cull.triangles));
}

#if STAGE == STAGE_MASK
layout(local_size_x = 64) in;

vec4 corner(int tri, int k) {
    int i = 9 * tri + 3 * k;
    return u_frame.view_proj * vec4(u_corners[i], u_corners[i + 1], u_corners[i + 2], 1.0);
}

// Characters are few and stored in their own space: they are always kept. For the others:
// false only where the triangle cannot produce a fragment: wholly outside one clip plane,
// facing away (closed volumes), or between pixel centres. Margins keep every doubtful case:
// SNAP covers the rasteriser snapping vertices to sub-pixel positions and float rounding.
const float SNAP = 1.0 / 64.0;   // pixels

bool may_show(int tri, bool closed) {
    if ((tri >= u_cull.keep_closed.x && tri < u_cull.keep_closed.y)
            || (tri >= u_cull.keep_open.x && tri < u_cull.keep_open.y)) {
        return true;
    }
    vec4 a = corner(tri, 0);
    vec4 b = corner(tri, 1);
    vec4 c = corner(tri, 2);
    // Outside one plane: x > w for all three, or x < -w for all three (and y, z alike).
    bvec3 beyond = greaterThan(min(min(a.xyz - a.w, b.xyz - b.w), c.xyz - c.w), vec3(0.0));
    bvec3 before = lessThan(max(max(a.xyz + a.w, b.xyz + b.w), c.xyz + c.w), vec3(0.0));
    if (any(beyond) || any(before)) {
        return false;
    }
    if (min(min(a.w, b.w), c.w) <= 0.0) {
        return true;   // crosses the eye plane: the clipper decides
    }
    vec2 pa = (a.xy / a.w * 0.5 + 0.5) * u_cull.viewport;
    vec2 pb = (b.xy / b.w * 0.5 + 0.5) * u_cull.viewport;
    vec2 pc = (c.xy / c.w * 0.5 + 0.5) * u_cull.viewport;
    vec2 lo_px = min(min(pa, pb), pc) - SNAP;
    vec2 hi_px = max(max(pa, pb), pc) + SNAP;
    // Pixel centres sit at k + 0.5: none inside the box on one axis means no fragment.
    if (any(greaterThan(ceil(lo_px - 0.5), floor(hi_px - 0.5)))) {
        return false;
    }
    if (closed) {
        vec2 e1 = pb - pa;
        vec2 e2 = pc - pa;
        float area = e1.x * e2.y - e1.y * e2.x;   // > 0: counter-clockwise, the front
        vec2 extent = hi_px - lo_px;
        if (area < -4.0 * SNAP * (extent.x + extent.y)) {
            return false;
        }
    }
    return true;
}

void main() {
    int chunk = int(gl_GlobalInvocationID.x);
    if (chunk >= u_cull.chunks) {
        return;
    }
    ivec2 range = chunk_range(chunk);
    bool closed = chunk < u_cull.closed_chunks;
    uint mask = 0u;
    for (int tri = range.x; tri < range.y; ++tri) {
        if (may_show(tri, closed)) {
            mask |= 1u << uint(tri - range.x);
        }
    }
    u_chunks[chunk].mask = mask;
}
#endif

#if STAGE == STAGE_SCAN
#define SCAN_SIZE 256
layout(local_size_x = SCAN_SIZE) in;

shared uint s_sum[SCAN_SIZE];
shared uint s_closed[SCAN_SIZE];

void main() {
    uint me = gl_LocalInvocationID.x;
    int n = u_cull.chunks;
    int per = (n + SCAN_SIZE - 1) / SCAN_SIZE;
    int first = int(me) * per;
    int end = min(first + per, n);
    uint sum = 0u;
    uint closed = 0u;
    for (int c = first; c < end; ++c) {
        uint kept = uint(bitCount(u_chunks[c].mask));
        sum += kept;
        closed += c < u_cull.closed_chunks ? kept : 0u;
    }
    s_sum[me] = sum;
    s_closed[me] = closed;
    barrier();
    if (me == 0u) {
        uint running = 0u;
        uint closed_all = 0u;
        for (int i = 0; i < SCAN_SIZE; ++i) {
            uint s = s_sum[i];
            s_sum[i] = running;
            running += s;
            closed_all += s_closed[i];
        }
        u_commands[0] = DrawCommand(3u * closed_all, 1u, 0u, 0u, 0u);
        u_commands[1] = DrawCommand(3u * (running - closed_all), 1u, 3u * closed_all, 0u, 0u);
    }
    barrier();
    uint slot = s_sum[me];
    for (int c = first; c < end; ++c) {
        u_chunks[c].first = slot;
        slot += uint(bitCount(u_chunks[c].mask));
    }
}
#endif

#if STAGE == STAGE_WRITE
layout(local_size_x = 64) in;

void main() {
    int chunk = int(gl_GlobalInvocationID.x);
    if (chunk >= u_cull.chunks) {
        return;
    }
    ivec2 range = chunk_range(chunk);
    uint mask = u_chunks[chunk].mask;
    uint slot = u_chunks[chunk].first;
    for (int tri = range.x; tri < range.y; ++tri) {
        if ((mask & (1u << uint(tri - range.x))) != 0u) {
            u_culled[3u * slot] = u_indices[3 * tri];
            u_culled[3u * slot + 1u] = u_indices[3 * tri + 1];
            u_culled[3u * slot + 2u] = u_indices[3 * tri + 2];
            slot += 1u;
        }
    }
}
#endif
