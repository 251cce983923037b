"""The character maps of a frame around a spot or point lamp, where walkers outnumber the map
records: runs of neighbours seen from the lamp.

A map around a lamp is one frustum from it, so walkers that share one must be neighbours seen
from the lamp; walkers on either side of it in one frustum are clipped away, and their shadows
with them. The walkers are ordered along a Hilbert curve over the directions they lie in and
cut into runs of near-equal length: the curve keeps neighbours on it neighbours in the plane,
and a sort each frame costs far less than merging the nearest pair again and again
(game/shadows/crowd.py, the directional light's groups).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from game.shadows.crowd import CrowdMap

CURVE_BITS = 16  # cells per side of the curve's grid, as a power of two


def hilbert_order(points: np.ndarray) -> np.ndarray:
    """The distance of each of ``points`` (n, 2) along a Hilbert curve over a grid of
    ``2**CURVE_BITS`` cells per side laid on the points' bounding square."""
    p = np.nan_to_num(np.asarray(points, float))
    side = 1 << CURVE_BITS
    lo = p.min(axis=0) if len(p) else np.zeros(2)
    span = max(float((p.max(axis=0) - lo).max()) if len(p) else 0.0, 1e-12)
    q = np.minimum(((p - lo) / span * (side - 1)).astype(np.int64), side - 1)
    x, y = q[:, 0], q[:, 1]
    d = np.zeros(len(p), np.int64)
    s = side >> 1
    while s > 0:
        rx = ((x & s) > 0).astype(np.int64)
        ry = ((y & s) > 0).astype(np.int64)
        d += s * s * ((3 * rx) ^ ry)
        # The quadrant's sub-curve turned to meet its neighbours end to end.
        turn = ry == 0
        flip = turn & (rx == 1)
        x, y = np.where(flip, side - 1 - x, x), np.where(flip, side - 1 - y, y)
        x, y = np.where(turn, y, x), np.where(turn, x, y)
        s >>= 1
    return d


def runs(sizes: list[int], directions: Callable[[], np.ndarray], max_resolution: int,
         max_maps: int) -> list[CrowdMap]:
    """Maps for walkers of these sizes around a lamp: one each, or, where there are more than
    ``max_maps``, that many runs of neighbours along the curve over ``directions()`` (n, 2:
    where each walker lies seen from the lamp; asked only then). A run of several walkers is
    fitted at ``max_resolution``, coarser than asked: degrade, never drop a shadow."""
    n = len(sizes)
    limit = max(1, max_maps)
    if n <= limit:
        return [CrowdMap([i], sizes[i]) for i in range(n)]
    order = np.argsort(hilbert_order(directions()), kind="stable")
    return [CrowdMap(sorted(run.tolist()),
                     sizes[int(run[0])] if len(run) == 1 else max_resolution)
            for run in np.array_split(order, limit)]
