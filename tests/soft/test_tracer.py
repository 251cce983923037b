"""The soft-shadow tracer on llvmpipe, checked against brute force and Embree."""


import numpy as np
import pytest

from game.app import dumps
from game.gpu.blocks import TRACE_LIGHT_POINT, TRACE_LIGHT_SEGMENT
from game.reference import hard as reference
from game.reference import soft as sr
from game.render.renderer import Renderer, View
from game.scene import geometry, parse_scene
from game.soft import grid as trace_grid
from game.soft import tracer as soft_tracer
from game.soft.grid import STRUCTURES
from game.soft.results import BYTE_COUNTERS
from game.soft.tracer import (
    RAY_OFFSET_DISTANCE,
    RAY_OFFSET_SCENE,
    TRIANGLE_BYTES,
    SoftTracer,
    TraceSettings,
)
from tests.helpers import ASSETS

SIZE = (96, 54)
ACCELERATED = ("grid", "tri-cache", "voxel-cache")
ALL = ("brute", *ACCELERATED)


def gbuffer_trace(ctx, scene, methods, samples, size=SIZE, t=0.0, **settings):
    """Render the G-buffer once and trace it with each method; returns (frame, results)."""
    r = Renderer(ctx, scene, size, gbuffer=True)
    try:
        frame = r.render(t, View.from_camera(scene.camera, size))
        results = {m: r.trace(t, TraceSettings(method=m, samples=samples, **settings))
                   for m in methods}
        diagonal = r.soft_tracer.grid.spec.diagonal
    finally:
        r.release()
    return frame, results, diagonal


def embree_of(scene, t=0.0):
    return sr.EmbreeOccluder(dumps.frame_geometry(scene, t).to_geometry())


def origins_of(frame, diagonal):
    g = frame.gbuffer
    covered = np.isfinite(g["position"]).all(axis=-1)
    pts, nrm = g["position"][covered], g["normal"][covered]
    return covered, sr.ray_origins(pts, nrm, RAY_OFFSET_SCENE * diagonal, RAY_OFFSET_DISTANCE), nrm


def rmse(a, b):
    return float(np.sqrt(np.mean((np.asarray(a, float) - np.asarray(b, float)) ** 2)))


# -- accelerated methods are exact ---------------------------------------------------------------
@pytest.mark.parametrize("structure", list(STRUCTURES))
@pytest.mark.parametrize("name, samples, size",
                         [("tiny", 8, SIZE), ("courtyard", 32, (64, 36))])
def test_accelerated_methods_equal_brute_with_the_same_samples(ctx, name, samples, size, structure,
                                                                request):
    # 32 samples of the courtyard take brute force past llvmpipe's loop budget in one dispatch
    # (6,016 triangles): the tracer must split every point's work and lose none of it.
    scene = request.getfixturevalue(name)
    _, results, _ = gbuffer_trace(ctx, scene, ALL, samples=samples, size=size,
                                  structure=structure)
    brute = results["brute"].visibility
    assert np.isfinite(brute).sum() > 1000
    assert np.nanmin(brute) < 0.5 < np.nanmax(brute)  # shadows and light in view
    for m in ALL:
        assert results[m].truncated == 0, m
    for m in ACCELERATED:
        np.testing.assert_array_equal(results[m].visibility, brute, err_msg=m)


def test_sampled_methods_equal_embree_on_the_same_rays(ctx, courtyard):
    frame, results, diagonal = gbuffer_trace(ctx, courtyard, ("voxel-cache",), samples=16)
    covered, origins, normals = origins_of(frame, diagonal)
    rows, cols = np.nonzero(covered)
    index = (SIZE[1] - 1 - rows) * SIZE[0] + cols  # the tracer's point index (GL rows)
    t = sr.tracer_samples(index, 16)
    light = courtyard.linear_light
    embree = sr.segment_visibility(embree_of(courtyard), origins, normals, light.a, light.b, t)
    ours = results["voxel-cache"].visibility[covered]
    # Float rounding may flip a ray that grazes an edge; a handful of pixels at most.
    assert np.mean(ours != embree) <= 0.005
    assert np.abs(ours - embree).max() <= 2 / 16 + 1e-6


