"""The soft-shadow tracer on chosen points where tracers fail: coplanar and collinear
occluders, a zero-length segment, scaled scenes, rays along voxel edges, self-shadowing."""

from __future__ import annotations

import numpy as np
import pytest

from game.app import dumps
from game.gpu.blocks import TRACE_LIGHT_POINT, TRACE_LIGHT_SEGMENT
from game.reference import hard as reference
from game.reference import soft as sr
from game.render.renderer import Renderer, View
from game.scene import parse_scene
from game.soft import grid as trace_grid
from game.soft.grid import STRUCTURES
from game.soft.tracer import (
    RAY_OFFSET_DISTANCE,
    RAY_OFFSET_SCENE,
    TraceSettings,
)
from tests.soft.tracer_helpers import (
    ALL,
    SIZE,
    check_all_equal_brute,
    gbuffer_trace,
    scene_text,
)


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


