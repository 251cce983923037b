"""The crowd planner's grouping (game/shadows/crowd.py ``group``) in time and memory near
linear in the characters, with the same plans as the quadratic original kept below as the
reference: random crowds of 10 to 160 walkers, with ties, caps on the maps and merging on and
off, must give equal maps, member for member and bit for bit."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import dataclass

import numpy as np
import pytest

from game.shadows import crowd
from tests.helpers import ROOT


# -- the reference: the original planner, quadratic (an n-by-n table per merge) -----------------
@dataclass
class Group:
    members: list[int]
    box: list[float]
    texel: float | None
    size: int


def union(a: Group, b: Group) -> list[float]:
    return [min(a.box[0], b.box[0]), min(a.box[1], b.box[1]),
            max(a.box[2], b.box[2]), max(a.box[3], b.box[3])]


def old_group(sizes: list[int], rects: np.ndarray | None, max_resolution: int,
              max_maps: int | None = None, merge: bool = True) -> list[crowd.CrowdMap]:
    """Maps for characters of these sizes: one each, merged in pairs where the cost model says
    one map is cheaper (``merge``), and merged further while there are more than ``max_maps``
    (those groups get coarser texels: degrade, never drop a shadow).

    ``rects`` (n, 4) are the light-space squares of the bounding spheres (directional light);
    without them, maps are only merged to meet ``max_maps``, round robin.
    """
    n = len(sizes)
    limit = n if max_maps is None else max(1, max_maps)
    if rects is None:
        if n <= limit:
            return [crowd.CrowdMap([i], sizes[i]) for i in range(n)]
        return [crowd.CrowdMap(list(range(g, n, limit)), max_resolution) for g in range(limit)]
    half = 0.5 * (rects[:, 2:] - rects[:, :2]).max(axis=1)
    texel = 2.0 * half / (np.asarray(sizes, float) - crowd.SPARE_TEXELS)  # as fit_directional's
    boxes, texels = rects.tolist(), texel.tolist()
    groups = {k: Group([k], boxes[k], texels[k], sizes[k]) for k in range(n)}
    if merge and n > 1:
        old_merge_by_cost(groups, rects, texel, np.asarray(sizes, float), max_resolution)
    while len(groups) > limit:
        old_merge_nearest(groups, max_resolution)
    out = []
    for g in groups.values():
        x0, y0, x1, y1 = g.box
        square = (0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * max(x1 - x0, y1 - y0))
        out.append(crowd.CrowdMap(sorted(g.members), g.size, square,
                                  None if len(g.members) == 1 else g.texel))
    return out


def old_merge_by_cost(groups: dict[int, Group], rects: np.ndarray, texel: np.ndarray,
                   size: np.ndarray, max_resolution: int) -> None:
    """Merge pairs, nearest first, where one map at the finer texel costs less than two;
    ``texel`` and ``size`` are the single maps' (the groups as they start)."""
    centre = 0.5 * (rects[:, :2] + rects[:, 2:])
    reach = 0.5 * (rects[:, 2:] - rects[:, :2]).max(axis=1)
    # Candidate pairs: footprints at most one footprint apart, and worth one map as they are
    # (two single maps): a group's union only grows, so few pairs that fail here would pass.
    i, j, gap = old_near_pairs(centre, reach)
    n = len(rects)
    side = (np.maximum(rects[i, 2:], rects[j, 2:]) - np.minimum(rects[i, :2], rects[j, :2])).max(1)
    need = side / np.minimum(texel[i], texel[j]) + crowd.SPARE_TEXELS
    merged = 2.0 ** np.ceil(np.log2(np.maximum(need, 1.0)))
    keep = (need <= max_resolution) & (
        merged ** 2 < size[i] ** 2 + size[j] ** 2 + crowd.MAP_COST_TEXELS)
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
        box = union(ga, gb)
        t = min(ga.texel, gb.texel)
        need = max(box[2] - box[0], box[3] - box[1]) / t + crowd.SPARE_TEXELS
        if need > max_resolution:
            continue
        size = crowd.pow2_at_least(need, 1, max_resolution)
        if size * size >= ga.size * ga.size + gb.size * gb.size + crowd.MAP_COST_TEXELS:
            continue
        owner[rb] = ra
        groups[ra] = Group(ga.members + gb.members, box, t, size)
        del groups[rb]


