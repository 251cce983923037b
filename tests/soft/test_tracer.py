"""The soft-shadow tracer on llvmpipe: its accelerated methods equal brute force, and its
samples and analytic visibility agree with Embree."""

from __future__ import annotations

import numpy as np
import pytest

from game.reference import soft as sr
from game.render.renderer import Renderer, View
from game.soft.grid import STRUCTURES
from game.soft.tracer import (
    TraceSettings,
)
from tests.soft.tracer_helpers import (
    ACCELERATED,
    ALL,
    SIZE,
    embree_of,
    gbuffer_trace,
    origins_of,
    rmse,
)


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


