"""The raster soft-shadow methods (segment-maps, pcss): the tracer's dump, the right visibility
where the answer is plain, against the exact analytic visibility, and the statics' maps cached
while the walkers' are drawn every frame."""

from __future__ import annotations

import numpy as np
import pytest

from game.gpu import resources
from game.render.renderer import Renderer, View
from game.scene import load_scene, parse_scene
from game.soft.map_frusta import EDGE_TEXELS, MAX_TAN, box_corners, fit, plan, receiver_bounds
from game.soft.methods import RASTER_METHODS, TraceSettings, is_raster
from tests.soft.tracer_helpers import rmse, scene_text

SIZE = (96, 54)
RASTER = tuple(RASTER_METHODS)
# A floor under a wide slab held up 2.5 m, a 4 m bar of light above it and a camera low enough
# to see the floor under the slab: its middle is in the umbra, its rim in a penumbra.
SLAB = scene_text([([8.0, 0.2, 8.0], [0.0, 2.5, 0.0])], [-2.0, 8.0, 0.0], [2.0, 8.0, 0.0]
                  ).replace("position = [0.0, 6.0, 10.0]", "position = [0.0, 1.2, 14.0]"
                  ).replace("target = [0.0, 0.0, 0.0]", "target = [0.0, 0.6, 0.0]")
OPEN = scene_text([], [-2.0, 8.0, 1.0], [2.0, 8.0, 1.0])
# The bounds of each method's RMSE against the analytic visibility on the tiny scene at SIZE
# (most of its points lit), about 2.5 times what they measure at their defaults (segment-maps:
# 0.0018; pcss: 0.0095).
RMSE_BOUND = {"segment-maps": 0.005, "pcss": 0.025}


def traced(ctx, scene, methods, t=0.0, **settings):
    """Render the G-buffer at time t and trace it with each method; returns the frame's
    G-buffer and the results by method."""
    r = Renderer(ctx, scene, SIZE, gbuffer=True)
    try:
        frame = r.render(t, View.from_camera(scene.camera, SIZE))
        results = {m: r.trace(t, TraceSettings(method=m, **settings)) for m in methods}
    finally:
        r.release()
    return frame.gbuffer, results


def test_the_registry_tells_raster_from_traced():
    assert set(RASTER) == {"segment-maps", "pcss"}
    assert all(is_raster(m) for m in RASTER)
    assert not is_raster("voxel-cache") and not is_raster("analytic")


@pytest.mark.parametrize("method", RASTER)
def test_the_soft_dump_has_the_tracers_shape(ctx, tiny, method):
    r = Renderer(ctx, tiny, SIZE, gbuffer=True)
    try:
        frame = r.render(0.0, View.from_camera(tiny.camera, SIZE),
                         soft=TraceSettings(method=method))
    finally:
        r.release()
    soft = frame.gbuffer["soft"]
    sky = ~np.isfinite(frame.gbuffer["position"]).all(axis=-1)
    assert soft.shape == (SIZE[1], SIZE[0]) and soft.dtype == np.float32
    assert sky.any() and (~sky).any()
    np.testing.assert_array_equal(np.isnan(soft), sky)
    assert np.nanmin(soft) >= 0.0 and np.nanmax(soft) <= 1.0
    assert frame.image is not None


@pytest.mark.parametrize("method", RASTER)
def test_fully_lit_where_nothing_blocks(ctx, method):
    _, results = traced(ctx, parse_scene(OPEN), [method])
    vis = results[method].visibility
    assert np.isfinite(vis).any()
    assert np.nanmin(vis) > 0.999


@pytest.mark.parametrize("method", RASTER)
def test_umbra_penumbra_and_lit_under_a_large_blocker(ctx, method):
    g, results = traced(ctx, parse_scene(SLAB), ["analytic", method])
    exact, vis = results["analytic"].visibility, results[method].visibility
    floor = np.isfinite(exact) & (g["position"][..., 1] < 0.01)
    umbra, lit = floor & (exact == 0.0), floor & (exact == 1.0)
    penumbra = floor & (exact > 0.2) & (exact < 0.8)
    assert umbra.sum() > 50 and lit.sum() > 50 and penumbra.sum() > 20
    assert np.quantile(vis[umbra], 0.98) < 0.02
    assert np.quantile(vis[lit], 0.02) > 0.98
    between = (vis[penumbra] > 0.05) & (vis[penumbra] < 0.95)
    assert between.mean() > 0.9


@pytest.mark.parametrize("method", RASTER)
def test_error_against_the_analytic_visibility(ctx, tiny, method):
    _, results = traced(ctx, tiny, ["analytic", method], t=1.3)
    exact, vis = results["analytic"].visibility, results[method].visibility
    covered = np.isfinite(exact)
    np.testing.assert_array_equal(np.isfinite(vis), covered)
    assert rmse(vis[covered], exact[covered]) < RMSE_BOUND[method]


def test_more_maps_come_nearer_the_analytic_visibility(ctx, tiny):
    errors = []
    for k in (1, 4, 16):
        _, results = traced(ctx, tiny, ["analytic", "segment-maps"], t=1.3, maps=k)
        exact = results["analytic"].visibility
        covered = np.isfinite(exact)
        errors.append(rmse(results["segment-maps"].visibility[covered], exact[covered]))
    assert errors[0] > errors[1] > errors[2]


