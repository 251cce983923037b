"""The CPU twin of the soft-shadow tracer (game/soft/cpu_twin.py) against the GPU pass on llvmpipe:
the same visibility on every point, and the same counters where the methods keep no state shared
between points."""

from __future__ import annotations

import numpy as np
import pytest

from game.errors import GameError
from game.render.renderer import Renderer, View
from game.soft import cpu_twin
from game.soft.grid import STRUCTURES
from game.soft.methods import TraceSettings

pytestmark = pytest.mark.skipif(not cpu_twin.numba_available(),
                                reason="the CPU twin needs numba (pip install -e '.[cache]')")

SIZE = (48, 27)
METHODS = ("brute", "grid", "tri-cache", "voxel-cache")
# Counters the twin must match exactly: every one for the methods without state shared between
# points; tri-cache's words are shared, and on the GPU the lanes running side by side overwrite
# each other's, so only its ray tests (decided by the cull, not by the words) match.
SAME_COUNTERS = ("ray_triangle_tests", "triangle_triangle_tests", "voxels_visited",
                 "candidates", "overflows", "bytes_triangles", "bytes_cells", "bytes_candidates")


def twin_and_gpu(ctx, scene, structure: str, samples: int):
    """The G-buffer's points, each method's GPU result and the twin's scene."""
    r = Renderer(ctx, scene, SIZE, gbuffer=True)
    try:
        frame = r.render(0.0, View.from_camera(scene.camera, SIZE))
        points, covered = cpu_twin.TwinPoints.from_gbuffer(frame.gbuffer)
        gpu = {m: r.trace(0.0, TraceSettings(method=m, samples=samples, structure=structure))
               for m in METHODS}
        twin_scene = cpu_twin.TwinScene.from_tracer(r.soft_tracer, r.traced.segment())
    finally:
        r.release()
    return points, covered, gpu, twin_scene


@pytest.mark.parametrize("structure", list(STRUCTURES))
@pytest.mark.parametrize("samples", [1, 8])
def test_twin_sees_what_the_gpu_pass_sees_on_every_point(ctx, tiny, structure, samples):
    points, covered, gpu, twin_scene = twin_and_gpu(ctx, tiny, structure, samples)
    assert len(points) > 500
    for method in METHODS:
        twin = cpu_twin.trace(twin_scene, points, method, samples)
        g = gpu[method]
        assert np.array_equal(twin.visibility, g.visibility[covered]), method
        assert 0 < twin.visibility.mean() < 1
        names = SAME_COUNTERS if method != "tri-cache" else ("ray_triangle_tests",)
        if method == "voxel-cache" and g.counters["dispatches"][covered].max() > 1:
            names = ("ray_triangle_tests",)  # a split point starts again with an empty cache
        for name in names:
            assert np.array_equal(twin.counters[name], g.counters[name][covered]), (method, name)
        if method == "tri-cache":
            assert (twin.counters["triangle_triangle_tests"]
                    <= g.counters["triangle_triangle_tests"][covered]).all()


def test_threads_change_nothing_but_the_time(ctx, courtyard):
    points, covered, gpu, twin_scene = twin_and_gpu(ctx, courtyard, "two-level", 8)
    for method in ("grid", "tri-cache", "voxel-cache"):
        one = cpu_twin.trace(twin_scene, points, method, 8)
        two = cpu_twin.trace(twin_scene, points, method, 8, threads=2, count=False)
        assert np.array_equal(one.visible, two.visible), method
        assert np.array_equal(one.rays, two.rays)
        assert np.array_equal(one.visibility, gpu[method].visibility[covered]), method
        assert two.counters is None and two.seconds > 0


def test_unknown_method_is_one_clear_error(ctx, tiny):
    points, _, _, twin_scene = twin_and_gpu(ctx, tiny, "uniform", 1)
    with pytest.raises(GameError, match="no method 'analytic'"):
        cpu_twin.trace(twin_scene, points, "analytic", 1)
