"""The soft-shadow tracer's acceleration structures: grids of triangle lists, one or two levels.

Every triangle is listed in every leaf cell its surface touches (conservative triangle-box
binning, game/soft/binning.py).

Two structures (:data:`STRUCTURES`) share one layout. ``uniform`` is one grid whose cells are the
leaves. ``two-level`` is a coarser top grid whose dense cells each hold their own uniform
sub-grid, sized by the triangles in that cell (Kalojanov, Billeter and Slusallek, "Two-Level
Grids for Ray Tracing on GPUs", 2011): a level whose triangles crowd into a few places gets small
cells there and large ones elsewhere.

The structure covers the floors, the statics and every place a character can walk to, so it is
fixed for a scene: the statics' lists are built once and cached, the characters' lists are
rebuilt every frame from their posed triangles into the same leaves. The GPU reads two lists per
leaf (static, dynamic), each as a (start, count) pair: the statics' from
:meth:`Structure.gpu_array`, the characters' from :class:`SparseLists`, which names only the
few leaves the characters touch, so that a frame's work follows the characters' triangles and
not the millions of leaves of a large level.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from game.scene import Scene
from game.scene.geometry import PackedGeometry
from game.soft.binning import (
    BIN_PAD_CELLS,
    CELLS_PER_TRIANGLE,
    CellLists,
    GridSpec,
    cell_pairs,
    cell_range,
    csr_lists,
    expand_ranges,
    grid_spec,
    leaf_order,
    linear_index,
    overlaps,
)

# two-level: the top grid is the uniform grid (TOP_SHARE of ``cells_per_triangle`` cells per
# triangle); a top cell holding more than SUBDIVIDE_ABOVE static triangles gets a sub-grid of
# about ``cells_per_triangle`` cells per triangle it holds, at most MAX_SUB_CELLS_PER_AXIS per
# axis, and MAX_SUB_LEAVES sub-cells in all (denser grids are made coarser to fit). The
# characters are binned into whatever leaves are where they stand: on the courtyard and the
# monastery a coarser top grid, subdividing for the characters' paths, or sparser sub-grids did
# not pay on llvmpipe, where a DDA step costs about what a ray-triangle test costs
# (docs/design/soft-tracer.md).
TOP_SHARE = 1.0
SUBDIVIDE_ABOVE = 16
MAX_SUB_CELLS_PER_AXIS = 32
MAX_SUB_LEAVES = 1 << 22
SUB_DIMS_BITS = 6  # a sub-grid's cells per axis, packed in its top cell's entry
assert MAX_SUB_CELLS_PER_AXIS < 1 << SUB_DIMS_BITS

# The one list of structure names: the tracer's settings, the sweep and the docs read it.
STRUCTURES: dict[str, str] = {
    "uniform": "one uniform grid; its cells are the leaves",
    "two-level": "a coarse uniform grid whose dense cells hold their own uniform sub-grid",
}
DEFAULT_STRUCTURE = "two-level"


@dataclass
class SparseLists:
    """Triangle lists of only the leaves that hold any: leaf ``leaves[i]`` lists
    ``ids[starts[i]:starts[i] + counts[i]]``."""

    leaves: np.ndarray  # (L,) int64, ascending
    counts: np.ndarray  # (L,) int64
    ids: np.ndarray     # (pairs,) int32, leaf by leaf

    @property
    def starts(self) -> np.ndarray:
        return np.cumsum(self.counts) - self.counts



@dataclass
class Structure:
    """Where the leaves are: the top grid, and for each subdivided top cell its sub-grid.

    Leaf ids: top cell ``t`` is leaf ``t`` unless it is subdivided (``sub_of[t] >= 0``); the
    cells of sub-grid ``g`` are leaves ``sub_first[g] + x + dx (y + dy z)``.
    """

    kind: str
    spec: GridSpec            # the top grid
    sub_of: np.ndarray        # (T,) int64: -1, or the top cell's sub-grid
    sub_dims: np.ndarray      # (S, 3) int64: cells per axis of each sub-grid
    sub_first: np.ndarray     # (S,) int64: leaf id of each sub-grid's first cell

    @property
    def n_subgrids(self) -> int:
        return len(self.sub_dims)

    @property
    def n_leaves(self) -> int:
        return self.spec.n_cells + int(np.prod(self.sub_dims, axis=1).sum())

    def leaf_pairs(self, tris: np.ndarray, top_pairs: tuple | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
        """Every (leaf, triangle) pair whose padded leaf cell the triangle touches;
        ``top_pairs`` are the triangles' top-cell pairs if they are known already."""
        spec = self.spec
        cells, ids = top_pairs if top_pairs is not None else cell_pairs(spec, tris)
        g = self.sub_of[cells] if len(cells) else np.zeros(0, np.int64)
        direct = g < 0
        leaves, out_ids = [cells[direct]], [ids[direct]]
        if not direct.all():
            top, tri, g = cells[~direct], ids[~direct], g[~direct]
            d = spec.dims
            top_xyz = np.stack([top % d[0], (top // d[0]) % d[1], top // (d[0] * d[1])], axis=1)
            box_lo = spec.origin + top_xyz * spec.cell
            dims = self.sub_dims[g]
            cell = spec.cell / dims
            t = tris[tri]
            lo, hi, one = cell_range(t, box_lo, cell, dims)
            leaves.append(self.sub_first[g[one]] + linear_index(lo[one], dims[one]))
            out_ids.append(tri[one])
            many = np.nonzero(~one)[0]
            for index, coords in expand_ranges(lo[many], hi[many]):
                index = many[index]
                centre = box_lo[index] + (coords + 0.5) * cell[index]
                keep = overlaps(t[index] - centre[:, None, :],
                                 cell[index] * (0.5 + BIN_PAD_CELLS))
                index, coords = index[keep], coords[keep]
                leaves.append(self.sub_first[g[index]] + linear_index(coords, dims[index]))
                out_ids.append(tri[index])
        return np.concatenate(leaves), np.concatenate(out_ids)

    def lists(self, tris: np.ndarray, first_id: int = 0,
              top_pairs: tuple | None = None) -> CellLists:
        """The leaf lists of triangles (F, 3, 3); ids start at ``first_id``."""
        leaves, ids = self.leaf_pairs(np.asarray(tris, np.float64), top_pairs)
        return csr_lists(leaves, ids, self.n_leaves, first_id)

    def sparse_lists(self, tris: np.ndarray, first_id: int = 0) -> SparseLists:
        """The lists of the leaves that triangles (F, 3, 3) touch; ids start at ``first_id``."""
        leaves, ids = self.leaf_pairs(np.asarray(tris, np.float64))
        order = leaf_order(leaves, ids)
        touched, counts = np.unique(leaves[order], return_counts=True)
        return SparseLists(touched, counts, (ids[order] + first_id).astype(np.int32))

    def gpu_array(self, lists: CellLists) -> np.ndarray:
        """The static int32 array the shader reads: a (start, count) pair per leaf, then the
        triangle ids (a start is an absolute position in this array).

        A subdivided top cell holds its sub-grid instead: (first leaf, -1 - packed dims), the
        cells per axis packed in SUB_DIMS_BITS bits each, so reaching a sub-grid costs the
        traversal no read beyond the pair it reads for any leaf.
        """
        n = self.n_leaves
        pairs = np.zeros((n, 2), np.int64)
        pairs[:, 0] = lists.offsets[:-1] + 2 * n
        pairs[:, 1] = lists.counts()
        top = np.nonzero(self.sub_of >= 0)[0]
        g = self.sub_of[top]
        d = self.sub_dims[g]
        pairs[top, 0] = self.sub_first[g]
        pairs[top, 1] = -1 - (d[:, 0] | (d[:, 1] << SUB_DIMS_BITS) | (d[:, 2] << 2 * SUB_DIMS_BITS))
        array = np.concatenate([pairs.ravel(), lists.ids])
        if array.size and array.max() > np.iinfo(np.int32).max:
            raise ValueError("the scene's triangle lists do not fit 32-bit indices")
        return array.astype(np.int32)


def uniform_structure(lower: np.ndarray, upper: np.ndarray, n_triangles: int,
                      cells_per_triangle: float) -> Structure:
    spec = grid_spec(lower, upper, n_triangles, cells_per_triangle)
    return Structure("uniform", spec, np.full(spec.n_cells, -1, np.int64),
                     np.zeros((0, 3), np.int64), np.zeros(0, np.int64))


def two_level_structure(lower: np.ndarray, upper: np.ndarray, static_tris: np.ndarray,
                        n_triangles: int, cells_per_triangle: float) -> tuple[Structure, tuple]:
    """The top grid at ``TOP_SHARE`` of the density for ``n_triangles``, and a sub-grid in every
    top cell holding more than SUBDIVIDE_ABOVE static triangles. Returns the structure and the
    statics' top-level pairs (to bin them without redoing it)."""
    top = grid_spec(lower, upper, n_triangles, cells_per_triangle * TOP_SHARE)
    cells, ids = cell_pairs(top, static_tris)
    load = np.bincount(cells, minlength=top.n_cells).astype(np.float64)
    dense = np.nonzero(load > SUBDIVIDE_ABOVE)[0]
    density = cells_per_triangle
    while True:
        side = (float(np.prod(top.cell)) / (density * load[dense])) ** (1.0 / 3.0)
        dims = np.clip(np.ceil(top.cell[None, :] / side[:, None]), 1,
                       MAX_SUB_CELLS_PER_AXIS).astype(np.int64)
        if np.prod(dims, axis=1).sum() <= MAX_SUB_LEAVES:
            break
        density /= 2.0
    split = np.prod(dims, axis=1) > 1
    dense, dims = dense[split], dims[split]
    sub_of = np.full(top.n_cells, -1, np.int64)
    sub_of[dense] = np.arange(len(dense))
    sizes = np.prod(dims, axis=1)
    first = top.n_cells + np.cumsum(sizes) - sizes
    return Structure("two-level", top, sub_of, dims, first), (cells, ids)


def static_triangles(geom: PackedGeometry) -> np.ndarray:
    """Floors and statics, world space, (S, 3, 3) float32, in object order."""
    parts = [geom.positions[geom.triangles[o]] for o in range(geom.first_character)]
    return np.concatenate(parts) if parts else np.zeros((0, 3, 3), np.float32)


def character_triangles(geom: PackedGeometry, models: np.ndarray) -> np.ndarray:
    """Every character's triangles posed by its (4, 4) model matrix, (C, 3, 3) float32."""
    parts = []
    for i in range(geom.n_characters):
        local = geom.positions[geom.triangles[geom.character_object(i)]].astype(np.float64)
        m = models[i]
        parts.append((local @ m[:3, :3].T + m[:3, 3]).astype(np.float32))
    return np.concatenate(parts) if parts else np.zeros((0, 3, 3), np.float32)


def scene_bounds(geom: PackedGeometry, scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """A box around the floors, the statics and everywhere a character can be."""
    boxes = []
    if geom.first_character:
        v = static_triangles(geom).reshape(-1, 3)
        if len(v):
            boxes += [v.min(axis=0), v.max(axis=0)]
    for i, character in enumerate(scene.characters):
        r = float(geom.character_radius[i])
        path = np.asarray(character.path, np.float64)
        boxes += [path.min(axis=0) - r, path.max(axis=0) + r]
    if not boxes:
        raise ValueError("the scene has no geometry to trace against")
    pts = np.stack(boxes)
    return pts.min(axis=0), pts.max(axis=0)


class SceneGrid:
    """The scene's structure: the statics' leaf lists built once, the characters' per frame."""

    def __init__(self, geom: PackedGeometry, scene: Scene,
                 cells_per_triangle: float = CELLS_PER_TRIANGLE,
                 structure: str = DEFAULT_STRUCTURE):
        if structure not in STRUCTURES:
            raise ValueError(f"unknown structure {structure!r}; valid: {', '.join(STRUCTURES)}")
        self.geom = geom
        self.cells_per_triangle = cells_per_triangle
        self.kind = structure
        lower, upper = scene_bounds(geom, scene)
        start = time.perf_counter()
        self.static_tris = static_triangles(geom)
        self.n_character_tris = sum(len(geom.triangles[geom.character_object(i)])
                                    for i in range(geom.n_characters))
        tris = self.static_tris.astype(np.float64)
        pairs = None
        if structure == "uniform":
            self.structure = uniform_structure(lower, upper,
                                               len(tris) + self.n_character_tris,
                                               cells_per_triangle)
        else:
            self.structure, pairs = two_level_structure(lower, upper, tris,
                                                        len(tris) + self.n_character_tris,
                                                        cells_per_triangle)
        self.static = self.structure.lists(tris, top_pairs=pairs)
        self.static_ms = (time.perf_counter() - start) * 1e3

    @property
    def spec(self) -> GridSpec:
        """The top grid (for ``uniform``, the only one)."""
        return self.structure.spec

    @property
    def n_static(self) -> int:
        return len(self.static_tris)

    def characters(self, models: np.ndarray) -> tuple[np.ndarray, SparseLists, float]:
        """Posed character triangles, their leaf lists (ids after the statics') and build ms."""
        start = time.perf_counter()
        tris = character_triangles(self.geom, models)
        lists = self.structure.sparse_lists(tris, first_id=self.n_static)
        return tris, lists, (time.perf_counter() - start) * 1e3

    def describe(self) -> dict:
        """What the stats report of the structure."""
        s = self.structure
        counts = self.static.counts()
        full = counts[counts > 0]
        return {"structure": self.kind, "dims": [int(x) for x in s.spec.dims],
                "cells": s.spec.n_cells, "cell_m": [round(float(x), 5) for x in s.spec.cell],
                "subgrids": s.n_subgrids, "leaves": s.n_leaves,
                "static_triangles": self.n_static,
                "character_triangles": self.n_character_tris,
                "static_entries": int(counts.sum()),
                "mean_per_nonempty_cell": round(float(full.mean()), 3) if len(full) else 0.0,
                "max_per_cell": int(counts.max()) if len(counts) else 0}