# -- accuracy against Embree --------------------------------------------------------------------
@pytest.mark.parametrize("name", ["tiny", "courtyard"])
def test_analytic_is_within_001_of_1024_embree_samples(ctx, name, request):
    scene = request.getfixturevalue(name)
    frame, results, diagonal = gbuffer_trace(ctx, scene, ("analytic",), samples=1)
    covered, origins, normals = origins_of(frame, diagonal)
    light = scene.linear_light
    ref = sr.stratified_reference(embree_of(scene), origins, normals, light.a, light.b, 1024)
    shadowed = ref < 0.999
    assert shadowed.sum() > 30  # penumbrae and umbrae are in view
    ours = results["analytic"].visibility[covered]
    assert rmse(ours, ref) <= 0.01
    # Also over the shadowed pixels alone, where a lit majority cannot dilute the error.
    assert rmse(ours[shadowed], ref[shadowed]) <= 0.01


def test_sampled_error_falls_with_the_number_of_samples(ctx, courtyard):
    ns = (1, 4, 16, 64)
    r = Renderer(ctx, courtyard, SIZE, gbuffer=True)
    try:
        r.render(0.0, View.from_camera(courtyard.camera, SIZE))
        exact = r.trace(0.0, TraceSettings(method="analytic")).visibility
        errors = [rmse(*np.broadcast_arrays(
            r.trace(0.0, TraceSettings(method="voxel-cache", samples=n)).visibility[
                np.isfinite(exact)], exact[np.isfinite(exact)])) for n in ns]
    finally:
        r.release()
    assert all(b < 0.7 * a for a, b in zip(errors, errors[1:], strict=False)), errors


def test_caches_cut_ray_triangle_tests_and_count_their_own(ctx, courtyard):
    _, results, _ = gbuffer_trace(ctx, courtyard, ("grid", "tri-cache", "voxel-cache"), 16)
    means = {m: res.means() for m, res in results.items()}
    assert means["grid"]["triangle_triangle_tests"] == 0
    for m in ("tri-cache", "voxel-cache"):
        assert means[m]["ray_triangle_tests"] < means["grid"]["ray_triangle_tests"] / 2
        assert means[m]["triangle_triangle_tests"] > 0
        assert means[m]["voxels_visited"] == means["grid"]["voxels_visited"]


# -- failure cases, on chosen points ------------------------------------------------------------
def scene_text(boxes, a, b, floor=True, scale=1.0):
    """A scene of boxes (size, position) and a linear light, all scaled by ``scale``."""
    def v(x):
        return "[" + ", ".join(repr(float(c) * scale) for c in x) + "]"

    parts = ['[camera]\nposition = ' + v([0, 6, 10]) + '\ntarget = ' + v([0, 0, 0])
             + f'\nfov = 60.0\nnear = {0.1 * scale}\nfar = {200.0 * scale}\n',
             '[light]\nkind = "directional"\ndirection = [-0.4, -1.0, -0.3]\n',
             f"[linear_light]\na = {v(a)}\nb = {v(b)}\n"]
    if floor:
        parts.append(f'[[floor]]\nshape = "box"\nsize = {v([30, 0.2, 30])}\n'
                     f'position = {v([0, -0.1, 0])}\n')
    for size, position in boxes:
        parts.append(f'[[static]]\nshape = "box"\nsize = {v(size)}\nposition = {v(position)}\n')
    return "\n".join(parts)


class Points:
    """A tracer over a scene for chosen points (no G-buffer render)."""

    def __init__(self, ctx, text, structure=trace_grid.DEFAULT_STRUCTURE,
                 cells_per_triangle=trace_grid.CELLS_PER_TRIANGLE):
        self.scene = parse_scene(text)
        self.geom = geometry.pack(self.scene)
        self.structure = structure
        self.tracer = SoftTracer(ctx, self.geom, self.scene, cells_per_triangle,
                                 structure=structure)

    def __call__(self, method, points, normals, samples=16, light=None):
        seg = self.scene.linear_light
        light = light or (TRACE_LIGHT_SEGMENT, seg.a, seg.b)
        points = np.asarray(points, np.float32)
        normals = np.broadcast_to(np.asarray(normals, np.float32), points.shape)
        result = self.tracer.trace_points(
            points, normals, np.zeros((0, 4, 4)),
            TraceSettings(method=method, samples=samples, structure=self.structure), light)
        return result

    def release(self):
        self.tracer.release()


