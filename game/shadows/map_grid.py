"""A light-space grid of map lists, so a fragment loops over a few candidate maps, not all.

Directional light: the grid covers the union of the maps' rectangles in the common light space
(their footprints are exact rectangles there). Spot and point lights: the grid lies over the
octahedral map of directions from the light, and a cell lists a map when the cone of
directions through the cell can meet the map's frustum. Both tests are conservative: a cell may
list a map that cannot shadow part of it (the shader's own test rejects that), never omit one.

The result is one int32 array: ``size * size + 1`` offsets into the same array, then the map
indices of every cell (read by ``shadow_visibility`` in shaders/shadow.glsl).

The shader clamps a fragment outside the grid's rectangle to the nearest edge cell, and the
cells of a map reaching past the rectangle are clamped the same way, so the rectangle decides
only how well the cells split the maps, never which maps a fragment finds. That lets
:class:`GridBuilder` lay the grid over the maps that stay put (the cached statics) and keep
their cells from frame to frame, while only the maps that move are placed again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from game.gpu.blocks import GRID_NONE, GRID_OCTAHEDRAL, GRID_ORTHO, GRID_TILES
from game.shadows.fit import MapFit
from game.shadows.octahedral import OCTAHEDRAL_GRID, map_hits

# Beyond this many maps the grid is cheaper than looping over all. With two, a fragment
# walks both records; one fetch of its cell's list, which names the one map that can
# shadow it or none, costs less.
LOOP_MAX_MAPS = 1
MAX_GRID = 128
MAX_TILE_GRID = 512       # a partition's grid: most cells per side (a wider one is not aligned)
MAX_WIDE_GRID = 2 * MAX_GRID  # most cells per side of a grid grown over walkers outside it
GRID_CELLS_PER_MAP = 8  # cells per side per sqrt(map count): short lists, small grid


@dataclass
class MapGrid:
    mode: int
    size: int
    rect: np.ndarray      # (4,) light-space rectangle covered
    data: np.ndarray      # int32 offsets then lists

    @property
    def mean_list(self) -> float:
        cells = self.size * self.size
        return float(self.data[cells] - self.data[0]) / max(cells, 1)


def no_grid() -> MapGrid:
    return MapGrid(GRID_NONE, 1, np.array([0.0, 0.0, 1.0, 1.0]), np.zeros(2, np.int32))


# Map indices stay below this (blocks.MAX_MAPS is far smaller), so a (cell, map) pair packs
# into one int64 key that sorts by cell, then map.
KEY_MAPS = 1 << 20


def _pack(keys: np.ndarray, size: int, mode: int, rect: np.ndarray) -> MapGrid:
    """Sorted unique (cell, map) keys -> offsets + lists, cell by cell, maps ascending."""
    cells = size * size
    counts = np.bincount(keys // KEY_MAPS, minlength=cells)
    offsets = (cells + 1) + np.concatenate([[0], np.cumsum(counts)])
    data = np.concatenate([offsets, keys % KEY_MAPS]).astype(np.int32)
    return MapGrid(mode, size, rect, data)


def _union(rects: np.ndarray) -> np.ndarray:
    return np.array([rects[:, 0].min(), rects[:, 1].min(), rects[:, 2].max(), rects[:, 3].max()])


def _grid_size(n_maps: int) -> int:
    return int(np.clip(GRID_CELLS_PER_MAP * np.ceil(np.sqrt(n_maps)), 4, MAX_GRID))


def _ortho_pairs(fits: list[MapFit], covers: list[np.ndarray | None] | None, reach: float,
                 rect: np.ndarray, size: int, first: int = 0) -> np.ndarray:
    """Sorted unique keys ``cell * KEY_MAPS + map`` of the cells each map's casters touch; the
    maps are numbered from ``first``."""
    if not fits:
        return np.zeros(0, np.int64)
    if covers is None:
        rects, owner = np.array([f.rect for f in fits], float), np.arange(len(fits))
    else:
        # Per map its covers grown by the reach, or its own rectangle: in one go, as a crowd's
        # frame has hundreds of maps.
        parts, grow = [], []
        for fit, cover in zip(fits, covers, strict=True):
            parts.append(fit.rect[None] if cover is None
                         else np.asarray(cover, float).reshape(-1, 4))
            grow.append(0.0 if cover is None else reach * fit.texel)
        owner = np.repeat(np.arange(len(fits)), [len(part) for part in parts])
        rects = (np.concatenate(parts)
                 + np.array(grow)[owner][:, None] * np.array([-1.0, -1.0, 1.0, 1.0]))
    # The cells each rectangle touches (cell = row * size + column, rows along y), as ranges
    # grown by a sliver so that float32 rounding in the shader cannot put a fragment one over.
    cell = (rect[2:] - rect[:2]) / size
    sliver = 1e-3
    lo = np.floor((rects[:, :2] - rect[:2]) / cell - sliver).astype(np.int64)
    hi = np.floor((rects[:, 2:] - rect[:2]) / cell + sliver).astype(np.int64)
    lo, hi = np.clip(lo, 0, size - 1), np.clip(hi, 0, size - 1)
    return _cell_keys(lo, hi, owner + first, size)


def _cell_keys(lo: np.ndarray, hi: np.ndarray, owner: np.ndarray, size: int) -> np.ndarray:
    """Sorted unique keys of every cell in the inclusive cell ranges ``lo``..``hi`` ((n, 2)
    columns and rows) of map ``owner[n]``."""
    width = hi[:, 0] - lo[:, 0] + 1
    height = hi[:, 1] - lo[:, 1] + 1
    count = np.maximum(width, 0) * np.maximum(height, 0)
    which = np.repeat(np.arange(len(lo)), count)
    k = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
    cx = lo[which, 0] + k % width[which]
    cy = lo[which, 1] + k // width[which]
    # Pairs, not a dense (cells, maps) table: with a hundred maps on a large grid that table
    # holds over a million entries to fill every frame.
    return np.unique((cy * size + cx) * KEY_MAPS + owner[which])


def _tile_lattice(tiles: list[np.ndarray], want: int, around: np.ndarray | None
                  ) -> tuple[np.ndarray, int] | None:
    """The grid's rectangle and size for a partition's tiles (equal squares on one lattice):
    whole tiles per side, each split into the same number of cells, so that no cell straddles
    two tiles; None where the tiles span more cells than MAX_TILE_GRID per side. The lattice
    reaches on by whole tiles over ``around`` (the moving maps' rectangles): the shader clamps a
    fragment outside the grid to an edge cell, which would list every walker's map beyond that
    edge."""
    t = np.asarray(tiles, float)
    span = float(t[0, 2] - t[0, 0])
    lo, hi = t[:, :2].min(axis=0), t[:, 2:].max(axis=0)
    if around is not None:
        lo = lo - np.ceil(np.maximum(lo - around[:2], 0.0) / span) * span
        hi = hi + np.ceil(np.maximum(around[2:] - hi, 0.0) / span) * span
    n = max(1, int(round(float((hi - lo).max()) / span)))
    if n > MAX_TILE_GRID:
        return None
    size = n * max(1, min(want, MAX_TILE_GRID) // n)
    return np.concatenate([lo, lo + n * span]), size


def _tile_pairs(tiles: list[np.ndarray], rect: np.ndarray, size: int) -> np.ndarray:
    """Keys of the cells of each tile, exactly: tile k lists map k in its own cells only."""
    t = np.asarray(tiles, float)
    cell = (rect[2:] - rect[:2]) / size
    lo = np.rint((t[:, :2] - rect[:2]) / cell).astype(np.int64)
    hi = np.rint((t[:, 2:] - rect[:2]) / cell).astype(np.int64) - 1
    return _cell_keys(lo, hi, np.arange(len(t)), size)


def _widen(rect: np.ndarray, size: int, around: np.ndarray
           ) -> tuple[np.ndarray, int, np.ndarray]:
    """The grid's rectangle grown by whole cells to hold ``around`` (the moving maps'
    rectangles' union), as :func:`_tile_lattice` grows a partition's; its new size, and the
    columns and rows added before the old first cell. Left as it is where that would pass
    MAX_WIDE_GRID cells per side."""
    cell = (rect[2:] - rect[:2]) / size
    before = np.ceil(np.maximum(rect[:2] - around[:2], 0.0) / cell).astype(np.int64)
    after = np.ceil(np.maximum(around[2:] - rect[2:], 0.0) / cell).astype(np.int64)
    grow = int((before + after).max())
    if grow == 0 or size + grow > MAX_WIDE_GRID:
        return rect, size, np.zeros(2, np.int64)
    lo = rect[:2] - before * cell
    return np.concatenate([lo, lo + (size + grow) * cell]), size + grow, before


def _moved_keys(keys: np.ndarray, size: int, wide: int, shift: np.ndarray) -> np.ndarray:
    """Keys of a ``size`` grid in the ``wide`` grid that adds ``shift`` columns and rows before
    it (:func:`_widen`); still sorted, as rows and columns keep their order."""
    cell, owner = keys // KEY_MAPS, keys % KEY_MAPS
    row, column = cell // size + shift[1], cell % size + shift[0]
    return (row * wide + column) * KEY_MAPS + owner


def build_ortho(fits: list[MapFit], covers: list[np.ndarray | None] | None = None,
                reach: float = 0.0) -> MapGrid:
    """Grid over the maps' light-space rectangles (directional light).

    ``covers`` may give, per map, the light-space rectangles (K, 4) of the casters in it: a cell
    then lists the map only where one of them, grown by ``reach`` texels of that map (the bias
    offsets and a filter tap), overlaps the cell. Depth texels outside every caster's rectangle
    are empty, so the map could not shadow anything there.
    """
    return GridBuilder().build(fits, None, "on", covers, reach)


def _octahedral_pairs(fits: list[MapFit], eye: np.ndarray, first: int = 0,
                      spheres: list[np.ndarray | None] | None = None,
                      reach: float = 0.0) -> np.ndarray:
    """As :func:`_ortho_pairs`, over the directions from a spot or point light at ``eye``
    (:func:`game.shadows.octahedral.map_hits`)."""
    cell, owner = map_hits(fits, eye, spheres, reach)
    return np.unique(cell.astype(np.int64) * KEY_MAPS + owner + first)


def build_octahedral(fits: list[MapFit], eye: np.ndarray) -> MapGrid:
    """Grid over the directions from a spot or point light at ``eye``."""
    return GridBuilder().build(fits, eye, "on")


class GridBuilder:
    """Builds each frame's grid, keeping the cells of the steady maps from the frame before.

    The steady maps are the plan's first ones (cached statics); the grid's rectangle is theirs,
    grown by whole cells (or tiles) over the maps that move every frame (characters) where they
    lie outside it. So those do not disturb the steady maps' cells, and a frame whose steady
    maps are unchanged only places the others. Holds no GL object.
    """

    def __init__(self):
        self._key = None
        self._keys = np.zeros(0, np.int64)

    def build(self, fits: list[MapFit], eye: np.ndarray | None, use: str = "auto",
              covers: list[np.ndarray | None] | None = None,
              reach: float = 0.0, steady: int | None = None,
              tiles: list[np.ndarray | None] | None = None,
              spheres: list[np.ndarray | None] | None = None) -> MapGrid:
        """The grid for these maps, or none when a plain loop is cheap enough: over the
        light space of orthographic maps, or over the directions from a light at ``eye``.

        ``use`` is "auto" (a grid above LOOP_MAX_MAPS maps), "on" or "off"; ``covers`` and
        ``reach`` as in :func:`build_ortho` (``spheres`` and ``reach`` as in
        :func:`_octahedral_pairs` for a light at ``eye``); the first ``steady`` maps (all by
        default) are the ones whose cells are kept while they do not change. Where every
        steady map has a tile of a partition (``tiles``), the grid is aligned to the tiles and
        lists each such map in its tile's cells only: a fragment then finds one static map.
        """
        if not fits or use == "off" or (use == "auto" and len(fits) <= LOOP_MAX_MAPS):
            return no_grid()
        steady = len(fits) if steady is None else min(steady, len(fits))
        ortho = eye is None
        own = (tiles or [None] * len(fits))[:steady]
        # Where the moving maps lie: the grid reaches on over them.
        around = (_union(np.array([f.rect for f in fits[steady:]], float))
                  if ortho and steady < len(fits) else None)
        lattice = (_tile_lattice(own, _grid_size(len(fits)), around)
                   if ortho and own and all(t is not None for t in own) else None)
        if lattice is not None:
            (rect, size), mode = lattice, GRID_TILES
        elif ortho:
            rects = np.array([f.rect for f in fits[:steady] or fits], float)
            rect, size, mode = _union(rects), _grid_size(len(fits)), GRID_ORTHO
        else:
            rect, size, mode = np.array([-1.0, -1.0, 1.0, 1.0]), OCTAHEDRAL_GRID, GRID_OCTAHEDRAL
        if not _representable(rect):
            return no_grid()
        cover = covers if covers is not None else [None] * len(fits)
        sphere = spheres if spheres is not None else [None] * len(fits)
        key = (mode, size, float(reach), rect.tobytes(),
               None if ortho else np.asarray(eye, float).tobytes(), lattice is not None,
               tuple(_fit_key(f, c, b) for f, c, b
                     in zip(fits[:steady], cover[:steady], sphere[:steady], strict=True)))
        if key != self._key:
            if lattice is not None:
                self._keys = _tile_pairs(own, rect, size)
                if covers is not None:
                    # A tile's texels are empty outside its casters' covers: a cell there lists
                    # no static map, and its fragments read none.
                    self._keys = np.intersect1d(self._keys, _ortho_pairs(
                        fits[:steady], cover[:steady], reach, rect, size), assume_unique=True)
            elif ortho:
                self._keys = _ortho_pairs(fits[:steady], cover[:steady], reach, rect, size)
            else:
                self._keys = _octahedral_pairs(fits[:steady], eye, 0, sphere[:steady], reach)
            self._key = key
        keys = self._keys
        if mode == GRID_ORTHO and around is not None:
            wide_rect, wide, shift = _widen(rect, size, around)
            if wide != size and not _representable(wide_rect):
                return no_grid()
            if wide != size:
                keys = _moved_keys(keys, size, wide, shift)
                rect, size = wide_rect, wide
        moving = (_ortho_pairs(fits[steady:], cover[steady:], reach, rect, size, steady)
                  if ortho else _octahedral_pairs(fits[steady:], eye, steady, sphere[steady:],
                                                  reach))
        # A partition packs like any other grid: its tiles are the first maps, so a cell's
        # sorted entries start with its tile's map.
        keys = keys if not len(moving) else np.sort(np.concatenate([keys, moving]))
        return _pack(keys, size, mode, rect)


def _representable(rect: np.ndarray) -> bool:
    """Whether the shader's float32 holds a grid over ``rect`` (maps absurdly wide, at a
    density target near zero, do not: the loop over every map still finds theirs)."""
    return bool(np.all(np.abs(rect) < np.finfo(np.float32).max / 4))


def _fit_key(fit: MapFit, cover: np.ndarray | None, spheres: np.ndarray | None) -> tuple:
    """What a map's cells depend on."""
    return (fit.view_proj.tobytes(), fit.rect.tobytes(), float(fit.texel),
            None if cover is None else np.asarray(cover, float).tobytes(),
            None if spheres is None else np.asarray(spheres, float).tobytes())


def build(fits: list[MapFit], eye: np.ndarray | None, use: str = "auto",
          covers: list[np.ndarray | None] | None = None, reach: float = 0.0) -> MapGrid:
    """The grid for these maps, built afresh (see :meth:`GridBuilder.build`)."""
    return GridBuilder().build(fits, eye, use, covers, reach)
