"""Procedural towns (game/scene/generate.py) and the town scene files; no GL needed."""

from __future__ import annotations

import numpy as np
import pytest

from game.errors import SceneError
from game.scene import load_scene
from game.scene.generate import TownParams, generate_town, town_params
from tests.helpers import ASSETS

SMALL = {"seed": 3, "blocks": 2, "block_size": 30.0, "street_width": 8.0,
         "buildings_per_block": 3, "trees_per_block": 3, "detail": 1, "characters": 6}


def test_params_defaults_and_types():
    assert town_params({}) == TownParams()
    params = town_params({"block_size": 25, "seed": 9})
    assert params.block_size == 25.0 and isinstance(params.block_size, float)
    assert params.seed == 9


@pytest.mark.parametrize(("table", "message"), [
    ({"blokcs": 2}, "generate.blokcs: unknown key, did you mean 'blocks'?"),
    ({"colour": 2}, "generate.colour: unknown key (expected one of: seed,"),
    ({"detail": 1.5}, "generate.detail: must be an integer, got 1.5"),
    ({"blocks": True}, "generate.blocks: must be a number"),
    ({"blocks": "4"}, "generate.blocks: must be a number"),
    ({"blocks": 0}, "generate.blocks: must be between 1 and 64, got 0"),
    ({"block_size": float("nan")}, "generate.block_size: must be finite"),
    ({"street_width": 1.0}, "generate.street_width: must be between 4"),
    ({"buildings_per_block": 100, "block_size": 20.0}, "generate.buildings_per_block: too many"),
])
def test_params_are_validated(table, message):
    with pytest.raises(SceneError) as info:
        town_params(table)
    assert str(info.value).startswith(message), str(info.value)


def test_same_seed_same_town_other_seed_other_town():
    a, b = generate_town(SMALL), generate_town(dict(SMALL))
    c = generate_town({**SMALL, "seed": 4})
    assert len(a.statics) == len(b.statics) == 2 * 2 * 6
    for ma, mb in zip(a.statics, b.statics, strict=True):
        assert np.array_equal(ma.vertices, mb.vertices) and np.array_equal(ma.faces, mb.faces)
    for wa, wb in zip(a.walkers, b.walkers, strict=True):
        assert np.array_equal(wa.path, wb.path) and (wa.speed, wa.phase) == (wb.speed, wb.phase)
    assert not all(np.array_equal(ma.vertices, mc.vertices)
                   for ma, mc in zip(a.statics, c.statics, strict=True))


def test_detail_raises_the_triangle_count():
    counts = [generate_town({**SMALL, "detail": d}).static_triangles() for d in (0, 1, 2, 3)]
    assert counts == sorted(counts) and counts[3] > 2 * counts[1]


def _block_squares(params: TownParams) -> np.ndarray:
    """(n*n, 2, 2) x-z corners (lo, hi) of every block."""
    pitch = params.block_size + params.street_width
    centres = (np.arange(params.blocks) - 0.5 * (params.blocks - 1)) * pitch
    cx, cz = (a.ravel() for a in np.meshgrid(centres, centres))
    half = 0.5 * params.block_size
    return np.stack([np.column_stack([cx - half, cz - half]),
                     np.column_stack([cx + half, cz + half])], axis=1)


def test_layout_statics_stand_in_blocks_and_walkers_walk_in_streets():
    params = town_params({**SMALL, "blocks": 3, "characters": 20})
    town = generate_town(params)
    squares = _block_squares(params)
    (floor,) = town.floors
    assert np.isclose(floor.bounds[1][1], 0.0)
    for mesh in town.statics:
        lo, hi = mesh.bounds
        assert abs(lo[1]) < 1e-9, "every static stands on the floor"
        inside = [np.all(lo[[0, 2]] >= sq[0]) and np.all(hi[[0, 2]] <= sq[1]) for sq in squares]
        assert sum(inside) == 1, "every static lies inside one block"
    for walker in town.walkers:
        lo_w, hi_w = walker.mesh.bounds
        radius = 0.5 * (hi_w[0] - lo_w[0])
        assert np.allclose(lo_w + hi_w, 0.0) and np.isclose(hi_w[1] - lo_w[1], 1.8)
        assert np.allclose(walker.path[:, 1], hi_w[1])  # feet on the floor
        for seg in range(len(walker.path)):
            a, b = walker.path[seg], walker.path[(seg + 1) % len(walker.path)]
            points = a[[0, 2]] + np.linspace(0.0, 1.0, 50)[:, None] * (b - a)[[0, 2]]
            for lo, hi in squares:
                gap = np.linalg.norm(np.maximum(0.0, np.maximum(lo - points, points - hi)),
                                     axis=1)
                assert gap.min() > radius, "walkers stay in the streets"
            assert np.all(np.abs(points) < floor.bounds[1][[0, 2]] - radius)


@pytest.mark.parametrize(("file", "low", "high", "characters"), [
    ("town_small.toml", 30_000, 80_000, 8),
    ("town_1m.toml", 1_000_000, 2_000_000, 16),
    ("town_1m_64.toml", 1_000_000, 2_000_000, 64),
])
def test_town_scene_files(file, low, high, characters):
    scene = load_scene(ASSETS / file)
    triangles = sum(len(body.mesh.faces) for body in scene.statics)
    assert low <= triangles <= high
    assert len(scene.characters) == characters
    assert len(scene.floors) == 1
    names = scene.object_names()
    assert len(names) == len(set(names)) == 1 + len(scene.statics) + characters
    assert names[-1] == f"character_{characters - 1}"
    # The camera looks at the town from outside it, with the far plane beyond its far corner.
    half = scene.floors[0].mesh.bounds[1][0]
    distance = np.linalg.norm(scene.camera.position)
    assert distance > half and scene.camera.far > distance + np.sqrt(2.0) * half
