"""The light-space grid of map lists: exact octahedral mapping, conservative cell lists."""

import numpy as np

from game import transforms
from game.gpu.blocks import GRID_NONE, GRID_OCTAHEDRAL, GRID_ORTHO, GRID_TILES
from game.shadows import map_grid, octahedral
from game.shadows.fit import fit_directional, fit_perspective


def cell_of(coord, grid):
    """The cell the shader reads: outside the rectangle, the nearest edge cell."""
    rect = grid.rect
    f = (coord - rect[:2]) / (rect[2:] - rect[:2])
    cell = np.clip(np.floor(f * grid.size).astype(int), 0, grid.size - 1)
    return cell[..., 1] * grid.size + cell[..., 0]


def holders_of(p, fits):
    """The orthographic maps whose rectangle holds world point p."""
    return {j for j, fit in enumerate(fits) if np.all(np.abs((fit.view_proj @ [*p, 1.0])[:2]) <= 1)}


def listed(grid, cell):
    return set(grid.data[grid.data[cell]:grid.data[cell + 1]].tolist())


def test_octahedral_round_trip():
    rng = np.random.default_rng(1)
    d = rng.normal(size=(2000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    assert np.allclose(octahedral.octahedral_decode(octahedral.octahedral_encode(d)), d, atol=1e-12)


def test_few_maps_use_no_grid_and_many_use_one():
    rot = transforms.light_rotation(np.array([0.0, -1.0, 0.0]))
    fits = [fit_directional(np.array([[x, 0, 0], [x + 1, 1, 1]], float), rot, 64)
            for x in range(20)]
    assert map_grid.build(fits[:map_grid.LOOP_MAX_MAPS], None).mode == GRID_NONE
    assert map_grid.build(fits, None).mode == GRID_ORTHO
    assert map_grid.build(fits[:3], None, use="on").mode == GRID_ORTHO
    # Maps wider than a float32 can span (a density target near zero): the loop, not a grid.
    huge = [fit_directional(np.array([[x * 1e300, 0, 0], [(x + 1) * 1e300, 1, 1]], float),
                            rot, 64) for x in range(2)]
    assert map_grid.build(huge, None, use="on").mode == GRID_NONE


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
        holders = holders_of(p, fits)
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
    coords = octahedral.octahedral_encode(points - eye)
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


def test_a_cell_that_does_not_list_a_map_holds_none_of_its_directions():
    """A map is projected only into the cells whose cones meet the cone round its frustum, then
    tested there: in every cell that does not list it, directions sampled across the cell miss
    the frustum. Narrow maps (a walker's far from the light) and wide ones both, and the narrow
    ones leave most cells out."""
    rng = np.random.default_rng(7)
    eye = np.array([1.0, 5.0, -2.0])
    size = 16
    fits = [fit_perspective(c + rng.uniform(-r, r, (12, 3)), eye, 128)
            for c, r in [(rng.uniform(-20, 20, 3), rng.choice([0.3, 2.0, 8.0]))
                         for _ in range(24)]]
    fits = [f for f in fits if f is not None]
    edges = np.linspace(-1.0, 1.0, size + 1)
    t = rng.uniform(size=(200, 2))
    unlisted = 0
    for fit in fits:
        cells, _ = octahedral.map_hits([fit], eye, size=size)
        for cell in set(range(size * size)) - set(cells.tolist()):
            lo = np.array([edges[cell % size], edges[cell // size]])
            dirs = octahedral.octahedral_decode(lo + t * (edges[1] - edges[0]))
            clip = np.c_[eye + dirs, np.ones(len(dirs))] @ fit.view_proj.T
            inside = (clip[:, 3] > 0) & np.all(np.abs(clip[:, :2]) <= clip[:, 3:], axis=1)
            assert not inside.any(), (cell, fit.rect)
            unlisted += 1
    assert unlisted > len(fits) * size * size / 2


def test_moving_maps_outside_the_steady_ones_are_found_and_steady_cells_are_kept():
    """The grid lies over the steady maps, grown by whole cells over maps that move far
    outside them: those are listed for every point they hold, in cells of their own (not an
    edge cell that gathers every map beyond it), frame after frame, and the kept cells equal a
    fresh build's."""
    rng = np.random.default_rng(4)
    rot = transforms.light_rotation(np.array([0.3, -1.0, 0.2]) / np.linalg.norm([0.3, -1, 0.2]))

    def fits_at(centres, spread):
        return [fit_directional(c + rng.uniform(-spread, spread, (8, 3)), rot, 128)
                for c in centres]

    steady = fits_at(rng.uniform(-10, 10, (30, 3)), 2.0)
    builder = map_grid.GridBuilder()
    for frame in range(3):
        centres = rng.uniform(-40, 40, (6, 3))
        moving = fits_at(centres, 1.0)
        fits = steady + moving
        grid = builder.build(fits, None, steady=len(steady))
        fresh = map_grid.GridBuilder().build(fits, None, steady=len(steady))
        assert np.array_equal(grid.data, fresh.data) and np.array_equal(grid.rect, fresh.rect)
        points = np.concatenate([rng.uniform(-45, 45, (1500, 3)),
                                 np.repeat(centres, 200, axis=0) + rng.normal(0, 2, (1200, 3))])
        steady_rect = map_grid.build(steady, None).rect
        xy = points @ rot[:2].T
        beyond = np.any((xy < steady_rect[:2]) | (xy > steady_rect[2:]), axis=1)
        lengths = []
        for p, cell, out in zip(points, cell_of(xy, grid), beyond, strict=True):
            holders = holders_of(p, fits)
            assert holders <= listed(grid, cell), frame
            if out and holders:
                lengths.append(len(listed(grid, cell)))
        assert len(lengths) > 50  # points held by moving maps beyond the steady rectangle
        assert np.mean(lengths) < 1.1, frame  # each finds its own map, about alone
    # A steady map that changes is placed again.
    steady[0] = fits_at([[30.0, 0.0, 30.0]], 1.0)[0]
    grid = builder.build(steady + moving, None, steady=len(steady))
    fresh = map_grid.GridBuilder().build(steady + moving, None, steady=len(steady))
    assert np.array_equal(grid.data, fresh.data)


def test_a_partitions_grid_reaches_over_walkers_beyond_its_tiles():
    """Tiles of 10 m on a 2 x 2 lattice and walkers' maps up to 25 m beyond it: the lattice
    grows by whole tiles over them, so each walker's map has cells of its own, and every tile
    keeps exactly its cells."""
    rng = np.random.default_rng(5)
    rot = transforms.light_rotation(np.array([0.0, -1.0, 0.0]))
    tiles = [np.array([x, y, x + 10.0, y + 10.0]) for x in (0.0, 10.0) for y in (0.0, 10.0)]
    # A tile's map: its square in light space (x, -z as the rotation for a light straight down
    # has it); the test reads only its tile.
    steady = [fit_directional(np.array([[t[0], 0, -t[1]], [t[2], 1, -t[3]]]), rot, 128)
              for t in tiles]
    walkers = rng.uniform(-25, 45, (12, 2))
    moving = [fit_directional(np.array([[x - 0.5, 0, -y + 0.5], [x + 0.5, 2, -y - 0.5]]), rot, 64)
              for x, y in walkers]
    grid = map_grid.GridBuilder().build(steady + moving, None, tiles=tiles + [None] * 12,
                                        steady=4)
    assert grid.mode == GRID_TILES
    rects = np.array([f.rect for f in moving])
    assert np.all(grid.rect[:2] <= rects[:, :2].min(axis=0))
    assert np.all(grid.rect[2:] >= rects[:, 2:].max(axis=0))
    span = (grid.rect[2:] - grid.rect[:2]) / 10.0  # whole tiles per side
    assert np.allclose(span, np.round(span)) and np.allclose(grid.rect[:2] % 10.0, 0.0)
    for j, fit in enumerate(moving):
        centre = (fit.rect[:2] + fit.rect[2:]) / 2
        cell = cell_of(centre, grid)
        found = listed(grid, int(cell))
        assert 4 + j in found and len(found - {-1}) <= 3, (j, found)


def test_a_tile_lists_its_map_only_where_its_casters_covers_reach():
    """A tile's map holds no texel outside its casters' covers, so its cells there list no
    static map (nothing at all, without walkers), and every point of a cover grown by the reach
    still finds its tile's map; a tile without covers keeps its map in all its cells."""
    rng = np.random.default_rng(9)
    rot = transforms.light_rotation(np.array([0.0, -1.0, 0.0]))
    tiles = [np.array([x, y, x + 10.0, y + 10.0]) for x in (0.0, 10.0) for y in (0.0, 10.0)]
    steady = [fit_directional(np.array([[t[0], 0, -t[1]], [t[2], 1, -t[3]]]), rot, 128)
              for t in tiles]
    covers = []
    for t in tiles[:3]:
        lo = t[:2] + rng.uniform(0.5, 4.0, (3, 2))
        covers.append(np.concatenate([lo, lo + rng.uniform(0.5, 3.0, (3, 2))], axis=1))
    covers.append(None)
    reach = 2.0
    grid = map_grid.GridBuilder().build(steady, None, covers=covers, reach=reach,
                                        tiles=tiles)
    assert grid.mode == GRID_TILES
    for k, (fit, cover) in enumerate(zip(steady, covers, strict=True)):
        if cover is None:
            points = rng.uniform(tiles[k][:2], tiles[k][2:], (200, 2))
        else:
            grown = cover + reach * fit.texel * np.array([-1.0, -1.0, 1.0, 1.0])
            box = grown[rng.integers(0, len(grown), 400)]
            points = rng.uniform(box[:, :2], box[:, 2:])
            points = points[np.all((points >= tiles[k][:2]) & (points < tiles[k][2:]), axis=1)]
        for p in points:
            assert k in listed(grid, int(cell_of(p, grid))), (k, p)
    empty = [c for c in range(grid.size * grid.size) if not listed(grid, c)]
    assert len(empty) > grid.size * grid.size / 4   # most of the covered tiles' cells
