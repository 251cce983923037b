"""The soft-shadow tracer's acceleration structure: a uniform grid of triangle lists.

Every triangle is listed in every cell its surface touches (conservative triangle-box binning:
the separating-axis test of Akenine-Moeller, "Fast 3D triangle-box overlap testing", 2001, with
each cell grown by ``BIN_PAD_CELLS`` so that the float32 3D-DDA on the GPU, which may round a ray
into a neighbouring cell at a boundary, still finds every triangle it can hit).

The grid covers the floors, the statics and every place a character can walk to, so it is fixed
for a scene: the statics' lists are built once and cached, the characters' lists are rebuilt every
frame from their posed triangles. The GPU reads two lists per cell (static, dynamic) in the CSR
layout of :class:`CellLists`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from game.scene import Scene
from game.scene.geometry import PackedGeometry

# Cells per triangle the grid aims for (Wald et al. and PBRT use a few cells per primitive).
CELLS_PER_TRIANGLE = 2.0
MAX_CELLS_PER_AXIS = 512
# Each cell is grown by this share of its size before the triangle-box test, on every side.
BIN_PAD_CELLS = 1e-3
# Triangle-cell pairs tested per numpy batch: bounds the build's memory on the 1 M-triangle town.
PAIRS_PER_BATCH = 4_000_000


@dataclass(frozen=True)
class GridSpec:
    """Where the grid is: its lower corner, the size of a cell and the cells per axis."""

    origin: np.ndarray   # (3,) float64, metres
    cell: np.ndarray     # (3,) float64, metres per cell along each axis
    dims: np.ndarray     # (3,) int64

    @property
    def n_cells(self) -> int:
        return int(np.prod(self.dims))

    @property
    def upper(self) -> np.ndarray:
        return self.origin + self.cell * self.dims

    @property
    def diagonal(self) -> float:
        return float(np.linalg.norm(self.cell * self.dims))


@dataclass
class CellLists:
    """Triangle lists of every cell, in CSR form: ``ids[offsets[c]:offsets[c + 1]]``."""

    offsets: np.ndarray  # (n_cells + 1,) int64
    ids: np.ndarray      # (pairs,) int32, triangle indices

    def gpu_array(self) -> np.ndarray:
        """One int32 array: the offsets (already shifted past themselves), then the ids."""
        n = len(self.offsets)
        return np.concatenate([self.offsets + n, self.ids]).astype(np.int32)

    def counts(self) -> np.ndarray:
        return np.diff(self.offsets)


def grid_spec(lower: np.ndarray, upper: np.ndarray, n_triangles: int,
              cells_per_triangle: float = CELLS_PER_TRIANGLE,
              max_per_axis: int = MAX_CELLS_PER_AXIS) -> GridSpec:
    """Near-cubic cells, about ``cells_per_triangle * n_triangles`` of them over the box."""
    lower = np.asarray(lower, np.float64)
    upper = np.asarray(upper, np.float64)
    extent = upper - lower
    size = float(extent.max())
    if not np.isfinite(size) or size <= 0.0:
        raise ValueError("the scene has no extent to build a grid over")
    # Flat axes still get a slab of some thickness so that the cells have a volume.
    extent = np.maximum(extent, size * 1e-3)
    lower = (lower + upper) / 2 - extent / 2
    target = max(1.0, cells_per_triangle * max(1, n_triangles))
    side = (float(np.prod(extent)) / target) ** (1.0 / 3.0)
    dims = np.clip(np.ceil(extent / side), 1, max_per_axis).astype(np.int64)
    return GridSpec(origin=lower, cell=extent / dims, dims=dims)


def _overlap_pairs(spec: GridSpec, tris: np.ndarray, cells: np.ndarray,
                   index: np.ndarray) -> np.ndarray:
    """Which (triangle, cell) pairs overlap: the separating-axis test, vectorised over pairs."""
    dims = spec.dims
    ix = cells % dims[0]
    iy = (cells // dims[0]) % dims[1]
    iz = cells // (dims[0] * dims[1])
    centre = spec.origin + (np.stack([ix, iy, iz], axis=1) + 0.5) * spec.cell
    half = spec.cell * (0.5 + BIN_PAD_CELLS)
    v = tris[index] - centre[:, None, :]          # (P, 3, 3), the box at the origin
    e = np.stack([v[:, 1] - v[:, 0], v[:, 2] - v[:, 1], v[:, 0] - v[:, 2]], axis=1)
    keep = np.ones(len(cells), bool)
    # The triangle's plane against the box.
    n = np.cross(e[:, 0], e[:, 1])
    r = np.abs(n) @ half
    keep &= np.abs(np.einsum("ij,ij->i", n, v[:, 0])) <= r
    # The nine cross products of the box axes with the triangle's edges.
    for k in range(3):
        edge = e[:, k]
        for axis in range(3):
            a = np.zeros_like(edge)
            j, m = (axis + 1) % 3, (axis + 2) % 3
            a[:, j] = -edge[:, m]
            a[:, m] = edge[:, j]
            p = np.einsum("pvk,pk->pv", v, a)
            r = np.abs(a) @ half
            keep &= (p.min(axis=1) <= r) & (p.max(axis=1) >= -r)
    return keep


def bin_triangles(spec: GridSpec, tris: np.ndarray, first_id: int = 0) -> CellLists:
    """List triangles (F, 3, 3) in the cells they touch; ids start at ``first_id``."""
    n_cells = spec.n_cells
    if len(tris) == 0:
        return CellLists(np.zeros(n_cells + 1, np.int64), np.zeros(0, np.int32))
    tris = np.asarray(tris, np.float64)
    pad = spec.cell * BIN_PAD_CELLS
    lo = np.floor((tris.min(axis=1) - pad - spec.origin) / spec.cell).astype(np.int64)
    hi = np.floor((tris.max(axis=1) + pad - spec.origin) / spec.cell).astype(np.int64)
    lo = np.clip(lo, 0, spec.dims - 1)
    hi = np.clip(hi, 0, spec.dims - 1)
    span = hi - lo + 1
    counts = np.prod(span, axis=1)
    ends = np.cumsum(counts)
    all_cells, all_ids = [], []
    start = 0
    while start < len(tris):
        # As many triangles as fit the batch (at least one, however many cells it spans).
        base = ends[start - 1] if start else 0
        stop = max(start + 1, int(np.searchsorted(ends, base + PAIRS_PER_BATCH, side="right")))
        sel = np.arange(start, stop)
        c = counts[sel]
        index = np.repeat(sel, c)
        local = np.arange(int(c.sum())) - np.repeat(np.cumsum(c) - c, c)
        sx, sy = span[index, 0], span[index, 1]
        cx = lo[index, 0] + local % sx
        cy = lo[index, 1] + (local // sx) % sy
        cz = lo[index, 2] + local // (sx * sy)
        cells = cx + spec.dims[0] * (cy + spec.dims[1] * cz)
        keep = _overlap_pairs(spec, tris, cells, index)
        all_cells.append(cells[keep])
        all_ids.append(index[keep])
        start = stop
    cells = np.concatenate(all_cells)
    ids = np.concatenate(all_ids)
    order = np.argsort(cells, kind="stable")
    offsets = np.zeros(n_cells + 1, np.int64)
    offsets[1:] = np.cumsum(np.bincount(cells, minlength=n_cells))
    return CellLists(offsets, (ids[order] + first_id).astype(np.int32))


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
    """The scene's grid: the statics' lists built once, the characters' lists per frame."""

    def __init__(self, geom: PackedGeometry, scene: Scene,
                 cells_per_triangle: float = CELLS_PER_TRIANGLE):
        self.geom = geom
        self.cells_per_triangle = cells_per_triangle
        lower, upper = scene_bounds(geom, scene)
        start = time.perf_counter()
        self.static_tris = static_triangles(geom)
        self.n_character_tris = sum(len(geom.triangles[geom.character_object(i)])
                                    for i in range(geom.n_characters))
        self.spec = grid_spec(lower, upper, len(self.static_tris) + self.n_character_tris,
                              cells_per_triangle)
        self.static = bin_triangles(self.spec, self.static_tris)
        self.static_ms = (time.perf_counter() - start) * 1e3

    @property
    def n_static(self) -> int:
        return len(self.static_tris)

    def characters(self, models: np.ndarray) -> tuple[np.ndarray, CellLists, float]:
        """Posed character triangles, their cell lists (ids after the statics') and build ms."""
        start = time.perf_counter()
        tris = character_triangles(self.geom, models)
        lists = bin_triangles(self.spec, tris, first_id=self.n_static)
        return tris, lists, (time.perf_counter() - start) * 1e3
