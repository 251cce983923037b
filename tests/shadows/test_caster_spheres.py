"""A spot or point light's map carries its casters' bounding spheres, and the map grid lists the
map for a cell of directions only where the cone through one of them meets the cell's
(game/shadows/map_grid.py). A caster outside every sphere would lose its shadow there, so each
point of every triangle a map draws must lie inside one of its spheres: light 0's clumps draw
their pieces, the other lights' clumps whole statics (game/shadows/lights.py). A caster whose
sphere holds the light (a lamp beside its post) has spheres of its triangles, split where they
hold it, so that its map is not listed in every direction."""

from __future__ import annotations

import numpy as np
import pytest

from game.render.renderer import View
from game.scene import load_scene
from game.scene.geometry import pack
from game.shadows import map_grid, octahedral
from game.shadows.fit import fit_cube_faces
from game.shadows.light_kinds import kind_of
from game.shadows.lights import LightShadows
from game.shadows.plan import ShadowSettings
from tests.helpers import ASSETS, SCENES

SIZE = (320, 180)
# Points on each triangle, as barycentric weights: corners, edges and inside, 1/4 apart. A
# triangle split in four (game/shadows/method.py) lies in its parts' spheres, not in one.
LATTICE = np.array([(i, j, 4 - i - j) for i in range(5) for j in range(5 - i)], float) / 4
LIGHTS = 4  # the first lights' maps are checked: light 0's and the others' are made apart


def _outside(points: np.ndarray, spheres: np.ndarray) -> np.ndarray:
    """Per point (n, 3), whether it lies outside every sphere, by one matrix product."""
    centres, radii = spheres[:, :3], spheres[:, 3]
    squared = ((points ** 2).sum(axis=1)[:, None] + (centres ** 2).sum(axis=1)[None]
               - 2 * points @ centres.T)
    # The drawn vertices are float32, the spheres float64, and the expansion rounds: a few
    # micrometres at the scenes' scale.
    return (squared > (radii[None] + 1e-4) ** 2).all(axis=1)


def _drawn(plan, record, geom) -> list[np.ndarray]:
    """The vertices of each piece or whole static drawn into ``record``."""
    if record.pieces is not None:
        return [geom.static_corners(*plan.static_pieces[p]) for p in record.pieces]
    return [geom.static_corners(o - geom.n_floors) for o in record.objects]


@pytest.mark.parametrize("path", [ASSETS / "night_town.toml", SCENES / "point.toml",
                                  SCENES / "lamps.toml", SCENES / "point_among.toml"])
def test_each_piece_a_map_draws_lies_in_one_of_its_spheres(path):
    scene = load_scene(path)
    geom = pack(scene)
    shadows = LightShadows(geom, scene.lights, ShadowSettings(), 2048, 4096)
    models = (np.stack([c.model_matrix(0.5) for c in scene.characters]) if scene.characters
              else np.zeros((0, 4, 4)))
    plan, spans = shadows.plan(models, View.from_camera(scene.camera, SIZE))
    checked = holding = 0
    for k, span in enumerate(spans[:LIGHTS]):
        for record in plan.maps[span.first_map:span.first_map + span.map_count]:
            if record.spheres is None:
                continue
            centres, radii = record.spheres[:, :3], record.spheres[:, 3]
            for corners in _drawn(plan, record, geom):
                points = np.einsum("pc,tcj->tpj", LATTICE, corners.reshape(-1, 3, 3))
                assert not _outside(points.reshape(-1, 3), record.spheres).any(), (k, record.name)
            checked += 1
            eye = kind_of(scene.lights[k]).eye(scene.lights[k])
            held = np.linalg.norm(centres - eye, axis=1) <= radii
            holding += bool(held.any())
    assert checked  # every scene here has a spot or point light with clumps
    assert holding <= checked // 4  # few maps are listed in every direction


def test_spheres_keep_a_cube_face_to_the_directions_of_its_casters():
    """A light among a ring of small casters: each face of the cube around it reaches the
    directions of the casters in front of it, not its whole quarter of the sphere. Every
    direction that can find a caster (within its cone grown by the reach) still lists it."""
    rng = np.random.default_rng(4)
    eye = np.array([0.0, 5.0, 0.0])
    angles = np.linspace(0.0, 2 * np.pi, 8, endpoint=False)
    centres = np.stack([3 * np.cos(angles), np.full(8, 1.0), 3 * np.sin(angles)], axis=1)
    spheres = np.concatenate([centres, np.full((8, 1), 0.5)], axis=1)
    points = np.concatenate([c + rng.uniform(-0.35, 0.35, (20, 3)) for c in centres])
    fits = fit_cube_faces(points, eye, 256)
    reach = 4.0
    plain = map_grid.GridBuilder().build(fits, eye, "on")
    grid = map_grid.GridBuilder().build(fits, eye, "on", reach=reach,
                                        spheres=[spheres] * len(fits))
    assert grid.mean_list < 0.5 * plain.mean_list
    dirs = rng.normal(size=(20000, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    to = centres - eye
    dist = np.linalg.norm(to, axis=1)
    apart = np.arccos(np.clip(dirs @ (to / dist[:, None]).T, -1, 1))
    cells = _cell(octahedral.octahedral_encode(dirs), grid)
    for j, fit in enumerate(fits):
        clip = np.concatenate([eye + dirs, np.ones((len(dirs), 1))], axis=1) @ fit.view_proj.T
        held = (clip[:, 3] > 0) & np.all(np.abs(clip[:, :2]) <= clip[:, 3:4], axis=1)
        near = (apart <= np.arcsin(0.5 / dist) + reach * fit.texel).any(axis=1)
        for cell in np.unique(cells[held & near]):
            assert j in grid.data[grid.data[cell]:grid.data[cell + 1]], (j, cell)


def _cell(coord: np.ndarray, grid) -> np.ndarray:
    f = (coord - grid.rect[:2]) / (grid.rect[2:] - grid.rect[:2])
    cell = np.clip(np.floor(f * grid.size).astype(int), 0, grid.size - 1)
    return cell[:, 1] * grid.size + cell[:, 0]
