"""Clumping in light space as a partition: tiles that do not overlap, every caster in each tile
it crosses, a grid aligned to the tiles, and one static map per fragment."""

from __future__ import annotations

import numpy as np
import pytest

from game.gpu.blocks import GRID_TILES
from game.render.renderer import Renderer, View
from game.scene import load_scene
from game.shadows import clumping, map_grid
from game.shadows.methods.clumped.tiles import TileMembers
from game.shadows.plan import ShadowSettings, shadow_reach
from tests.helpers import ACCURACY_SIZE
from tests.shadows.level_scenes import write_level


@pytest.fixture(scope="module")
def level(tmp_path_factory):
    return load_scene(write_level(tmp_path_factory.mktemp("tiles") / "one", as_parts=False))


def test_tiles_partition_the_plane_and_hold_every_caster_they_cross(ctx, level):
    renderer = Renderer(ctx, level, ACCURACY_SIZE)
    try:
        method = renderer.method
        members = method.members
        assert isinstance(members, TileMembers)
        records = method.static_maps
        assert len(records) >= 8
        tiles = np.array([r.tile for r in records])
        # Squares of one side on one lattice, none twice.
        sides = tiles[:, 2:] - tiles[:, :2]
        assert np.allclose(sides, members.span)
        steps = (tiles[:, :2] - members.origin) / members.span
        assert np.allclose(steps, np.round(steps))
        assert len({tuple(np.round(s).astype(int)) for s in steps}) == len(tiles)
        # Each unit is drawn into every tile its footprint crosses, and each tile's map covers
        # the casters it holds (cut to the tile and the reach).
        index = members.units.index()
        for k, record in enumerate(records):
            held = {index[key] for key in members.keys[k]}
            for u, rect in enumerate(members.unit_rects):
                inside = (rect[0] < record.tile[2] and rect[2] > record.tile[0]
                          and rect[1] < record.tile[3] and rect[3] > record.tile[1])
                if inside:
                    assert u in held, (k, u)
            cover = clumping.union_rect(record.cover)
            assert np.all(record.fit.rect[:2] <= cover[:2] + 1e-6)
            assert np.all(record.fit.rect[2:] >= cover[2:] - 1e-6)
    finally:
        renderer.release()


def test_the_grid_names_each_cells_tile_map_first_where_its_casters_reach(ctx, level):
    renderer = Renderer(ctx, level, ACCURACY_SIZE)
    try:
        records = renderer.method.static_maps
        grid = map_grid.GridBuilder().build(
            [r.fit for r in records], None, "on", [r.cover for r in records],
            shadow_reach(renderer.settings), tiles=[r.tile for r in records])
    finally:
        renderer.release()
    assert grid.mode == GRID_TILES
    size, rect, data = grid.size, grid.rect, grid.data
    cell = (rect[2:] - rect[:2]) / size
    reach = shadow_reach(renderer.settings)
    named = empty = 0
    for c in range(size * size):
        lo = rect[:2] + np.array([c % size, c // size]) * cell
        centre = lo + 0.5 * cell
        owner = [j for j, r in enumerate(records)
                 if np.all(centre >= r.tile[:2]) and np.all(centre < r.tile[2:])]
        entries = data[data[c]:data[c + 1]]
        assert len(entries) <= 1  # no character maps here
        first = entries[0] if len(entries) else -1
        assert first in ((owner[0], -1) if owner else (-1,)), c
        if owner and first == -1:
            # Only where no cover of the tile's casters, grown by the reach, meets the cell
            # (shrunk by a sliver, as the grid's own ranges are grown by one).
            r = records[owner[0]]
            grown = np.asarray(r.cover, float).reshape(-1, 4) + (
                reach * r.fit.texel * np.array([-1.0, -1.0, 1.0, 1.0]))
            inner = np.concatenate([lo + 0.01 * cell, lo + 0.99 * cell])
            meets = ((grown[:, 0] < inner[2]) & (grown[:, 2] > inner[0])
                     & (grown[:, 1] < inner[3]) & (grown[:, 3] > inner[1]))
            assert not meets.any(), c
            empty += 1
        named += first >= 0
    assert named > 0 and empty > 0


@pytest.mark.parametrize("clumping", ["light", "world"])
def test_a_fragment_considers_one_static_map_where_tiled(ctx, level, clumping):
    renderer = Renderer(ctx, level, ACCURACY_SIZE, ShadowSettings(clumping=clumping),
                        gbuffer=True)
    renderer.count_candidates = True
    try:
        frame = renderer.render(0.0, View.from_camera(level.camera, ACCURACY_SIZE))
        maps = len(renderer.method.static_maps)
    finally:
        renderer.release()
    assert maps >= 8
    most = int(frame.map_candidates[frame.covered].max())
    if clumping == "light":
        assert most == 1
    else:  # world-space clumps overlap under the light: some fragments consider several
        assert most > 1