@pytest.mark.parametrize("method", RASTER)
def test_statics_maps_are_cached_and_the_walkers_drawn_every_frame(ctx, tiny, method):
    r = Renderer(ctx, tiny, SIZE, gbuffer=True)
    view = View.from_camera(tiny.camera, SIZE)
    settings = TraceSettings(method=method, maps=4)
    count = 1 if method == "pcss" else 4
    try:
        frames = []
        for t in (0.0, 0.7, 1.4):
            r.render(t, view)
            frames.append(r.trace(t, settings))
        raster = r.traced.raster
        objects = raster.gl_objects()
        r.render(2.1, view)
        r.trace(2.1, settings)
        assert raster.gl_objects() == objects > 0
    finally:
        r.release()
    assert raster.gl_objects() == 0
    first, later = frames[0].maps, [f.maps for f in frames[1:]]
    assert first["soft_maps_static_rendered"] == count
    assert first["soft_maps_dynamic_rendered"] == count
    for maps in later:
        assert maps["soft_maps_static_rendered"] == 0
        assert maps["soft_maps_static_cached"] == count
        assert maps["soft_maps_dynamic_rendered"] == count
        assert maps["soft_triangles_to_maps"] < first["soft_triangles_to_maps"]
    assert frames[0].ms["build_static"] > frames[1].ms["build_static"]
    # The walker moved between the frames, and its shadow with it.
    assert not np.array_equal(frames[0].visibility, frames[2].visibility)


def test_a_maps_frustum_holds_every_receiver_corner():
    lo, hi = np.array([-10.0, 0.0, -8.0]), np.array([10.0, 3.0, 8.0])
    casters = (lo - 1.0, hi + 1.0)
    for eye in ([0.0, 9.0, 0.0], [-12.0, 6.0, 3.0], [4.0, 20.0, -9.0]):
        frustum = fit(np.array(eye), box_corners(lo, hi), casters, 512)
        corners = np.c_[box_corners(lo, hi), np.ones(8)] @ frustum.view_proj.T
        assert (corners[:, 3] > 0).all()
        assert (np.abs(corners[:, :3]) <= corners[:, 3:] * (1 + 1e-9)).all(), eye


def test_a_plan_of_many_points_gives_each_the_map_it_gets_alone():
    # Eyes above the receivers, inside their hull (the map as wide as a map may look), on one
    # of their corners and far to the side: planned together, each keeps its own frustum.
    lo, hi = np.array([-10.0, 0.0, -8.0]), np.array([10.0, 3.0, 8.0])
    corners = box_corners(lo, hi)
    casters = (lo - 1.0, hi + 1.0)
    eyes = np.array([[0.0, 9.0, 0.0], [1.0, 1.5, -2.0], hi, [-40.0, 5.0, 30.0]])
    together = plan(eyes, corners, casters, 512)
    for eye, frustum in zip(eyes, together, strict=True):
        alone = fit(eye, corners, casters, 512)
        np.testing.assert_allclose(frustum.view_proj, alone.view_proj, rtol=1e-12, atol=1e-12)
        assert (frustum.near, frustum.far, frustum.texel) == pytest.approx(
            (alone.near, alone.far, alone.texel), rel=1e-12)
    widest = 2 * MAX_TAN * (1 + 2 * EDGE_TEXELS / 512) / 512   # inside the hull
    assert together[1].texel == pytest.approx(widest)
    assert widest > 1.5 * together[0].texel


# A floor and one walker standing still: a sheet of one quad 1.5 m up, its faces turned down,
# away from the bar of light above it. It is an open mesh: culled as a closed walker's back
# faces are, it would cast no shadow.
SHEET = scene_text([], [-2.0, 8.0, 1.0], [2.0, 8.0, 1.0]) + (
    '[[character]]\nshape = "mesh"\nfile = "sheet.obj"\npath = [[0.0, 1.5, 0.0]]\n')
SHEET_OBJ = "v -0.75 0 -0.75\nv 0.75 0 -0.75\nv 0.75 0 0.75\nv -0.75 0 0.75\nf 1 2 3\nf 1 3 4\n"


@pytest.mark.parametrize("walker", ["closed capsule", "open sheet"])
def test_culling_the_closed_walkers_back_faces_leaves_the_visibility_as_it_was(
        ctx, tiny, tmp_path, walker):
    scene = tiny
    if walker == "open sheet":
        (tmp_path / "sheet.obj").write_text(SHEET_OBJ)
        (tmp_path / "scene.toml").write_text(SHEET)
        scene = load_scene(tmp_path / "scene.toml")
    r = Renderer(ctx, scene, SIZE, gbuffer=True)
    settings = TraceSettings(method="segment-maps", maps=4)
    try:
        r.render(1.3, View.from_camera(scene.camera, SIZE))
        culled = r.trace(1.3, settings)           # closed walkers culled: the default
        r.traced.raster.cull_walkers = False
        whole = r.trace(1.3, settings)
    finally:
        r.release()
    np.testing.assert_array_equal(culled.visibility, whole.visibility)
    shadowed = np.isfinite(whole.visibility) & (whole.visibility < 0.5)
    assert shadowed.sum() >= 10   # the sheet's shadow, on a floor nothing else shadows


def test_receiver_bounds_skip_uncovered_pixels():
    positions = np.zeros((2, 2, 4), np.float32)
    positions[0, 0, :3] = [1.0, 2.0, 3.0]
    positions[1, 1, :3] = [-1.0, 5.0, 0.0]
    positions[0, 1, :3] = [100.0, 100.0, 100.0]
    covered = np.array([[True, False], [False, True]])
    lo, hi = receiver_bounds(positions, covered)
    np.testing.assert_array_equal(lo, [-1.0, 2.0, 0.0])
    np.testing.assert_array_equal(hi, [1.0, 5.0, 3.0])


def test_release_frees_every_gl_object(ctx, tiny):
    before = resources.live_gl_names()
    traced(ctx, tiny, RASTER)
    assert resources.live_gl_names() == before