@pytest.fixture
def points_tracer(ctx):
    made = []

    def make(text, **kwargs):
        made.append(Points(ctx, text, **kwargs))
        return made[-1]

    yield make
    for p in made:
        p.release()


def check_all_equal_brute(tracer, points, normals, samples=16, light=None):
    brute = tracer("brute", points, normals, samples, light).visibility
    for m in ACCELERATED:
        np.testing.assert_array_equal(tracer(m, points, normals, samples, light).visibility,
                                      brute, err_msg=m)
    return brute


def test_occluder_coplanar_with_the_light_triangle(points_tracer):
    # For receivers on z = 0 the light triangle lies in the plane z = 0, the box's face too.
    tracer = points_tracer(scene_text([([1.0, 1.0, 1.0], [0.0, 2.0, -0.5])],
                                      [-2.0, 4.0, 0.0], [2.0, 4.0, 0.0]))
    xs = np.linspace(-3.0, 3.0, 61)
    for z in (0.0, 1e-3, -1e-3):
        pts = np.stack([xs, np.zeros_like(xs), np.full_like(xs, z)], axis=1)
        check_all_equal_brute(tracer, pts, [0.0, 1.0, 0.0])
    # Beside the plane the answer is well posed: analytic agrees with dense Embree there.
    for z in (1e-3, -1e-3):
        pts = np.stack([xs, np.zeros_like(xs), np.full_like(xs, z)], axis=1)
        ours = tracer("analytic", pts, [0.0, 1.0, 0.0]).visibility
        occ = sr.EmbreeOccluder(dumps.frame_geometry(tracer.scene, 0.0).to_geometry())
        origins = sr.ray_origins(pts, np.tile([0.0, 1.0, 0.0], (len(pts), 1)),
                                 RAY_OFFSET_SCENE * tracer.tracer.grid.spec.diagonal,
                                 RAY_OFFSET_DISTANCE)
        ref = sr.stratified_reference(occ, origins, np.tile([0.0, 1.0, 0.0], (len(pts), 1)),
                                      tracer.scene.linear_light.a, tracer.scene.linear_light.b,
                                      4096)
        assert np.abs(ours - ref).max() <= 0.01
        if z < 0:
            assert ours.min() < 0.9  # the box does shadow the receivers behind the plane


def test_point_collinear_with_the_segment(points_tracer):
    # The point sits on the segment's line beyond b; a box between x = -1 and -0.5 hides the
    # part of the segment beyond it: from x = 5 the nearest face is x = -0.5, t < 0.375 hidden.
    tracer = points_tracer(scene_text([([0.5, 0.5, 0.5], [-0.75, 4.0, 0.0])],
                                      [-2.0, 4.0, 0.0], [2.0, 4.0, 0.0]))
    pts, nrm = [[5.0, 4.0, 0.0]], [[-1.0, 0.0, 0.0]]
    exact = tracer("analytic", pts, nrm).visibility[0]
    assert exact == pytest.approx(0.625, abs=1e-3)
    sampled = check_all_equal_brute(tracer, pts, nrm, samples=64)[0]
    assert sampled == pytest.approx(0.625, abs=1.5 / 64)
    clear = points_tracer(scene_text([([0.5, 0.5, 0.5], [0.0, 8.0, 5.0])],
                                     [-2.0, 4.0, 0.0], [2.0, 4.0, 0.0]))
    assert clear("analytic", pts, nrm).visibility[0] == 1.0


