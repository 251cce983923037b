"""The tracer's acceleration structures, uniform and two-level, and the scene's grid (no GL)."""


import numpy as np
import pytest

from game.scene import geometry, load_scene
from game.soft import grid as trace_grid
from game.soft.binning import cell_pairs
from tests.helpers import SCENES


def _random_triangles(rng, n, scale):
    centres = rng.uniform(-10, 10, (n, 1, 3))
    return centres + rng.normal(0, scale, (n, 3, 3))


def test_scene_grid_covers_characters_everywhere_on_their_path():
    scene = load_scene(SCENES / "tiny.toml")
    geom = geometry.pack(scene)
    grid = trace_grid.SceneGrid(geom, scene)
    assert grid.n_static == sum(len(geom.triangles[o]) for o in range(geom.first_character))
    for t in np.linspace(0.0, 20.0, 9):
        models = np.stack([c.model_matrix(t) for c in scene.characters])
        tris, lists, ms = grid.characters(models)
        v = tris.reshape(-1, 3)
        assert (v >= grid.spec.origin - 1e-6).all() and (v <= grid.spec.upper + 1e-6).all()
        assert lists.ids.min() >= grid.n_static
        assert ms >= 0.0


def _leaf_of_points(structure, pts):
    """The leaf holding each point (as the GPU's traversal finds it)."""
    spec = structure.spec
    c = np.clip(np.floor((pts - spec.origin) / spec.cell).astype(int), 0, spec.dims - 1)
    top = c[:, 0] + spec.dims[0] * (c[:, 1] + spec.dims[1] * c[:, 2])
    leaf = top.copy()
    g = structure.sub_of[top]
    for i in np.nonzero(g >= 0)[0]:
        dims = structure.sub_dims[g[i]]
        box = spec.origin + c[i] * spec.cell
        s = np.clip(np.floor((pts[i] - box) / (spec.cell / dims)).astype(int), 0, dims - 1)
        leaf[i] = structure.sub_first[g[i]] + s[0] + dims[0] * (s[1] + dims[1] * s[2])
    return leaf


def _clustered_triangles(rng):
    """A sparse scatter of large triangles and one dense cluster of small ones."""
    sparse = _random_triangles(rng, 60, 1.5)
    dense = rng.uniform(2.0, 3.0, (600, 1, 3)) + rng.normal(0, 0.08, (600, 3, 3))
    return np.concatenate([sparse, dense])


def test_two_level_subdivides_the_dense_cells_and_lists_every_point(monkeypatch):
    rng = np.random.default_rng(4)
    tris = _clustered_triangles(rng)
    lower, upper = tris.reshape(-1, 3).min(0), tris.reshape(-1, 3).max(0)
    structure, _ = trace_grid.two_level_structure(lower, upper, tris, len(tris), 2.0)
    uniform = trace_grid.uniform_structure(lower, upper, len(tris), 2.0)
    assert structure.n_subgrids > 0
    # Only cells holding more than SUBDIVIDE_ABOVE triangles are subdivided.
    counts = np.bincount(cell_pairs(structure.spec, tris)[0],
                         minlength=structure.spec.n_cells)
    subdivided = structure.sub_of >= 0
    assert (counts[subdivided] > trace_grid.SUBDIVIDE_ABOVE).all()
    lists = structure.lists(tris)
    # The dense cluster's leaves hold fewer triangles than the uniform grid's cells there.
    assert lists.counts().max() < uniform.lists(tris).counts().max()
    listed = [set() for _ in tris]
    for leaf in np.nonzero(lists.counts())[0]:
        for tri in lists.ids[lists.offsets[leaf]:lists.offsets[leaf + 1]]:
            listed[tri].add(int(leaf))
    w = rng.dirichlet([1, 1, 1], 200)
    w = np.vstack([w, np.eye(3), [[0.5, 0.5, 0], [0, 0.5, 0.5], [0.5, 0, 0.5]]])
    for i, tri in enumerate(tris):
        assert set(_leaf_of_points(structure, w @ tri).tolist()) <= listed[i]


def test_two_level_stays_within_its_leaf_budget(monkeypatch):
    monkeypatch.setattr(trace_grid, "MAX_SUB_LEAVES", 5000)
    rng = np.random.default_rng(5)
    tris = _clustered_triangles(rng)
    lower, upper = tris.reshape(-1, 3).min(0), tris.reshape(-1, 3).max(0)
    structure, _ = trace_grid.two_level_structure(lower, upper, tris, len(tris), 64.0)
    assert 0 < structure.n_leaves - structure.spec.n_cells <= 5000
    # Still a listing of every triangle: the GPU array's (start, count) pairs cover its ids,
    # and each subdivided top cell holds its sub-grid's first leaf and cells per axis.
    lists = structure.lists(tris)
    array = structure.gpu_array(lists)
    pairs = array[:2 * structure.n_leaves].reshape(-1, 2).astype(np.int64)
    leaf = pairs[:, 1] >= 0
    assert (pairs[leaf, 0] >= 2 * structure.n_leaves).all()
    assert (pairs[leaf, 0] + pairs[leaf, 1] <= len(array)).all()
    assert pairs[leaf, 1].sum() == len(lists.ids) == len(array) - 2 * structure.n_leaves
    top = np.nonzero(structure.sub_of >= 0)[0]
    bits = -1 - pairs[top, 1]
    mask = (1 << trace_grid.SUB_DIMS_BITS) - 1
    dims = np.stack([bits & mask, (bits >> trace_grid.SUB_DIMS_BITS) & mask,
                     bits >> (2 * trace_grid.SUB_DIMS_BITS)], axis=1)
    np.testing.assert_array_equal(dims, structure.sub_dims[structure.sub_of[top]])
    np.testing.assert_array_equal(pairs[top, 0], structure.sub_first[structure.sub_of[top]])


def test_scene_grid_builds_either_structure(tiny):
    geom = geometry.pack(tiny)
    for kind in trace_grid.STRUCTURES:
        grid = trace_grid.SceneGrid(geom, tiny, structure=kind)
        info = grid.describe()
        assert info["structure"] == kind and info["leaves"] >= info["cells"]
        assert info["static_entries"] >= grid.n_static
    with pytest.raises(ValueError):
        trace_grid.SceneGrid(geom, tiny, structure="octree")
