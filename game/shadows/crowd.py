"""The characters' maps for one frame: sized by what the view needs of them, skipped where no
shadow of theirs can be seen, grouped where one map costs less than several, and packed into
the layers of the depth array.

Pure arithmetic on the characters' bounding spheres and the view; the clumped method turns the
result into map records (game/shadows/methods/clumped/characters.py). Holds no GL object.

- **Need.** A character's shadow lies in its shadow volume: its bounding box swept along the
  light down to the scene's lowest surface. The nearest point of that volume to the camera sets
  the finest detail any pixel can ask of the map: ``texels_per_pixel`` texels per pixel there.
  Resolutions are powers of two between the settings' minimum and maximum; a map grows at once
  and shrinks only when it needs well under the smaller size (hysteresis), so sizes do not flip
  between frames.
- **Skip.** A volume wholly outside one plane of the view frustum casts no visible shadow.
- **Group.** Two maps become one when one map at the finer member's texels costs less (texels
  plus a fixed cost per map) than both; texels stay world-fixed per size, so a group's members
  keep their texel density.
- **Pack.** Square maps of power-of-two sides, largest first, fill each layer in Z order: no
  gaps, so the layers needed are the texels over the layer's texels, rounded up.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Hashable
from dataclasses import dataclass

import numpy as np

from game.shadows.fit import MARGIN_TEXELS

# A map's fixed cost in texel units: the clear call, its record and fit on the CPU, its entry
# in the map grid. Measured against the per-texel cost on llvmpipe (docs/design/crowds.md).
MAP_COST_TEXELS = 128 * 128
# A map shrinks a size only when it needs under this share of the smaller size.
SHRINK_BELOW = 0.75
# The texels a fitted map gives up to its margins (fit.fit_directional): usable = res - SPARE.
SPARE_TEXELS = 2 * MARGIN_TEXELS + 1


@dataclass
class CrowdMap:
    """One character map of the frame."""

    members: list[int]           # character indices
    resolution: int              # texels per side
    # Directional light: the light-space square (centre x, centre y, half side) that holds
    # the members' bounding spheres, and the texel size to keep (None: fit to the square).
    square: tuple[float, float, float] | None = None
    texel: float | None = None
    layer: int = 0               # index into the layers given to :func:`pack`
    origin: tuple[int, int] = (0, 0)  # texel offset of its square in that layer


def pow2_at_least(x: float, lo: int = 1, hi: int = 1 << 30) -> int:
    """The smallest power of two >= x, then held within [lo, hi]."""
    if not math.isfinite(x) or x >= hi:
        return hi
    return min(hi, max(lo, 1 << max(0, math.ceil(math.log2(max(x, 1.0))))))


def pow2_sides(x: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """:func:`pow2_at_least` of every element of ``x``, at once: the view's budget asks it of
    every clump map some thirty times a frame."""
    x = np.where(np.isfinite(x), np.maximum(x, 1.0), hi)
    return np.clip(2 ** np.ceil(np.log2(x)), lo, hi).astype(np.int64)


def held_sizes(needed: np.ndarray, last: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """Power-of-two sizes for ``needed`` within [lo, hi], with the hysteresis: a size grows at
    once, and shrinks from ``last`` (0: none yet) only when the need falls under
    :data:`SHRINK_BELOW` of the smaller size."""
    sizes = pow2_sides(needed, lo, hi)
    last = np.minimum(last, hi)
    return np.where((last > sizes) & (needed > SHRINK_BELOW * last / 2), last, sizes)


def shadow_volumes(centres: np.ndarray, radii: np.ndarray, direction: np.ndarray | None,
                   eye: np.ndarray | None, ground: float) -> tuple[np.ndarray, np.ndarray]:
    """Per character, 16 points whose convex hull holds its shadow volume down to ``ground``
    (the lowest height anything lies at), and whether the volume is bounded (False where the
    light's rays through the character do not go down: its shadow may reach anywhere). Rays
    leave a light at ``eye``, or travel along ``direction`` where there is none (parallel
    light)."""
    n = len(centres)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    box = centres[:, None, :] + radii[:, None, None] * corners[None]  # (n, 8, 3)
    if eye is None:
        d = np.broadcast_to(np.asarray(direction, float), box.shape)
    else:
        d = box - np.asarray(eye, float)
    down = d[..., 1] < -1e-6
    bounded = down.all(axis=1)
    t = np.where(down, (box[..., 1] - ground) / np.where(down, -d[..., 1], 1.0), 0.0)
    swept = box + d * np.maximum(t, 0.0)[..., None]
    return np.concatenate([box, swept], axis=1).reshape(n, 16, 3), bounded


def outside_view(points: np.ndarray, view_proj: np.ndarray) -> np.ndarray:
    """(n,) True where all of a character's points lie beyond one plane of the frustum."""
    hom = np.concatenate([points, np.ones(points.shape[:-1] + (1,))], axis=-1)
    clip = hom @ view_proj.T
    x, y, z, w = clip[..., 0], clip[..., 1], clip[..., 2], clip[..., 3]
    out = np.zeros(len(points), bool)
    for plane in (x - w, -x - w, y - w, -y - w, z - w, -z - w):
        out |= (plane > 0).all(axis=1)
    return out


def texels_needed(points: np.ndarray, centres: np.ndarray, radii: np.ndarray,
                  view: np.ndarray, proj: np.ndarray, height: int, texels_per_pixel: float,
                  eye: np.ndarray | None) -> np.ndarray:
    """(n,) texels per side each map needs: its footprint (the bounding sphere's width, as
    the map's fit uses) at ``texels_per_pixel`` times the screen's pixel density at the
    volume's nearest point; a perspective map also by how much its shadow grows beyond the
    caster (farthest volume point over the centre, from the light)."""
    hom = np.concatenate([points, np.ones(points.shape[:-1] + (1,))], axis=-1)
    depth = -(hom @ view[2])                                # (n, 16) view-space depth
    near = proj[2, 3] / (proj[2, 2] - 1.0)                 # a perspective projection's
    nearest = np.maximum(depth.min(axis=1), max(near, 1e-6))
    pixels_per_metre = 0.5 * height * proj[1, 1] / nearest
    grow = np.ones(len(points))
    if eye is not None:
        to_centre = np.linalg.norm(centres - eye, axis=1)
        farthest = np.linalg.norm(points - eye, axis=2).max(axis=1)
        grow = farthest / np.maximum(to_centre, 1e-9)
    return 2.0 * radii * pixels_per_metre * texels_per_pixel * grow + SPARE_TEXELS


class CrowdPlanner:
    """Plans the character maps frame after frame; keeps each character's last size (by name)
    for the hysteresis."""

    def __init__(self, min_resolution: int, max_resolution: int):
        self.min_resolution = min_resolution
        self.max_resolution = max_resolution
        self._size: dict[Hashable, int] = {}

    def sizes(self, names: list[Hashable], needed: np.ndarray) -> list[int]:
        """Power-of-two sides for these needs, with the hysteresis (:func:`held_sizes`);
        ``names`` are any keys that stay while what they name does."""
        out = held_sizes(np.asarray(needed, float), self.last_sizes(names),
                         self.min_resolution, self.max_resolution).tolist()
        self._size.update(zip(names, out, strict=True))
        return out

    def settle(self, names: list[Hashable], sizes: list[int]) -> None:
        """Make ``sizes`` the last sizes of ``names`` (what they got, where it differs from
        what they asked)."""
        self._size.update(zip(names, sizes, strict=True))

    def last_sizes(self, names: list[Hashable]) -> np.ndarray:
        """The last size of each of ``names`` (0 for one never sized)."""
        return np.array([self._size.get(name, 0) for name in names], np.int64)

    @property
    def held(self) -> set[Hashable]:
        """The names whose last size is kept."""
        return set(self._size)

    def forget(self, keep: set[Hashable]) -> None:
        """Drop the sizes of the names not in ``keep`` (characters, or clump maps, that no
        longer exist)."""
        self._size = {n: s for n, s in self._size.items() if n in keep}


def group(sizes: list[int], rects: np.ndarray, max_resolution: int,
          max_maps: int | None = None, merge: bool = True) -> list[CrowdMap]:
    """Maps for characters of these sizes: one each, merged in pairs where the cost model says
    one map is cheaper (``merge``), and merged further while there are more than ``max_maps``
    (those groups get coarser texels: degrade, never drop a shadow).

    ``rects`` (n, 4) are the light-space squares of the bounding spheres (a directional
    light; around a lamp, game/shadows/crowd_runs.py).
    """
    n = len(sizes)
    limit = n if max_maps is None else max(1, max_maps)
    half = 0.5 * (rects[:, 2:] - rects[:, :2]).max(axis=1)
    texel = 2.0 * half / (np.asarray(sizes, float) - SPARE_TEXELS)  # as fit_directional's
    boxes, texels = rects.tolist(), texel.tolist()
    groups = {k: _Group([k], boxes[k], texels[k], sizes[k]) for k in range(n)}
    if merge and n > 1:
        _merge_by_cost(groups, rects, texel, np.asarray(sizes, float), max_resolution)
    if len(groups) > limit:
        _merge_nearest(groups, max_resolution, limit)
    out = []
    for g in groups.values():
        x0, y0, x1, y1 = g.box
        square = (0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * max(x1 - x0, y1 - y0))
        out.append(CrowdMap(sorted(g.members), g.size, square,
                            None if len(g.members) == 1 else g.texel))
    return out


@dataclass
class _Group:
    members: list[int]
    box: list[float]       # light-space rectangle (x0, y0, x1, y1) of the members' spheres
    texel: float | None    # the finest member's texel; None once merged past the largest map
    size: int


def _union(a: _Group, b: _Group) -> list[float]:
    return [min(a.box[0], b.box[0]), min(a.box[1], b.box[1]),
            max(a.box[2], b.box[2]), max(a.box[3], b.box[3])]


def _merge_by_cost(groups: dict[int, _Group], rects: np.ndarray, texel: np.ndarray,
                   size: np.ndarray, max_resolution: int) -> None:
    """Merge pairs, nearest first, where one map at the finer texel costs less than two;
    ``texel`` and ``size`` are the single maps' (the groups as they start)."""
    centre = 0.5 * (rects[:, :2] + rects[:, 2:])
    reach = 0.5 * (rects[:, 2:] - rects[:, :2]).max(axis=1)
    # Candidate pairs: footprints at most one footprint apart, and worth one map as they are
    # (two single maps): a group's union only grows, so few pairs that fail here would pass.
    i, j, gap = near_pairs(centre, reach)
    n = len(rects)
    side = (np.maximum(rects[i, 2:], rects[j, 2:]) - np.minimum(rects[i, :2], rects[j, :2])).max(1)
    need = side / np.minimum(texel[i], texel[j]) + SPARE_TEXELS
    merged = 2.0 ** np.ceil(np.log2(np.maximum(need, 1.0)))
    keep = (need <= max_resolution) & (merged ** 2 < size[i] ** 2 + size[j] ** 2 + MAP_COST_TEXELS)
    i, j = i[keep], j[keep]
    owner = list(range(n))

    def root(k: int) -> int:
        while owner[k] != k:
            owner[k] = owner[owner[k]]
            k = owner[k]
        return k

    # The walk below runs once per candidate pair: plain floats, not small arrays.
    order = np.lexsort((j, i, gap[keep]))
    for a, b in zip(i[order].tolist(), j[order].tolist(), strict=True):
        ra, rb = root(a), root(b)
        if ra == rb:
            continue
        ga, gb = groups[ra], groups[rb]
        box = _union(ga, gb)
        t = min(ga.texel, gb.texel)
        need = max(box[2] - box[0], box[3] - box[1]) / t + SPARE_TEXELS
        if need > max_resolution:
            continue
        size = pow2_at_least(need, 1, max_resolution)
        if size * size >= ga.size * ga.size + gb.size * gb.size + MAP_COST_TEXELS:
            continue
        owner[rb] = ra
        groups[ra] = _Group(ga.members + gb.members, box, t, size)
        del groups[rb]


def near_pairs(centre: np.ndarray, reach: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pairs i < j of footprints (centres, half sides) less than twice the larger one's
    half side apart, and their gaps: only those in neighbouring cells of a grid as wide as two
    near footprints may lie apart are paired, so a crowd costs no n-by-n table. (In each gap,
    the one of a pair earlier along x comes first, as in a sweep along x: the same rounding.)"""
    n = len(centre)
    window = 4.0 * float(reach.max()) if n else 0.0  # the most two near footprints lie apart
    if not window > 0.0 or not math.isfinite(window):
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    rank = np.empty(n, np.int64)
    rank[np.argsort(centre[:, 0], kind="stable")] = np.arange(n)
    cell = np.floor(centre / (1.01 * window)).astype(np.int64)  # a little wider: no rounding
    cell -= cell.min(axis=0)                                  # loses a pair across a cell edge
    rows = int(cell[:, 1].max()) + 3
    key = cell[:, 0] * rows + cell[:, 1] + 1
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    starts, stops = [], []
    for step in (0, 1, rows - 1, rows, rows + 1):  # this cell and the next four: each pair once
        starts.append(np.arange(n) + 1 if step == 0 else
                      np.searchsorted(sorted_key, sorted_key + step, side="left"))
        stops.append(np.searchsorted(sorted_key, sorted_key + step, side="right"))
    lo = np.concatenate(starts)
    count = np.maximum(np.concatenate(stops) - lo, 0)
    first = np.repeat(np.tile(np.arange(n), 5), count)
    second = np.repeat(lo, count) + np.arange(int(count.sum())) - np.repeat(
        np.cumsum(count) - count, count)
    p, q = order[first], order[second]
    swap = rank[p] > rank[q]
    p, q = np.where(swap, q, p), np.where(swap, p, q)
    gap = np.hypot(*(centre[p] - centre[q]).T) - reach[p] - reach[q]
    near = (gap < 2.0 * np.maximum(reach[p], reach[q])) & (
        centre[q, 0] <= centre[p, 0] + window)
    return np.minimum(p, q)[near], np.maximum(p, q)[near], gap[near]


class _Nearest:
    """The groups' union sides, for merging the two whose union is smallest again and again
    (too many maps for the records), with the first pair in the groups' order among equals.

    Each group keeps its best partner; a merge changes only the merged group's and those whose
    best was one of the pair: a union only grows, so no other group finds a better partner. A
    partner is searched for in rings of grid cells around the group's centre, out to where no
    union can be smaller (it is at least as wide as its two centres lie apart)."""

    def __init__(self, groups: dict[int, _Group]):
        self.keys = list(groups)
        n = len(self.keys)
        self.boxes = np.array([groups[k].box for k in self.keys], float)
        self.alive = np.ones(n, bool)
        self.best = np.full(n, -1, np.int64)
        self.side = np.full(n, np.inf)
        self.heap: list[tuple[float, int, int]] = []
        self._grid()
        for a in range(n):
            self._refresh(a)

    def _grid(self) -> None:
        """Cells of about one group each, made anew as the groups halve."""
        live = np.flatnonzero(self.alive)
        centres = 0.5 * (self.boxes[live, :2] + self.boxes[live, 2:])
        self.origin = centres.min(axis=0)
        span = float((centres.max(axis=0) - self.origin).max())
        self.h = span / math.sqrt(len(live)) if span > 0 and math.isfinite(span) else 1.0
        self.cells: dict[tuple[int, int], set[int]] = {}
        self.cell_of: dict[int, tuple[int, int]] = {}
        self.extent = 0
        for a in live.tolist():
            self._place(a)
        self.regrid_at = len(live) // 2

    def _place(self, a: int) -> None:
        c = 0.5 * (self.boxes[a, :2] + self.boxes[a, 2:])
        cx, cy = (int(v) for v in np.floor((c - self.origin) / self.h))
        self.cells.setdefault((cx, cy), set()).add(a)
        self.cell_of[a] = (cx, cy)
        self.extent = max(self.extent, abs(cx), abs(cy))

    def _ring(self, cx: int, cy: int, k: int) -> list[int]:
        cells = [(cx + d, cy + e) for d in range(-k, k + 1) for e in {-k, k}]
        cells += [(cx + e, cy + d) for d in range(-k + 1, k) for e in (-k, k)]
        return [i for cell in cells for i in self.cells.get(cell, ())]

    def _refresh(self, a: int) -> None:
        (cx, cy), best_side, best = self.cell_of[a], math.inf, -1
        k = 0
        # A group k + 1 rings out lies more than (k - 1) cells away along one axis (a ring of
        # margin for rounding), and so does its union's side.
        while (k - 1) * self.h < best_side and k <= 2 * self.extent + 2:
            found = [i for i in self._ring(cx, cy, k) if i != a]
            k += 1
            if not found:
                continue
            idx = np.array(found)
            lo = np.minimum(self.boxes[a, :2], self.boxes[idx, :2])
            hi = np.maximum(self.boxes[a, 2:], self.boxes[idx, 2:])
            side = (hi - lo).max(axis=1)
            m = float(side.min())
            first = int(idx[side == m].min())  # the groups' order breaks ties
            if m < best_side or (m == best_side and first < best):
                best_side, best = m, first
        self.best[a], self.side[a] = best, best_side
        if best >= 0:
            heapq.heappush(self.heap, (best_side, min(a, best), max(a, best)))

    def pop(self) -> tuple[int, int]:
        """The pair (a, b), a before b, to merge next; the merged group will be ``a``."""
        while True:
            side, a, b = heapq.heappop(self.heap)
            if not (self.alive[a] and self.alive[b]):
                continue
            if ((self.best[a] == b and self.side[a] == side)
                    or (self.best[b] == a and self.side[b] == side)):
                return a, b

    def merged(self, a: int, b: int, box: list[float]) -> None:
        for k in (a, b):
            self.cells[self.cell_of.pop(k)].discard(k)
        self.alive[b] = False
        self.boxes[a] = box
        self._place(a)
        if int(self.alive.sum()) <= self.regrid_at:
            self._grid()
        stale = np.flatnonzero(self.alive & ((self.best == a) | (self.best == b)))
        for k in [a, *stale.tolist()]:
            self._refresh(k)


def _merge_nearest(groups: dict[int, _Group], max_resolution: int, limit: int) -> None:
    """Merge the two groups whose union is smallest while there are more than ``limit`` (too
    many maps for the records)."""
    nearest = _Nearest(groups)
    keys = nearest.keys
    while len(groups) > limit:
        a, b = nearest.pop()
        ga, gb = groups[keys[a]], groups[keys[b]]
        box = _union(ga, gb)
        texel = None if ga.texel is None or gb.texel is None else min(ga.texel, gb.texel)
        need = ((max(box[2] - box[0], box[3] - box[1]) / texel + SPARE_TEXELS) if texel
                else math.inf)
        if need > max_resolution:
            texel = None  # coarser than asked: fitted to the square at the largest size
        size = max_resolution if texel is None else pow2_at_least(need, 1, max_resolution)
        groups[keys[a]] = _Group(ga.members + gb.members, box, texel, size)
        del groups[keys[b]]
        nearest.merged(a, b, box)


def layer_square(layer_resolution: int) -> int:
    """The largest power-of-two square of a layer: where its character maps are packed."""
    return 1 << int(math.floor(math.log2(layer_resolution)))


def pack(maps: list[CrowdMap], layers: int, layer_resolution: int) -> int:
    """Place the maps in ``layers`` layers (sets their layer and origin); where they cannot all
    fit, halve the largest until they do. Returns how many maps were shrunk.

    Each map takes the power-of-two square at least its size (its slot) in the largest
    power-of-two square of the layer; slots go largest first, in Z order.
    """
    square = layer_square(layer_resolution)
    capacity = layers * square ** 2
    slots = [pow2_at_least(m.resolution) for m in maps]
    used = sum(side * side for side in slots)
    shrunk = set()
    while maps and used > capacity:
        big = max(range(len(maps)), key=lambda k: maps[k].resolution)
        if maps[big].resolution <= 1:
            raise ValueError(f"{len(maps)} character maps cannot fit {layers} layers")
        maps[big].resolution = slots[big] // 2
        maps[big].texel = None  # a shrunk group is fitted to its members at the new size
        used -= slots[big] ** 2 - (slots[big] // 2) ** 2
        slots[big] //= 2
        shrunk.add(big)
    layer, used = 0, 0
    for k in sorted(range(len(maps)), key=lambda k: -slots[k]):
        m, side = maps[k], slots[k]
        if used + side * side > square ** 2:
            layer, used = layer + 1, 0
        x, y = _z_order(used // (side * side))  # the slot's index at its size
        m.layer, m.origin = layer, (x * side, y * side)
        used += side * side
    return len(shrunk)


def _z_order(k: int) -> tuple[int, int]:
    """Column and row of the k-th square in Z (Morton) order: the even and odd bits of k."""
    x = y = 0
    bit = 0
    while k >> (2 * bit):
        x |= ((k >> (2 * bit)) & 1) << bit
        y |= ((k >> (2 * bit + 1)) & 1) << bit
        bit += 1
    return x, y
