"""Conservative triangle-box binning into a uniform grid (no GL)."""

import numpy as np
import pytest

from game.soft import binning


def _cells_of_points(spec, pts):
    c = np.floor((pts - spec.origin) / spec.cell).astype(int)
    c = np.clip(c, 0, spec.dims - 1)
    return c[:, 0] + spec.dims[0] * (c[:, 1] + spec.dims[1] * c[:, 2])


def _random_triangles(rng, n, scale):
    centres = rng.uniform(-10, 10, (n, 1, 3))
    return centres + rng.normal(0, scale, (n, 3, 3))


@pytest.mark.parametrize("scale", [0.05, 1.0, 6.0])
def test_every_point_of_a_triangle_lies_in_a_listed_cell(scale):
    rng = np.random.default_rng(1)
    tris = _random_triangles(rng, 300, scale)
    spec = binning.grid_spec(tris.reshape(-1, 3).min(0), tris.reshape(-1, 3).max(0), 300)
    lists = binning.bin_triangles(spec, tris)
    listed = [set() for _ in tris]
    for cell in range(spec.n_cells):
        for tri in lists.ids[lists.offsets[cell]:lists.offsets[cell + 1]]:
            listed[tri].add(cell)
    w = rng.dirichlet([1, 1, 1], 400)
    # Edges and corners too: the points most likely to fall on a cell boundary.
    w = np.vstack([w, np.eye(3), [[0.5, 0.5, 0], [0, 0.5, 0.5], [0.5, 0, 0.5]]])
    for i, tri in enumerate(tris):
        cells = _cells_of_points(spec, w @ tri)
        assert set(cells.tolist()) <= listed[i]


def test_binning_is_tighter_than_the_bounding_box():
    # A long diagonal sliver spans many cells of its box but touches few of them.
    tri = np.array([[[0.0, 0.0, 0.0], [10.0, 10.0, 10.0], [10.1, 10.0, 10.0]]])
    spec = binning.grid_spec(np.zeros(3), np.full(3, 10.1), 500)
    lists = binning.bin_triangles(spec, tri)
    box_cells = int(np.prod(spec.dims))
    assert 0 < len(lists.ids) < box_cells / 10