def test_zero_length_segment_equals_a_point_light(ctx, tiny):
    # Scene files reject a == b; the tracer takes one, and must then act as a point light.
    a = np.array([1.0, 5.0, 0.5])
    r = Renderer(ctx, tiny, SIZE, gbuffer=True)
    try:
        frame = r.render(0.0, View.from_camera(tiny.camera, SIZE))
        results = {m: r.trace(0.0, TraceSettings(method=m, samples=4),
                              (TRACE_LIGHT_SEGMENT, a, a))
                   for m in ("brute", "grid", "voxel-cache", "analytic")}
        point = r.trace(0.0, TraceSettings(method="grid", samples=1), (TRACE_LIGHT_POINT, a, a))
    finally:
        r.release()
    g = frame.gbuffer
    mesh = dumps.frame_geometry(tiny, 0.0).to_geometry()
    hard = reference.hard_visibility(mesh, g["position"], g["normal"],
                                     {"kind": "point", "position": a})
    covered = np.isfinite(hard)
    assert 0.005 < np.mean(hard[covered] == 0.0) < 0.98
    for m, res in results.items():
        assert set(np.unique(res.visibility[covered])) <= {0.0, 1.0}, m
        assert np.mean(res.visibility[covered] != hard[covered]) <= 0.003, m
    np.testing.assert_array_equal(point.visibility, results["grid"].visibility)


@pytest.mark.parametrize("method", ["analytic", "voxel-cache"])
def test_scaled_scenes_see_the_same_visibility(points_tracer, method):
    boxes = [([1.5, 2.0, 1.0], [-0.5, 1.0, -0.5]), ([0.6, 0.6, 3.0], [1.5, 0.3, 1.0])]
    rng = np.random.default_rng(3)
    base = np.concatenate([
        np.stack([rng.uniform(-4, 4, 300), np.zeros(300), rng.uniform(-4, 4, 300)], axis=1),
        np.stack([rng.uniform(-1.2, 0.2, 50), np.full(50, 2.0), rng.uniform(-1, 0, 50)], axis=1)])
    results = {}
    for scale in (0.001, 1.0, 1000.0):
        tracer = points_tracer(scene_text(boxes, [-2.0, 8.0, 1.0], [2.0, 8.0, 1.0], scale=scale))
        results[scale] = tracer(method, base * scale, [0.0, 1.0, 0.0], samples=16).visibility
    assert 0.05 < np.mean(results[1.0] < 1.0) < 0.9
    for scale in (0.001, 1000.0):
        diff = np.abs(results[scale] - results[1.0])
        if method == "analytic":
            assert diff.max() <= 1e-3
        else:
            assert np.mean(diff > 0) <= 0.01 and diff.max() <= 1 / 16 + 1e-6


