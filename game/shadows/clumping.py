"""Group static objects into clumps, one tight shadow map per clump.

The multi-map idea ("Some Ideas on Shadow Algorithms", *Hard Shadows*) gives each moving character
its own tight shadow map and lumps the static objects into a few clumps, one map each, and asks
whether the clumps are best formed from neighbours in world space or neighbours in light space.
This module implements both so that the benchmark can answer that question:

``world``
    Recursive median split of the object centres along the axis of largest world-space spread.
    Cheap and light-independent, but objects that are neighbours in the world can land far apart in
    the light's view (and vice versa), so the maps of two clumps can cover the same texels.
``light``
    Recursive split in the light's 2-D map plane that minimises the overlap of the two children's
    footprint rectangles, with the children's total area as a small secondary cost. This is the
    surface-area-heuristic sweep of BVH builders (MacDonald and Booth 1990) with overlap as the main
    cost, as in the R*-tree split (Beckmann et al. 1990).

Both split top-down, always splitting the clump with the largest footprint next, until every clump
fits the texel-density target (or is one object), or until a requested number of clumps exists.

Everything works on precomputed per-object summaries (a footprint rectangle and a world centre),
so a split of ``m`` objects costs one sort, ``O(m log m)``, whatever the objects' vertex counts.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

STRATEGIES = ("world", "light")
"""Valid values for the ``strategy`` argument of :func:`make_clumps`."""

LIGHT_SPLIT_AREA_WEIGHT = 0.01
"""Weight of the children's summed footprint area (m^2, or to_light units^2) against their overlap
area in the light-space split cost. Small so that overlap dominates; it only decides between splits
of equal overlap (most often: several that do not overlap at all), where the smaller total area
means fewer wasted texels."""

SPLIT_TIE_RTOL = 1e-9
"""Costs within this fraction of the parent's squared extent count as equal. Among equal-cost
splits the most balanced one wins, which keeps the recursion O(log n) deep on regular layouts
(a row of evenly spaced houses has the same cost at every gap) instead of peeling one object off
per level."""

LIGHT_SPLIT_MIN_FRACTION = 0.25
"""Smallest share of the objects either child of a light-space split may get. Without it the
cheapest split in a scattered town is usually an outlier peeled off alone (it overlaps nothing),
which makes the recursion O(n) deep and the build O(n^2 log n); the R*-tree split imposes a minimum
fill (40%) for the same reason (Beckmann et al. 1990). A quarter keeps the depth under
log_{4/3} n (about 35 levels for 20,000 objects) and still lets a split follow a real gap."""

FOOTPRINT_CHUNK_POINTS = 1 << 20
"""Points handed to the footprint function per call while summarising objects: few calls for speed,
bounded temporary memory for towns with many detailed objects."""

OVERLAP_PAIRS_PER_BLOCK = 1 << 22
"""Candidate clump pairs checked per vectorised block in :func:`footprint_overlap`."""

Footprint = Callable[[np.ndarray], np.ndarray]
"""Maps world points (N, 3) to light-space map-plane coordinates (N, 2), one row per point."""


@dataclass(frozen=True)
class Clump:
    """A group of static objects that share one shadow map."""

    members: tuple[int, ...]
    """Indices into the statics list, ascending."""
    rect: np.ndarray
    """Light-space footprint (xmin, ymin, xmax, ymax) of all the members' points, shape (4,)."""

    @property
    def extent(self) -> float:
        """Larger side of the footprint rectangle: what the texel-density target limits."""
        return float(max(self.rect[2] - self.rect[0], self.rect[3] - self.rect[1]))


def max_extent_for_density(map_resolution: int, texels_per_metre: float) -> float:
    """Largest footprint side one map can cover at the target density: resolution / density.

    Directional lights only; for spot and point lights the caller states ``max_extent`` in the
    units of its ``to_light`` function.
    """
    if map_resolution < 1:
        raise ValueError(f"map_resolution must be at least 1 texel, got {map_resolution}")
    if not texels_per_metre > 0 or not np.isfinite(texels_per_metre):
        raise ValueError(f"texels_per_metre must be positive and finite, got {texels_per_metre}")
    return map_resolution / texels_per_metre


