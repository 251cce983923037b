// The soft-shadow tracer's step budget, its per-dispatch counters and the cursor where a point
// resumes. Part of trace.comp (needs blocks/trace.glsl).
//
// Every point's work is split into dispatches ("rounds") by a step budget: each loop iteration
// costs a step, and a point whose steps reach u_trace.step_budget saves where it is (its
// cursor, in its PointResult) and resumes there in the next round. Mesa's llvmpipe stops all
// loops of an invocation after 65,535 iterations in all (see loop_budget_left); the budget keeps
// every invocation well below that, whatever the method, scene or grid.

// What a walk (a ray through the structure, a leaf's list, an enumeration) ended with.
const int WALK_CLEAR = 0;  // finished, nothing hit
const int WALK_HIT = 1;    // a triangle hides the sample
const int WALK_STOP = 2;   // the step budget ran out: resume at the saved cursor

// Per-dispatch counters of the current point, added to its PointResult at the end.
uint g_ray_tri;
uint g_tri_tri;
uint g_voxels;
uint g_candidates;
uint g_overflows;
uint g_bytes_triangles;   // read from the Triangles buffer
uint g_bytes_cells;       // read from the structure: top table, sub-grid table, leaf offsets, ids
uint g_bytes_candidates;  // candidate state read and written: voxel cache, tri-cache words

// The step budget: steps taken in this dispatch, and whether anything was done since the point
// resumed (a point may only stop after some progress, so every round moves it on).
int g_steps;
bool g_progress;

bool must_stop(int cost) {
    return g_progress && g_steps + cost > u_trace.step_budget;
}

// The cursor: where the current point resumes (read at the start of a dispatch) and where it
// stopped (written on WALK_STOP). top/sub are cells (sampled methods) or enumeration indices
// (analytic); -1 means from the start; ref is the entry of the leaf's list (brute: the triangle).
int g_at_top;
int g_at_sub;
int g_at_ref;
int g_stop_top;
int g_stop_sub;
int g_stop_ref;

// Mesa's llvmpipe (22.3) stops every loop of an invocation once their iterations add up to 65535
// (one shared counter, LP_MAX_TGSI_LOOP_ITERATIONS): the work left is silently skipped. A loop
// of u_trace.loop_probe_trips = 2 trips then runs once; that flags the point as truncated, and
// game/soft/tracer.py runs such traces again with a smaller step budget.
bool loop_budget_left() {
    int trips = 0;
    for (int i = 0; i < u_trace.loop_probe_trips; ++i) {
        trips += 1;
    }
    return trips == u_trace.loop_probe_trips;
}

// A 64-bit counter kept as (low, high) words.
uvec2 add64(uvec2 total, uint v) {
    uint carry;
    uint low = uaddCarry(total.x, v, carry);
    return uvec2(low, total.y + carry);
}
