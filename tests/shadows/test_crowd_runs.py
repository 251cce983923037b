"""Walkers around a lamp share maps in runs of neighbours along a Hilbert curve
(game/shadows/crowd_runs.py); numpy, no GL."""

from __future__ import annotations

import numpy as np

from game.shadows.crowd_runs import CURVE_BITS, hilbert_order, runs


def _xy2d(side: int, x: int, y: int) -> int:
    """The textbook distance along the Hilbert curve of a ``side`` x ``side`` grid."""
    d, s = 0, side // 2
    while s > 0:
        rx, ry = int(x & s > 0), int(y & s > 0)
        d += s * s * ((3 * rx) ^ ry)
        if ry == 0:
            if rx == 1:
                x, y = side - 1 - x, side - 1 - y
            x, y = y, x
        s //= 2
    return d


def test_the_order_is_the_textbook_curve_and_steps_one_cell_at_a_time():
    side = 1 << CURVE_BITS
    rng = np.random.default_rng(3)
    points = np.concatenate([[[0, 0], [side - 1, side - 1]],
                             rng.integers(0, side, (500, 2))]).astype(float)
    got = hilbert_order(points)
    assert got.tolist() == [_xy2d(side, int(x), int(y)) for x, y in points]
    # Every cell of a corner 8 x 8 block, once: consecutive cells along the curve touch.
    block = np.array([[x, y] for x in range(8) for y in range(8)] + [[side - 1, side - 1]],
                     float)
    order = np.argsort(hilbert_order(block)[:-1])
    steps = np.abs(np.diff(block[order], axis=0)).sum(axis=1)
    assert (steps == 1).all()


def test_walkers_in_a_ring_share_maps_with_their_neighbours_and_every_one_has_one():
    angles = np.random.default_rng(5).permutation(np.linspace(0, 2 * np.pi, 40, endpoint=False))
    directions = np.stack([np.cos(angles), np.sin(angles)], axis=1)
    maps = runs([256] * 40, lambda: directions, 512, max_maps=10)
    assert len(maps) == 10
    assert sorted(k for m in maps for k in m.members) == list(range(40))
    for m in maps:
        assert len(m.members) == 4 and m.resolution == 512
        a = np.sort(angles[m.members])
        gaps = np.diff(np.concatenate([a, [a[0] + 2 * np.pi]]))
        # The arc that holds them (the circle less its widest gap) is narrow enough for one
        # frustum; dealt round robin, four walkers would lie a quarter turn apart.
        assert 2 * np.pi - gaps.max() <= np.pi / 2


def test_walkers_the_records_hold_keep_a_map_each_at_their_own_size():
    def unasked():
        raise AssertionError("the directions are not needed")

    maps = runs([64, 128, 256], unasked, 512, max_maps=5)
    assert [(m.members, m.resolution) for m in maps] == [([0], 64), ([1], 128), ([2], 256)]