def directional_footprint(light_rot: np.ndarray) -> Footprint:
    """Footprint function of a directional light: world points -> light-space (x, y).

    Parameters
    ----------
    light_rot : (3, 3) array
        Rotation whose rows are the light-space x, y and z axes in world coordinates (z points
        towards the light, so x and y span the map plane).

    Returns
    -------
    callable
        ``points (N, 3) -> (N, 2)``: the points' coordinates along the light's x and y axes.
    """
    rot = np.asarray(light_rot, dtype=np.float64)
    if rot.shape != (3, 3) or not np.all(np.isfinite(rot)):
        raise ValueError(f"light_rot must be a finite 3x3 matrix, got shape {rot.shape}")
    if not np.allclose(rot @ rot.T, np.eye(3), atol=1e-6):
        raise ValueError("light_rot must be a rotation (orthonormal rows)")
    plane = rot[:2].T.copy()

    def footprint(points: np.ndarray) -> np.ndarray:
        return np.asarray(points, dtype=np.float64) @ plane

    return footprint


def object_summaries(
    points: Sequence[np.ndarray], footprint: Footprint
) -> tuple[np.ndarray, np.ndarray]:
    """Each object's light-space footprint rectangle (n, 4) and world bounding-box centre (n, 3).

    The footprint function is called on many objects' points at once, so it must treat every row
    independently (true of projections and of angles seen from a light).
    """
    n = len(points)
    rects = np.empty((n, 4))
    centres = np.empty((n, 3))
    arrays = []
    for i, p in enumerate(points):
        a = np.asarray(p, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] != 3 or a.shape[0] == 0:
            raise ValueError(
                f"object {i}: points must have shape (N, 3) with N >= 1, got {a.shape}"
            )
        if not np.all(np.isfinite(a)):
            raise ValueError(f"object {i}: points must be finite")
        arrays.append(a)

    start = 0
    while start < n:
        stop, total = start, 0
        while stop < n and (stop == start or total + len(arrays[stop]) <= FOOTPRINT_CHUNK_POINTS):
            total += len(arrays[stop])
            stop += 1
        chunk = np.concatenate(arrays[start:stop])
        offsets = np.cumsum([0] + [len(a) for a in arrays[start : stop - 1]])
        fp = np.asarray(footprint(chunk), dtype=np.float64)
        if fp.shape != (len(chunk), 2):
            raise ValueError(f"footprint must return shape ({len(chunk)}, 2), got {fp.shape}")
        rects[start:stop] = _reduce_footprint(fp, offsets)
        if not np.all(np.isfinite(rects[start:stop])) or np.isinf(fp).any():
            raise ValueError(f"footprint of objects {start}..{stop - 1} is not finite")
        lo = np.minimum.reduceat(chunk, offsets, axis=0)
        hi = np.maximum.reduceat(chunk, offsets, axis=0)
        centres[start:stop] = 0.5 * (lo + hi)
        start = stop
    return rects, centres


