"""Conservative triangle-box binning into uniform grids: the cells of the soft-shadow tracer's
acceleration structures (game/soft/grid.py).

Every triangle is listed in every cell its surface touches (the separating-axis test of
Akenine-Moeller, "Fast 3D triangle-box overlap testing", 2001, with each cell grown by
``BIN_PAD_CELLS`` so that the float32 3D-DDA on the GPU, which may round a ray into a
neighbouring cell at a boundary, still finds every triangle it can hit). Lists are kept in CSR
form, each ascending by triangle.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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
    """Triangle lists of every cell (or leaf), in CSR form: ``ids[offsets[c]:offsets[c + 1]]``."""

    offsets: np.ndarray  # (n_cells + 1,) int64
    ids: np.ndarray      # (pairs,) int32, triangle indices

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


def expand_ranges(lo: np.ndarray, hi: np.ndarray):
    """Every cell of every item's inclusive cell range [lo, hi] (both (F, 3) int64), in batches
    of about PAIRS_PER_BATCH: yields (item index (K,), cell coordinates (K, 3))."""
    span = hi - lo + 1
    counts = np.prod(span, axis=1)
    ends = np.cumsum(counts)
    start = 0
    while start < len(lo):
        # As many items as fit the batch (at least one, however many cells it spans).
        base = ends[start - 1] if start else 0
        stop = max(start + 1, int(np.searchsorted(ends, base + PAIRS_PER_BATCH, side="right")))
        sel = np.arange(start, stop)
        c = counts[sel]
        index = np.repeat(sel, c)
        local = np.arange(int(c.sum())) - np.repeat(np.cumsum(c) - c, c)
        sx, sy = span[index, 0], span[index, 1]
        coords = np.stack([lo[index, 0] + local % sx, lo[index, 1] + (local // sx) % sy,
                           lo[index, 2] + local // (sx * sy)], axis=1)
        yield index, coords
        start = stop


def overlaps(v: np.ndarray, half: np.ndarray) -> np.ndarray:
    """Which triangles (P, 3, 3), given relative to their box's centre, overlap the box of
    half-size ``half`` ((P, 3) or (3,)): the separating-axis test, vectorised over pairs, on the
    survivors of each stage only."""
    half = np.broadcast_to(half, (len(v), 3))
    v0, v1, v2 = v[:, 0], v[:, 1], v[:, 2]
    # The box's own three axes.
    keep = ((np.minimum(np.minimum(v0, v1), v2) <= half)
            & (np.maximum(np.maximum(v0, v1), v2) >= -half)).all(axis=1)
    idx = np.nonzero(keep)[0]
    v0, v1, v2, h = v0[idx], v1[idx], v2[idx], half[idx]
    edges = (v1 - v0, v2 - v1, v0 - v2)
    # The triangle's plane against the box.
    n = np.cross(edges[0], edges[1])
    ok = np.abs((n * v0).sum(axis=1)) <= (np.abs(n) * h).sum(axis=1)
    # The nine cross products of the box axes with the triangle's edges: the axis e x X_a has
    # components j = a + 1 and m = a + 2 (mod 3), -e_m and e_j.
    for e in edges:
        for axis in range(3):
            j, m = (axis + 1) % 3, (axis + 2) % 3
            ej, em = e[:, j], e[:, m]
            p0 = ej * v0[:, m] - em * v0[:, j]
            p1 = ej * v1[:, m] - em * v1[:, j]
            p2 = ej * v2[:, m] - em * v2[:, j]
            r = np.abs(em) * h[:, j] + np.abs(ej) * h[:, m]
            ok &= (np.minimum(np.minimum(p0, p1), p2) <= r) & (np.maximum(np.maximum(p0, p1), p2)
                                                              >= -r)
    keep[idx] = ok
    return keep


def cell_range(tris: np.ndarray, origin: np.ndarray, cell: np.ndarray,
                dims: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The padded cell range [lo, hi] of each triangle's bounding box, clipped to the grid, and
    whether that box lies inside one cell of the grid (the triangle then touches that padded
    cell: no overlap test needed). ``origin``, ``cell`` and ``dims`` are (3,) or one row per
    triangle."""
    pad = cell * BIN_PAD_CELLS
    lo = np.floor((tris.min(axis=1) - pad - origin) / cell).astype(np.int64)
    hi = np.floor((tris.max(axis=1) + pad - origin) / cell).astype(np.int64)
    one = ((lo == hi) & (lo >= 0) & (lo < dims)).all(axis=1)
    return np.clip(lo, 0, dims - 1), np.clip(hi, 0, dims - 1), one


def linear_index(coords: np.ndarray, dims: np.ndarray) -> np.ndarray:
    """Cell index x + dx (y + dy z); ``dims`` is (3,) or one row per cell."""
    dims = np.broadcast_to(dims, coords.shape)
    return coords[:, 0] + dims[:, 0] * (coords[:, 1] + dims[:, 1] * coords[:, 2])


def cell_pairs(spec: GridSpec, tris: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every (cell, triangle) pair of a uniform grid whose padded cell the triangle touches."""
    if len(tris) == 0:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    lo, hi, one = cell_range(tris, spec.origin, spec.cell, spec.dims)
    cells, ids = [linear_index(lo[one], spec.dims)], [np.nonzero(one)[0]]
    many = np.nonzero(~one)[0]
    half = spec.cell * (0.5 + BIN_PAD_CELLS)
    for index, coords in expand_ranges(lo[many], hi[many]):
        index = many[index]
        centre = spec.origin + (coords + 0.5) * spec.cell
        keep = overlaps(tris[index] - centre[:, None, :], half)
        cells.append(linear_index(coords[keep], spec.dims))
        ids.append(index[keep])
    return np.concatenate(cells), np.concatenate(ids)


def leaf_order(keys: np.ndarray, ids: np.ndarray) -> np.ndarray:
    """The order that sorts pairs by key, and by triangle within a key (lists ascend whatever
    order the binning found them in)."""
    span = int(ids.max()) + 1 if len(ids) else 1
    return np.argsort(keys * span + ids)


def csr_lists(keys: np.ndarray, ids: np.ndarray, n: int, first_id: int = 0) -> CellLists:
    order = leaf_order(keys, ids)
    offsets = np.zeros(n + 1, np.int64)
    offsets[1:] = np.cumsum(np.bincount(keys, minlength=n))
    return CellLists(offsets, (ids[order] + first_id).astype(np.int32))


def bin_triangles(spec: GridSpec, tris: np.ndarray, first_id: int = 0) -> CellLists:
    """List triangles (F, 3, 3) in the cells of a uniform grid they touch; ids start at
    ``first_id``."""
    cells, ids = cell_pairs(spec, np.asarray(tris, np.float64))
    return csr_lists(cells, ids, spec.n_cells, first_id)