@pytest.mark.parametrize("structure", list(STRUCTURES))
def test_rays_along_voxel_edges_and_corners(points_tracer, structure, monkeypatch):
    # Every top cell with a triangle gets a sub-grid: rays cross sub-cell edges and corners too.
    monkeypatch.setattr(trace_grid, "SUBDIVIDE_ABOVE", 0)
    tracer = points_tracer(scene_text(
        [([1.0, 1.0, 1.0], [0.0, 2.0, 0.0]), ([0.5, 3.0, 0.5], [2.25, 1.5, -1.75])],
        [-3.0, 5.0, 0.0], [3.0, 5.0, 0.0]), structure=structure)
    if structure == "two-level":
        assert tracer.tracer.grid.structure.n_subgrids > 0
    spec = tracer.tracer.grid.spec
    # Grid vertices on the floor's top (y = 0 is a cell boundary only by chance; x, z are).
    xs = spec.origin[0] + spec.cell[0] * np.arange(spec.dims[0] + 1)
    zs = spec.origin[2] + spec.cell[2] * np.arange(spec.dims[2] + 1)
    near = lambda v: v[np.abs(v) < 4.0]  # noqa: E731
    gx, gz = np.meshgrid(near(xs), near(zs))
    pts = np.stack([gx.ravel(), np.zeros(gx.size), gz.ravel()], axis=1)
    # A segment along a grid line (z = a cell boundary): rays in a cell-face plane.
    zk = float(near(zs)[len(near(zs)) // 2])
    seg = (TRACE_LIGHT_SEGMENT, np.array([-3.0, 5.0, zk]), np.array([3.0, 5.0, zk]))
    check_all_equal_brute(tracer, pts, [0.0, 1.0, 0.0], 16, seg)
    # Point lights straight above each vertex: every ray runs along a vertical cell edge.
    for x in near(xs)[::3]:
        p = np.array([x, 6.0, zk])
        v = check_all_equal_brute(tracer, pts, [0.0, 1.0, 0.0], 1, (TRACE_LIGHT_POINT, p, p))
        under = np.isclose(pts[:, 0], x) & np.isclose(pts[:, 2], zk)
        inside = (np.abs(x) < 0.5) and (np.abs(zk) < 0.5)
        assert v[under][0] == (0.0 if inside else 1.0)


def test_receivers_do_not_shadow_themselves(ctx):
    # Convex shapes lit from above their horizon: every point sees the whole segment.
    text = scene_text([([2.0, 1.0, 2.0], [-2.0, 0.5, 0.0])], [-2.0, 9.0, 1.0], [2.0, 9.0, 1.0],
                      floor=False)
    text += '\n[[static]]\nshape = "sphere"\nradius = 1.0\nposition = [2.0, 1.0, 0.0]\n'
    scene = parse_scene(text)
    frame, results, _ = gbuffer_trace(ctx, scene, ("brute", "voxel-cache", "analytic"), 8,
                                      size=(192, 108))
    g = frame.gbuffer
    covered = np.isfinite(g["position"]).all(axis=-1)
    light = scene.linear_light
    h = np.stack([np.einsum("hwk,k->hw", g["normal"], light.a) - np.einsum(
        "hwk,hwk->hw", g["normal"], g["position"]) for _ in (0,)])[0]
    hb = np.einsum("hwk,k->hw", g["normal"], light.b) - np.einsum(
        "hwk,hwk->hw", g["normal"], g["position"])
    # Points of the sphere's upper half and the box's top, with the segment clearly above.
    lit = covered & (h > 0.1) & (hb > 0.1) & (g["position"][..., 1] > 0.99)
    assert lit.sum() > 100
    for m, res in results.items():
        assert (res.visibility[lit] == 1.0).all(), m


def test_segment_partly_below_the_horizon(points_tracer):
    tracer = points_tracer(scene_text([([0.5, 0.5, 0.5], [8.0, 0.25, 8.0])],
                                      [-2.0, 1.0, 0.0], [2.0, 1.0, 0.0], floor=False))
    pts, nrm = [[0.0, 0.0, 0.0]], [[1.0, 0.0, 0.0]]
    assert tracer("analytic", pts, nrm).visibility[0] == pytest.approx(0.5, abs=1e-4)
    assert check_all_equal_brute(tracer, pts, nrm, samples=64)[0] == 0.5
    # Wholly below: nothing visible.
    assert tracer("analytic", pts, [[0.0, -1.0, 0.0]]).visibility[0] == 0.0


def test_occluder_beyond_the_light_casts_nothing(points_tracer):
    tracer = points_tracer(scene_text([([8.0, 0.5, 8.0], [0.0, 6.0, 0.0])],
                                      [-2.0, 4.0, 0.0], [2.0, 4.0, 0.0]))
    rng = np.random.default_rng(5)
    pts = np.stack([rng.uniform(-3, 3, 200), np.zeros(200), rng.uniform(-3, 3, 200)], axis=1)
    for m in (*ALL, "analytic"):
        assert (tracer(m, pts, [0.0, 1.0, 0.0]).visibility == 1.0).all(), m


# -- resources ----------------------------------------------------------------------------------
def test_frames_do_not_grow_gl_objects_and_characters_move(ctx, tiny):
    r = Renderer(ctx, tiny, SIZE, gbuffer=True)
    view = View.from_camera(tiny.camera, SIZE)
    try:
        counts, images = [], []
        for k in range(4):
            r.render(k * 0.7, view)
            res = r.trace(k * 0.7, TraceSettings(samples=4))
            counts.append(r.soft_tracer.gl_objects())
            images.append(res.visibility)
            assert res.ms["build_dynamic"] > 0.0
            assert res.ms["build_static"] == (res.ms["build_static"] if k == 0 else 0.0)
        assert len(set(counts)) == 1
        assert not np.array_equal(images[0], images[-1])
    finally:
        r.release()
    assert r.soft_tracer is None


@pytest.mark.parametrize("structure", list(STRUCTURES))
def test_leaves_the_characters_left_hold_nothing_of_them(ctx, tiny, structure):
    # Each frame rewrites only the leaves the characters touch now or touched before: a frame
    # after the characters walked on must trace as a tracer that never saw them elsewhere.
    settings = TraceSettings(method="grid", samples=4, structure=structure)
    t0, t1 = 0.0, 6.0

    def traced(times):
        r = Renderer(ctx, tiny, SIZE, gbuffer=True)
        view = View.from_camera(tiny.camera, SIZE)
        try:
            for t in times:
                r.render(t, view)
                result = r.trace(t, settings)
            return result
        finally:
            r.release()

    walked, fresh = traced([t0, t1]), traced([t1])
    assert not np.array_equal(traced([t0]).visibility, fresh.visibility, equal_nan=True)
    np.testing.assert_array_equal(walked.visibility, fresh.visibility)
    np.testing.assert_array_equal(walked.counters["ray_triangle_tests"],
                                  fresh.counters["ray_triangle_tests"])


def test_the_loop_budget_probe_catches_a_cut_short_trace(ctx, courtyard, monkeypatch):
    # A step budget past llvmpipe's loop limit lets brute force run out of loops: the probe
    # must catch it, and the tracer halve the budget until nothing is cut short.
    r = Renderer(ctx, courtyard, (32, 18), gbuffer=True)
    try:
        r.render(0.0, View.from_camera(courtyard.camera, (32, 18)))
        grid = r.trace(0.0, TraceSettings(method="grid", samples=64))
        monkeypatch.setattr(soft_tracer, "STEP_BUDGET", 1 << 17)
        brute = r.trace(0.0, TraceSettings(method="brute", samples=64))
    finally:
        r.release()
    assert brute.truncated == 0 and brute.step_budget < 1 << 17
    assert brute.ms["trace_discarded"] > 0
    np.testing.assert_array_equal(brute.visibility, grid.visibility)


@pytest.mark.parametrize("structure", list(STRUCTURES))
def test_points_resumed_across_dispatches_give_the_same_visibility(ctx, courtyard, structure,
                                                                   monkeypatch):
    # A tiny step budget stops every point many times, mid-ray, mid-leaf and mid-enumeration;
    # each resumes at its cursor. Sampled methods must give exactly the unbroken results;
    # analytic the same up to float rounding.
    size = (32, 18)
    methods = (*ALL, "analytic")
    view = View.from_camera(courtyard.camera, size)
    whole, split = {}, {}
    r = Renderer(ctx, courtyard, size, gbuffer=True)
    try:
        r.render(0.0, view)
        for m in methods:
            whole[m] = r.trace(0.0, TraceSettings(method=m, samples=8, structure=structure))
    finally:
        r.release()
    for m in methods:  # a new tracer per budget: a tracer keeps the budget that worked
        monkeypatch.setattr(soft_tracer, "STEP_BUDGET", 1150 if m == "analytic" else 40)
        r = Renderer(ctx, courtyard, size, gbuffer=True)
        try:
            r.render(0.0, view)
            split[m] = r.trace(0.0, TraceSettings(method=m, samples=8, structure=structure))
        finally:
            r.release()
    for m in methods:
        assert split[m].truncated == 0 and whole[m].truncated == 0, m
        assert split[m].rounds > 3 and split[m].means()["dispatches"] > 2, m
        if m == "analytic":
            np.testing.assert_allclose(split[m].visibility, whole[m].visibility, atol=1e-5)
        else:
            np.testing.assert_array_equal(split[m].visibility, whole[m].visibility, err_msg=m)


def sphere_field_text(rows: int, spacing: float, radius: float, height: float) -> str:
    """A floor under a rows x rows field of spheres (320 triangles each) and a linear light."""
    text = scene_text([], [-4.0, 7.0, -1.0], [4.0, 7.0, 1.0])
    half = (rows - 1) * spacing / 2
    for i in range(rows):
        for j in range(rows):
            x, z = i * spacing - half, j * spacing - half
            text += (f'\n[[static]]\nshape = "sphere"\nradius = {radius}\n'
                     f"position = [{x}, {height}, {z}]\n")
    return text


def test_analytic_splits_work_past_the_old_loop_budget(points_tracer):
    # 400 spheres (128,000 triangles) in a uniform grid of 0.001 cells per triangle: each cell
    # lists thousands of triangles, and the light triangle of a point on the floor touches
    # several cells. Run as one invocation per point, with no split (as analytic ran before),
    # every one of these 40 points ran out of llvmpipe's loop budget. Split by the step
    # budget, none does, and the result matches Embree's dense reference; brute force on the
    # same scene agrees with Embree on its own rays.
    tracer = points_tracer(sphere_field_text(20, 0.55, 0.22, 2.5), structure="uniform",
                           cells_per_triangle=0.001)
    rng = np.random.default_rng(7)
    pts = np.stack([rng.uniform(-4.5, 4.5, 40), np.zeros(40), rng.uniform(-4.5, 4.5, 40)],
                   axis=1)
    up = np.array([0.0, 1.0, 0.0])
    exact = tracer("analytic", pts, up)
    assert exact.truncated == 0
    # Each entry of a leaf's list is at least one loop trip: far past one dispatch's budget.
    assert exact.counters["triangle_triangle_tests"].min() > 2 * soft_tracer.STEP_BUDGET
    assert exact.counters["dispatches"].min() > 1
    light = tracer.scene.linear_light
    occ = sr.EmbreeOccluder(dumps.frame_geometry(tracer.scene, 0.0).to_geometry())
    normals = np.tile(up, (len(pts), 1))
    origins = sr.ray_origins(pts, normals, RAY_OFFSET_SCENE * tracer.tracer.grid.spec.diagonal,
                             RAY_OFFSET_DISTANCE)
    ref = sr.stratified_reference(occ, origins, normals, light.a, light.b, 1024)
    assert 0.05 < ref.mean() < 0.95  # penumbrae, not all lit or all dark
    assert rmse(exact.visibility, ref) <= 0.005
    assert np.abs(exact.visibility - ref).max() <= 0.03
    brute = tracer("brute", pts, up, samples=16)
    assert brute.truncated == 0
    t = sr.tracer_samples(np.arange(len(pts)), 16)
    same_rays = sr.segment_visibility(occ, origins, normals, light.a, light.b, t)
    assert np.mean(brute.visibility != same_rays) <= 0.05


@pytest.mark.parametrize("structure", list(STRUCTURES))
def test_byte_counters_follow_the_reads(ctx, courtyard, structure):
    _, results, _ = gbuffer_trace(ctx, courtyard, ("grid", "tri-cache", "voxel-cache"), 8,
                                  size=(48, 27), structure=structure)
    for m, res in results.items():
        c, covered = res.counters, res.covered
        # Every ray-triangle test and every test against the light triangle reads one triangle.
        expected = TRIANGLE_BYTES * (c["ray_triangle_tests"].astype(np.uint64)
                                     + c["triangle_triangle_tests"])
        np.testing.assert_array_equal(c["bytes_triangles"][covered], expected[covered], m)
        # A leaf visit reads its four offsets at least.
        assert (c["bytes_cells"][covered] >= 16 * c["voxels_visited"][covered]).all(), m
        means = res.means()
        assert means["bytes_total"] == pytest.approx(sum(means[k] for k in BYTE_COUNTERS))
    assert results["grid"].means()["bytes_candidates"] == 0
    # tri-cache reads a word per list entry; voxel-cache reads its candidate lists instead.
    for m in ("tri-cache", "voxel-cache"):
        assert results[m].means()["bytes_candidates"] > 0
    assert (results["voxel-cache"].means()["bytes_triangles"]
            < results["tri-cache"].means()["bytes_triangles"]
            < results["grid"].means()["bytes_triangles"])


@pytest.mark.skipif(not (ASSETS / "real" / "monastery.toml").exists(),
                    reason="the real level is fetched by assets/fetch_real.py")
def test_analytic_on_the_real_level_is_within_0005_of_1024_embree_samples(ctx):
    from game.scene import load_scene

    with pytest.warns(UserWarning):  # the level's file has zero-area triangles, removed
        scene = load_scene(ASSETS / "real" / "monastery.toml")
    frame, results, diagonal = gbuffer_trace(ctx, scene, ("analytic",), samples=1,
                                             size=(48, 27))
    exact = results["analytic"]
    assert exact.truncated == 0
    covered, origins, normals = origins_of(frame, diagonal)
    light = scene.linear_light
    ref = sr.stratified_reference(embree_of(scene), origins, normals, light.a, light.b, 1024)
    shadowed = ref < 0.999
    assert shadowed.sum() > 30
    assert rmse(exact.visibility[covered], ref) <= 0.005