def _reduce_footprint(fp: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Each object's rectangle (xmin, ymin, xmax, ymax) of footprint points ``fp`` split at
    ``offsets``. A NaN point has no footprint (a caster's vertex at a point light) and is
    skipped; an object with no other point stays NaN."""
    if not np.isnan(fp).any():
        return np.concatenate([np.minimum.reduceat(fp, offsets, axis=0),
                               np.maximum.reduceat(fp, offsets, axis=0)], axis=1)
    return np.concatenate([np.fmin.reduceat(fp, offsets, axis=0),
                           np.fmax.reduceat(fp, offsets, axis=0)], axis=1)


def union_rect(rects: np.ndarray) -> np.ndarray:
    """Smallest rectangle (xmin, ymin, xmax, ymax) containing all of ``rects`` (m, 4), m >= 1."""
    return np.concatenate([rects[:, :2].min(axis=0), rects[:, 2:].max(axis=0)])


def rect_extent(rect: np.ndarray) -> float:
    """Larger side of a footprint rectangle (xmin, ymin, xmax, ymax)."""
    return float(max(rect[2] - rect[0], rect[3] - rect[1]))


def triangles_meet_rects(triangles: np.ndarray, rects: np.ndarray) -> np.ndarray:
    """(T, K) whether each footprint triangle ((T, 3, 2) corners) meets each rectangle ((K, 4)
    as xmin, ymin, xmax, ymax): the separating-axis test, on the rectangle's two axes and the
    triangle's three edge normals."""
    t = np.asarray(triangles, np.float64)[:, None]          # (T, 1, 3, 2)
    r = np.asarray(rects, np.float64)[None]                 # (1, K, 4)
    meet = ((t[..., 0].min(axis=2) <= r[..., 2]) & (t[..., 0].max(axis=2) >= r[..., 0])
            & (t[..., 1].min(axis=2) <= r[..., 3]) & (t[..., 1].max(axis=2) >= r[..., 1]))
    box = np.stack([r[..., [0, 1]], r[..., [2, 1]], r[..., [2, 3]], r[..., [0, 3]]], axis=2)
    for e in range(3):
        edge = t[:, :, (e + 1) % 3] - t[:, :, e]             # (T, 1, 2)
        normal = np.stack([-edge[..., 1], edge[..., 0]], axis=-1)
        tri = np.einsum("tkcd,tkd->tkc", np.broadcast_to(t, (*meet.shape, 3, 2)), normal)
        rec = np.einsum("tkcd,tkd->tkc", np.broadcast_to(box, (*meet.shape, 4, 2)),
                        np.broadcast_to(normal, (*meet.shape, 2)))
        meet &= (tri.min(axis=2) <= rec.max(axis=2)) & (tri.max(axis=2) >= rec.min(axis=2))
    return meet


def split_wide(corners: np.ndarray, faces: np.ndarray, footprint: Footprint,
               max_extent: float) -> list[np.ndarray]:
    """Split one part's ``faces`` (their corners: (F, 3, 3)) into pieces whose footprints are
    at most ``max_extent`` wide, or hold one face: a recursive median split of the faces'
    footprint centres along the piece's wider side. A part larger than one clump map can hold at
    the density target (a level's ground, a long wall) is then clumped piece by piece.
    Returns the pieces' faces, each ascending, in a fixed order."""
    fp = np.asarray(footprint(corners.reshape(-1, 3)), np.float64).reshape(-1, 3, 2)
    if np.isnan(fp).any():  # a corner at a point light has no footprint: the others span it
        lo, hi = np.fmin.reduce(fp, axis=1), np.fmax.reduce(fp, axis=1)
    else:
        lo, hi = fp.min(axis=1), fp.max(axis=1)
    centre = (lo + hi) / 2
    pieces = []
    stack = [np.arange(len(faces))]
    while stack:
        idx = stack.pop()
        size = hi[idx].max(axis=0) - lo[idx].min(axis=0)
        if len(idx) == 1 or size.max() <= max_extent:
            pieces.append(np.sort(faces[idx]))
            continue
        axis = int(np.argmax(size))
        order = idx[np.argsort(centre[idx, axis], kind="stable")]
        half = len(order) // 2
        stack += [order[half:], order[:half]]
    return pieces


def split_world(idx: np.ndarray, centres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split ascending indices ``idx`` (len >= 2) at the median centre along the widest axis.

    The axis is the one of largest spread of the object centres among world x, y and z. The sort
    is stable over ascending indices, so tied centres (objects stacked in one place) split by
    index and the recursion always terminates.
    """
    c = centres[idx]
    axis = int(np.argmax(np.ptp(c, axis=0)))
    order = np.argsort(c[:, axis], kind="stable")
    half = len(idx) // 2
    return np.sort(idx[order[:half]]), np.sort(idx[order[half:]])


def split_light(idx: np.ndarray, rects: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Split ascending indices ``idx`` (len >= 2) where the children's footprints overlap least.

    For each map-plane axis the objects are sorted by footprint centre, and every split position
    that leaves each child at least ``LIGHT_SPLIT_MIN_FRACTION`` of the objects is costed from
    prefix and suffix bounding rectangles (running min/max, O(m) after the sort):
    ``overlap area + LIGHT_SPLIT_AREA_WEIGHT * (left area + right area)``. Among splits within
    ``SPLIT_TIE_RTOL`` of the cheapest, the most balanced wins (then axis x, then the smaller left
    side), which keeps the split deterministic and the recursion shallow.
    """
    r = rects[idx]
    m = len(idx)
    k = np.arange(1, m)  # number of objects on the left
    costs = np.empty((2, m - 1))
    orders = []
    for axis in (0, 1):
        order = np.argsort(r[:, axis] + r[:, axis + 2], kind="stable")
        s = r[order]
        pre_lo = np.minimum.accumulate(s[:, :2], axis=0)[:-1]
        pre_hi = np.maximum.accumulate(s[:, 2:], axis=0)[:-1]
        suf_lo = np.minimum.accumulate(s[::-1, :2], axis=0)[::-1][1:]
        suf_hi = np.maximum.accumulate(s[::-1, 2:], axis=0)[::-1][1:]
        inter = np.clip(np.minimum(pre_hi, suf_hi) - np.maximum(pre_lo, suf_lo), 0.0, None)
        overlap = inter[:, 0] * inter[:, 1]
        area = np.prod(pre_hi - pre_lo, axis=1) + np.prod(suf_hi - suf_lo, axis=1)
        costs[axis] = overlap + LIGHT_SPLIT_AREA_WEIGHT * area
        orders.append(order)
    smallest = max(1, int(np.ceil(LIGHT_SPLIT_MIN_FRACTION * m - 1e-9)))
    costs[:, (k < smallest) | (k > m - smallest)] = np.inf
    tol = SPLIT_TIE_RTOL * max(rect_extent(union_rect(r)) ** 2, np.finfo(np.float64).tiny)
    near_best = costs <= costs.min() + tol
    imbalance = np.where(near_best, np.abs(2 * k - m), np.iinfo(np.int64).max)
    axis, pos = np.unravel_index(int(np.argmin(imbalance)), imbalance.shape)
    order = orders[axis]
    cut = int(k[pos])
    return np.sort(idx[order[:cut]]), np.sort(idx[order[cut:]])


def _check_clump_args(strategy: str, max_extent: float, count: int | None,
                      limit: int | None) -> None:
    """ValueError where :func:`make_clumps`'s arguments make no clumps."""
    if strategy not in STRATEGIES:
        raise ValueError(f"unknown clumping strategy {strategy!r}; valid: {', '.join(STRATEGIES)}")
    if count is not None and count < 1:
        raise ValueError(f"count must be at least 1, got {count}")
    if limit is not None and limit < 1:
        raise ValueError(f"limit must be at least 1, got {limit}")
    if count is None and (np.isnan(max_extent) or max_extent <= 0):
        raise ValueError(f"max_extent must be positive, got {max_extent}")


def make_clumps(
    points: Sequence[np.ndarray],
    footprint: Footprint,
    strategy: str,
    max_extent: float,
    count: int | None = None,
    limit: int | None = None,
    summaries: tuple[np.ndarray, np.ndarray] | None = None,
) -> list[Clump]:
    """Group static objects into clumps that each get one shadow map.

    Parameters
    ----------
    points : sequence of (Ni, 3) arrays
        World-space points of each static object (vertices, or a subset or hull of them).
    footprint : callable
        ``points (N, 3) -> (N, 2)`` map-plane coordinates of the light, applied row by row; see
        :func:`directional_footprint`. For spot and point lights any 2-D light-space mapping
        (e.g. angles seen from the light) works, with ``max_extent`` in the same units.
    strategy : {"world", "light"}
        ``"world"``: median split along the widest axis of the object centres. ``"light"``:
        split that minimises the overlap of the children's footprints in the map plane.
    max_extent : float
        Largest footprint side one map may cover, e.g. ``max_extent_for_density(1024, 48)``. The
        clump with the largest footprint is split until every clump fits or is a single object.
        Ignored when ``count`` is given.
    count : int, optional
        Split largest-first until exactly this many clumps exist (or one per object, if there are
        fewer objects), regardless of ``max_extent``.
    limit : int, optional
        With ``max_extent`` (ignored with ``count``): stop splitting once this many clumps
        exist, so that a caller who can afford far fewer maps learns that the target is out of
        reach without paying for every split it would take (the clumps returned then need not
        fit ``max_extent``).
    summaries : (rects, centres), optional
        :func:`object_summaries` of ``points``, for a caller that clumps them several times.

    Returns
    -------
    list of Clump
        Disjoint clumps covering every object once, ordered by their smallest member.
    """
    _check_clump_args(strategy, max_extent, count, limit)
    n = len(points)
    if n == 0:
        return []
    rects, centres = summaries if summaries is not None else object_summaries(points, footprint)

    def split(idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        if strategy == "world":
            return split_world(idx, centres)
        return split_light(idx, rects)

    target = None if count is None else min(count, n)
    done: list[tuple[np.ndarray, np.ndarray]] = []
    # Max-heap on footprint extent; the sequence number breaks ties first-in-first-out, so the
    # result does not depend on comparing arrays.
    heap: list[tuple[float, int, np.ndarray, np.ndarray]] = []
    seq = 0

    def push(idx: np.ndarray) -> None:
        nonlocal seq
        rect = union_rect(rects[idx])
        ext = rect_extent(rect)
        if len(idx) == 1 or (target is None and ext <= max_extent):
            done.append((idx, rect))
        else:
            heapq.heappush(heap, (-ext, seq, idx, rect))
            seq += 1

    push(np.arange(n))
    cap = target if target is not None else limit
    while heap and (cap is None or len(heap) + len(done) < cap):
        _, _, idx, _ = heapq.heappop(heap)
        left, right = split(idx)
        push(left)
        push(right)
    done.extend((idx, rect) for _, _, idx, rect in heap)
    done.sort(key=lambda item: int(item[0][0]))
    return [Clump(members=tuple(int(i) for i in idx), rect=rect) for idx, rect in done]


def footprint_overlap(clumps: Sequence[Clump]) -> float:
    """Total pairwise overlap area of the clumps' footprints divided by their total area.

    0 means no two maps cover the same part of the map plane; the ratio can exceed 1 when many
    footprints pile onto one place. Clumps with zero total area (all degenerate) give 0.

    A sweep over x keeps the work proportional to the pairs that overlap in x rather than to all
    pairs, so thousands of clumps cost little.
    """
    if len(clumps) < 2:
        return 0.0
    r = np.array([c.rect for c in clumps], dtype=np.float64)
    total = float(np.sum((r[:, 2] - r[:, 0]) * (r[:, 3] - r[:, 1])))
    if total <= 0.0:
        return 0.0
    r = r[np.argsort(r[:, 0], kind="stable")]
    # Pairs (i, j > i) whose x ranges overlap: j runs from i + 1 up to the first xmin >= xmax_i.
    first = np.arange(1, len(r))
    counts = np.maximum(np.searchsorted(r[:, 0], r[:-1, 2], side="left") - first, 0)
    ends = np.cumsum(counts)
    overlap = 0.0
    start = 0
    while start < len(counts):
        # Blocks of rows holding about OVERLAP_PAIRS_PER_BLOCK pairs bound the temporary memory.
        done = ends[start - 1] if start else 0
        stop = max(start + 1, int(np.searchsorted(ends, done + OVERLAP_PAIRS_PER_BLOCK, "right")))
        c = counts[start:stop]
        ii = np.repeat(np.arange(start, stop), c)
        jj = first[ii] + np.arange(len(ii)) - np.repeat(np.cumsum(c) - c, c)
        a, b = r[ii], r[jj]
        w = np.minimum(a[:, 2], b[:, 2]) - np.maximum(a[:, 0], b[:, 0])
        h = np.minimum(a[:, 3], b[:, 3]) - np.maximum(a[:, 1], b[:, 1])
        overlap += float(np.sum(np.clip(w, 0.0, None) * np.clip(h, 0.0, None)))
        start = stop
    return overlap / total
