"""Clearing the character maps: merged squares clear exactly the maps' texels."""

import numpy as np

from game.render.shadow_pass import merged_squares
from game.shadows import crowd


def _texels(squares) -> set:
    return {(layer, x + i, y + j) for layer, x, y, side in squares
            for i in range(side) for j in range(side)}


def test_merged_squares_clear_the_same_texels_in_fewer_calls():
    rng = np.random.default_rng(3)
    for _ in range(20):
        sizes = rng.choice([4, 8, 16, 32], size=int(rng.integers(1, 40))).tolist()
        maps = [crowd.CrowdMap([k], s) for k, s in enumerate(sizes)]
        crowd.pack(maps, layers=4, layer_resolution=64)
        squares = {(m.layer, *m.origin, m.resolution) for m in maps}
        merged = merged_squares(squares)
        assert _texels(merged) == _texels(squares)
        assert len(merged) <= len(squares)


def test_a_full_layer_of_maps_is_one_clear():
    maps = [crowd.CrowdMap([k], 16) for k in range(16)]
    crowd.pack(maps, layers=1, layer_resolution=64)
    assert merged_squares({(m.layer, *m.origin, m.resolution) for m in maps}) == {(0, 0, 0, 64)}


def test_squares_that_do_not_tile_stay_apart():
    squares = {(0, 0, 0, 8), (0, 8, 0, 8), (0, 0, 8, 8), (1, 8, 8, 8)}
    assert merged_squares(squares) == squares
