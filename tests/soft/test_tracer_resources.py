"""The soft-shadow tracer's resources and budget: GL objects, characters' leaves, the loop
budget, dispatches resumed, byte counters, and the real level."""

from __future__ import annotations

import numpy as np
import pytest

from game.app import dumps
from game.reference import soft as sr
from game.render.renderer import Renderer, View
from game.soft import tracer as soft_tracer
from game.soft.grid import STRUCTURES
from game.soft.results import BYTE_COUNTERS
from game.soft.tracer import (
    RAY_OFFSET_DISTANCE,
    RAY_OFFSET_SCENE,
    TRIANGLE_BYTES,
    TraceSettings,
)
from tests.helpers import ASSETS
from tests.soft.tracer_helpers import (
    ALL,
    SIZE,
    embree_of,
    gbuffer_trace,
    origins_of,
    rmse,
    sphere_field_text,
)


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