def old_near_pairs(centre: np.ndarray, reach: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pairs i < j of footprints (centres, half sides) less than twice the larger one's
    half side apart, and their gaps. A sweep along x: pairs further apart along x than any pair
    may be near are never formed, so a crowd spread over a town costs no n-by-n table."""
    n = len(centre)
    order = np.argsort(centre[:, 0], kind="stable")
    x = centre[order, 0]
    window = 4.0 * float(reach.max()) if n else 0.0  # the most two near footprints lie apart
    count = np.searchsorted(x, x + window, side="right") - np.arange(n) - 1
    a = np.repeat(np.arange(n), count)
    b = a + 1 + np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    p, q = order[a], order[b]
    gap = np.hypot(*(centre[p] - centre[q]).T) - reach[p] - reach[q]
    near = gap < 2.0 * np.maximum(reach[p], reach[q])
    return np.minimum(p, q)[near], np.maximum(p, q)[near], gap[near]


def old_merge_nearest(groups: dict[int, Group], max_resolution: int) -> None:
    """Merge the two groups whose union is smallest (too many maps for the records)."""
    keys = list(groups)
    boxes = np.array([groups[k].box for k in keys])
    lo = np.minimum(boxes[:, None, :2], boxes[None, :, :2])
    hi = np.maximum(boxes[:, None, 2:], boxes[None, :, 2:])
    side = (hi - lo).max(axis=2)
    np.fill_diagonal(side, np.inf)
    a, b = np.unravel_index(int(np.argmin(side)), side.shape)
    ga, gb = groups[keys[a]], groups[keys[b]]
    box = union(ga, gb)
    texel = None if ga.texel is None or gb.texel is None else min(ga.texel, gb.texel)
    need = ((max(box[2] - box[0], box[3] - box[1]) / texel + crowd.SPARE_TEXELS) if texel
            else math.inf)
    if need > max_resolution:
        texel = None  # coarser than asked: fitted to the square at the largest size
    size = max_resolution if texel is None else crowd.pow2_at_least(need, 1, max_resolution)
    groups[keys[a]] = Group(ga.members + gb.members, box, texel, size)
    del groups[keys[b]]



# -- the checks ----------------------------------------------------------------------------------
def _crowd(rng, n: int, ties: bool):
    """``n`` walkers' light-space squares in a town-like spread, and their map sizes."""
    span = rng.uniform(5.0, 200.0)
    xy = rng.uniform(-span, span, (n, 2))
    if ties:  # walkers on a grid of whole metres with equal radii: many equal distances
        xy = np.round(xy / 4.0)
    r = np.full((n, 1), 0.5) if ties else rng.uniform(0.3, 1.5, (n, 1))
    rects = np.concatenate([xy - r, xy + r], axis=1)
    sizes = [int(s) for s in rng.choice([32, 64, 128, 256, 512], n)]
    return sizes, rects


def _same(a: list[crowd.CrowdMap], b: list[crowd.CrowdMap]) -> bool:
    return len(a) == len(b) and all(x == y for x, y in zip(a, b, strict=True))


@pytest.mark.parametrize("seed", range(12))
def test_group_gives_the_plans_of_the_quadratic_original(seed):
    rng = np.random.default_rng(seed)
    # The reference merges down to the map cap by an n-by-n table per merge: past 160
    # walkers it takes most of a second per plan, on the same code paths.
    n = int(rng.integers(10, 161))
    sizes, rects = _crowd(rng, n, ties=seed % 3 == 0)
    for max_maps in (None, int(rng.integers(1, 9)), max(1, n // 3), n - 1):
        for merge in (True, False):
            for max_resolution in (512, 2048):
                new = crowd.group(sizes, rects, max_resolution, max_maps, merge)
                old = old_group(sizes, rects, max_resolution, max_maps, merge)
                assert _same(new, old), (seed, n, max_maps, merge, max_resolution)


@pytest.mark.parametrize("seed", range(6))
def test_near_pairs_are_the_swept_pairs(seed):
    rng = np.random.default_rng(100 + seed)
    n = int(rng.integers(2, 400))
    _, rects = _crowd(rng, n, ties=seed % 2 == 0)
    centre = 0.5 * (rects[:, :2] + rects[:, 2:])
    reach = 0.5 * (rects[:, 2:] - rects[:, :2]).max(axis=1)
    new = crowd.near_pairs(centre, reach)
    old = old_near_pairs(centre, reach)
    key_new, key_old = np.lexsort(new[::-1]), np.lexsort(old[::-1])
    for a, b in zip(new, old, strict=True):
        assert np.array_equal(a[key_new], b[key_old])


TOWN_OF_WALKERS = """
import json, sys, time
import numpy as np
from game.shadows import crowd
from tests.helpers import ROOT

def high_water():  # the most memory this process has held so far, in bytes
    with open("/proc/self/status") as status:
        line = next(x for x in status if x.startswith("VmHWM:"))
    return int(line.split()[1]) * 1024

rng = np.random.default_rng(7)
n = 20_000
street = rng.integers(0, 4, n)
xy = np.stack([rng.uniform(-100, 100, n), street * 25.0 + rng.uniform(-4, 4, n)], axis=1)
rects = np.concatenate([xy - 0.5, xy + 0.5], axis=1)
sizes = [int(s) for s in rng.choice([32, 64, 128], n)]
before = high_water()
start = time.perf_counter()
maps = crowd.group(sizes, rects, 512, 256)
took = time.perf_counter() - start
print(json.dumps({"n": n, "took": took, "grew": high_water() - before, "maps": len(maps),
                  "members": sorted(m for g in maps for m in g.members) == list(range(n))}))
"""


def test_a_town_of_walkers_groups_in_near_linear_time_and_memory():
    """20,000 walkers in a few streets: the original built an n-by-n table (867 MiB of pairs,
    then one per merge down to the map records); this must take seconds and tens of MiB.

    Measured in a fresh process, by how far the call raises its memory's high-water mark:
    tracing every allocation instead would make the call five times slower."""
    result = subprocess.run([sys.executable, "-c", TOWN_OF_WALKERS], cwd=ROOT,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    seen = json.loads(result.stdout)
    assert seen["maps"] <= 256 and seen["members"]
    assert seen["took"] < 60.0, seen
    assert seen["grew"] < 400 * 2**20, seen["grew"] / 2**20
