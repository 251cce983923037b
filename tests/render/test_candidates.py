"""The map records a fragment considers: counted outside the frame, without changing it."""

import numpy as np
import pytest

from game.render.renderer import Renderer, View
from game.shadows.plan import ShadowSettings
from tests.helpers import SMALL_SIZE as SIZE


def frames(ctx, scene, count: bool, settings=None):
    r = Renderer(ctx, scene, SIZE, settings, gbuffer=True)
    r.count_candidates = count
    view = View.from_camera(scene.camera, SIZE)
    try:
        return [r.render(k / 30, view) for k in range(2)]
    finally:
        r.release()


@pytest.mark.parametrize("grid", ["off", "on"])
def test_candidates_are_counted_and_the_frame_is_unchanged(ctx, courtyard, grid):
    settings = ShadowSettings(grid=grid)
    counted = frames(ctx, courtyard, True, settings)
    plain = frames(ctx, courtyard, False, settings)
    for a, b in zip(counted, plain, strict=True):
        assert np.array_equal(a.image, b.image)
        assert np.array_equal(a.gbuffer["lit"], b.gbuffer["lit"], equal_nan=True)
        assert np.array_equal(a.maps_sampled, b.maps_sampled)
        assert b.map_candidates is None and b.map_candidates_per_fragment is None
        # Every map read was considered first; without a grid every pixel that faces the
        # light considers maps until one shadows it fully.
        assert (a.map_candidates >= a.maps_sampled).all()
        assert a.map_candidates_per_fragment >= a.maps_per_fragment > 0


def test_a_grid_considers_fewer_records_than_a_loop_over_many_maps(ctx, courtyard):
    loop = frames(ctx, courtyard, True, ShadowSettings(grid="off", clump_count=12))[-1]
    grid = frames(ctx, courtyard, True, ShadowSettings(grid="on", clump_count=12))[-1]
    assert grid.map_candidates_per_fragment < loop.map_candidates_per_fragment
    assert np.array_equal(grid.gbuffer["lit"], loop.gbuffer["lit"], equal_nan=True)
