"""The light-space grid of map lists: exact octahedral mapping, conservative cell lists."""

import numpy as np

from game import transforms
from game.gpu.blocks import GRID_NONE, GRID_OCTAHEDRAL, GRID_ORTHO
from game.shadows import map_grid
from game.shadows.fit import fit_directional, fit_perspective


def cell_of(coord, grid):
    rect = grid.rect
    f = (coord - rect[:2]) / (rect[2:] - rect[:2])
    cell = np.minimum((f * grid.size).astype(int), grid.size - 1)
    return cell[..., 1] * grid.size + cell[..., 0]


def listed(grid, cell):
    return set(grid.data[grid.data[cell]:grid.data[cell + 1]].tolist())


def test_octahedral_round_trip():
    rng = np.random.default_rng(1)
    d = rng.normal(size=(2000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    assert np.allclose(map_grid.octahedral_decode(map_grid.octahedral_encode(d)), d, atol=1e-12)


def test_few_maps_use_no_grid_and_many_use_one():
    rot = transforms.light_rotation(np.array([0.0, -1.0, 0.0]))
    fits = [fit_directional(np.array([[x, 0, 0], [x + 1, 1, 1]], float), rot, 64)
            for x in range(20)]
    assert map_grid.build(fits[:map_grid.LOOP_MAX_MAPS], "directional", None).mode == GRID_NONE
    assert map_grid.build(fits, "directional", None).mode == GRID_ORTHO
    assert map_grid.build(fits[:3], "directional", None, use="on").mode == GRID_ORTHO


def test_ortho_grid_lists_every_map_that_holds_a_point():
    rng = np.random.default_rng(2)
    rot = transforms.light_rotation(np.array([-0.4, -1.0, -0.3]) / np.linalg.norm([-0.4, -1, -0.3]))
    fits = []
    for _ in range(40):
        c = rng.uniform(-20, 20, 3)
        fits.append(fit_directional(c + rng.uniform(-2, 2, (8, 3)), rot, 128))
    grid = map_grid.build_ortho(fits)
    points = rng.uniform(-25, 25, (5000, 3))
    xy = points @ rot[:2].T
    cells = cell_of(xy, grid)
    inside_grid = np.all((xy >= grid.rect[:2]) & (xy <= grid.rect[2:]), axis=1)
    for p, cell, inside in zip(points, cells, inside_grid, strict=True):
        holders = set()
        for j, fit in enumerate(fits):
            clip = fit.view_proj @ [*p, 1.0]
            if np.all(np.abs(clip[:2]) <= 1):
                holders.add(j)
        if holders:
            assert inside
            assert holders <= listed(grid, cell)


def test_octahedral_grid_lists_every_map_that_holds_a_point():
    rng = np.random.default_rng(3)
    eye = np.array([0.0, 6.0, 0.0])
    fits = []
    for _ in range(30):
        c = rng.uniform(-15, 15, 3) * [1, 0.3, 1]
        fit = fit_perspective(c + rng.uniform(-1.5, 1.5, (12, 3)), eye, 128)
        if fit is not None:
            fits.append(fit)
    grid = map_grid.build_octahedral(fits, eye)
    assert grid.mode == GRID_OCTAHEDRAL
    points = eye + rng.normal(size=(6000, 3)) * [15, 8, 15]
    coords = map_grid.octahedral_encode(points - eye)
    cells = cell_of(coords, grid)
    missed = 0
    for p, cell in zip(points, cells, strict=True):
        for j, fit in enumerate(fits):
            clip = fit.view_proj @ [*p, 1.0]
            if clip[3] > 0 and np.all(np.abs(clip[:2] / clip[3]) <= 1):
                missed += j not in listed(grid, cell)
    assert missed == 0
    # And the lists are short: the grid is useful, not a list of everything.
    assert grid.mean_list < 0.5 * len(fits)
