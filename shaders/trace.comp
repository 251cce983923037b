#version 430
// The soft-shadow compute pass: one invocation per pixel of the G-buffer, one shaded point each.
// METHOD (a #define from game/soft/methods.py) picks how occluders are found; all methods share the
// samples, the leaf walk and the ray-triangle test, so the accelerated ones equal METHOD_BRUTE.
//
// A point's work is split into dispatches ("rounds") by a step budget (trace_budget.glsl): a
// point that runs out saves its cursor in its PointResult and resumes there in the next round.
// The parts, in the order they build on each other:
//   trace_budget.glsl              the step budget, the counters, the cursor
//   trace_structure.glsl           the light triangle, the mailbox, the structure's leaves
//   trace_leaf_list.glsl           a leaf's whole list (METHOD_GRID's leaf walk)
//   trace_leaf_tri_cache.glsl      METHOD_TRI_CACHE's leaf walk
//   trace_leaf_voxel_cache.glsl    METHOD_VOXEL_CACHE's leaf walk
//   trace_ray_walk.glsl            a ray per sample through the grid (or every triangle: brute)
//   trace_analytic_intervals.glsl  METHOD_ANALYTIC: the hidden intervals of the segment
//   trace_analytic_walk.glsl       METHOD_ANALYTIC: the leaves the light triangle may touch
#include "blocks/trace.glsl"
#include "trace.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

uniform sampler2D u_position;  // xyz world position
uniform sampler2D u_normal;    // xyz unit normal facing the camera
uniform sampler2D u_colour;    // a > 0 where geometry covers the pixel

#include "trace_budget.glsl"
#include "trace_structure.glsl"
#include "trace_leaf_list.glsl"
#include "trace_leaf_tri_cache.glsl"
#include "trace_leaf_voxel_cache.glsl"
#include "trace_ray_walk.glsl"
#include "trace_analytic_intervals.glsl"
#include "trace_analytic_walk.glsl"

// The result of a point before its first round: no geometry, nothing counted, the cursor at the
// start.
PointResult new_point_result() {
    PointResult res;
    res.visibility = -1.0;  // no geometry
    res.ray_triangle_tests = 0u;
    res.triangle_triangle_tests = 0u;
    res.voxels_visited = 0u;
    res.candidates = 0u;
    res.overflows = 0u;
    res.truncated = 0u;
    res.visible = 0u;
    res.bytes_triangles = uvec2(0u);
    res.bytes_cells = uvec2(0u);
    res.bytes_candidates = uvec2(0u);
    res.dispatches = 0u;
    res.pending = 0u;
    res.at_sample = 0;
    res.at_top = -1;
    res.at_sub = -1;
    res.at_ref = 0;
    res.near_hit = 2.0;
    res.intervals = 0;
    res.kept_intervals = mat4(0.0);
    return res;
}

// Zeroes this dispatch's counters and step budget; the point resumes at its cursor in `res`.
void start_round(PointResult res) {
    g_ray_tri = 0u;
    g_tri_tri = 0u;
    g_voxels = 0u;
    g_candidates = 0u;
    g_overflows = 0u;
    g_bytes_triangles = 0u;
    g_bytes_cells = 0u;
    g_bytes_candidates = 0u;
    g_steps = 0;
    g_progress = false;
    g_at_top = res.at_top;
    g_at_sub = res.at_sub;
    g_at_ref = res.at_ref;
    g_stop_top = -1;
    g_stop_sub = -1;
    g_stop_ref = 0;
}

// Adds this dispatch's counters to `res` and saves where the point stopped.
void end_round(inout PointResult res) {
    res.at_top = g_stop_top;
    res.at_sub = g_stop_sub;
    res.at_ref = g_stop_ref;
    res.ray_triangle_tests += g_ray_tri;
    res.triangle_triangle_tests += g_tri_tri;
    res.voxels_visited += g_voxels;
    res.candidates += g_candidates;
    res.overflows += g_overflows;
    res.bytes_triangles = add64(res.bytes_triangles, g_bytes_triangles);
    res.bytes_cells = add64(res.bytes_cells, g_bytes_cells);
    res.bytes_candidates = add64(res.bytes_candidates, g_bytes_candidates);
    res.dispatches += 1u;
}

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (px.x >= u_trace.width || px.y >= u_trace.height) {
        return;
    }
    int index = px.y * u_trace.width + px.x;
    int summary = u_trace.width * u_trace.height;  // the record after the points: totals
    PointResult res;
    if (u_trace.round_index == 0) {
        res = new_point_result();
        if (texelFetch(u_colour, px, 0).a <= 0.0) {
            u_results[index] = res;
            return;
        }
    } else {
        res = u_results[index];
        if (res.pending == 0u) {
            return;  // finished in an earlier round, or no geometry
        }
    }
    start_round(res);

    vec3 p = texelFetch(u_position, px, 0).xyz;
    vec3 nrm = normalize(texelFetch(u_normal, px, 0).xyz);
    // Receiver self-occlusion: start the rays off the surface along its normal.
    vec3 o = p + nrm * (u_trace.ray_offset + u_trace.ray_offset_per_metre * length(p));
    g_apex = o;
    g_la = u_trace.light_a;
    g_lb = u_trace.light_b;
#if METHOD == METHOD_TRI_CACHE
    g_ray_id = uint(u_trace.ray_id_base + index) & 0x7fffffffu;
#elif METHOD == METHOD_VOXEL_CACHE
    voxel_cache_reset();
#endif
    int walked;
#if METHOD == METHOD_ANALYTIC
    if (u_trace.light_mode == TRACE_LIGHT_SEGMENT) {
        float vis;
        walked = analytic_visibility(o, nrm, res, vis);
        if (walked == WALK_CLEAR) {
            res.visibility = vis;
        }
    } else
#endif
    {
        int at = res.at_sample;
        uint visible = res.visible;
        walked = sampled_walk(o, nrm, uint(index), at, visible);
        res.at_sample = at;
        res.visible = visible;
        if (walked == WALK_CLEAR) {
            res.visibility = float(visible) / float(u_trace.samples);
        }
    }
    end_round(res);
    res.pending = walked == WALK_STOP ? 1u : 0u;
    if (!loop_budget_left()) {
        res.truncated = 1u;
        atomicAdd(u_results[summary].truncated, 1u);
    }
    if (walked == WALK_STOP) {
        atomicAdd(u_results[summary].pending, 1u);
    }
    u_results[index] = res;
}
