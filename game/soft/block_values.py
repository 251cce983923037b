"""The window's raster soft shadows, one value per block of the frame: what a block's points agree
on, whether its pixels interpolate them or look the visibility up each, and the runs of blocks
the composite draws (game/soft/direct.py puts them to use).

1. **Values** (:func:`block_values`): a block whose 3 x 3 neighbourhood of points agrees on one
   visibility takes that value; one whose points all show geometry and differ by at most
   :data:`TOLERANCE` (a smooth stretch of a wide penumbra) interpolates them bilinearly; the
   others (the penumbrae's edges, depth edges, a point in the sky beside geometry) look it up at
   each of their pixels. Blocks in the umbra (agreed visibility 0) gain nothing.
2. **Runs** (:func:`block_runs`): blocks in a row that share a value join into one run, and runs
   with the same columns and value in consecutive rows into one rectangle of the frame.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from game.soft.upsample import window_extremes

LOOKUP = -1.0        # a block's value where each pixel looks the visibility up
SKIP = -2.0          # a block the linear light adds nothing to (sky, umbra): not drawn
INTERPOLATE = -3.0   # a block that interpolates its neighbourhood's points
SKY = -4.0           # a block whose point is in the sky: the shading pass marks it if covered
CACHED = -5.0        # a block that looks up, whose pixels' visibility a still view kept
# A still view refines what it kept with maps from other points of the segment: a block that
# adds them to its pixels' kept means, and one that starts its means with them.
REFINE_ADD = -6.0
REFINE_START = -7.0
NEIGHBOURS = 3       # blocks per side of the neighbourhood whose points must agree
# The most the points of a neighbourhood may differ by for its block to interpolate them: the
# error an interpolated pixel can carry where the visibility bends between points.
TOLERANCE = 0.3


@dataclass
class Runs:
    """The composite's rectangles: vertices (n, 3) of x, y (pixels from the frame's bottom
    left) and visibility, six per run; ``flat`` runs carry their blocks' value (or
    :data:`INTERPOLATE`), ``lookup`` runs :data:`LOOKUP`. ``blocks`` counts the blocks of
    each class. ``points`` is the points' visibility texture, one texel per block, which the
    interpolating runs read; ``point_at`` the block's side and the pixel of the block each
    point lies on."""

    flat: np.ndarray
    lookup: np.ndarray
    blocks: dict
    points: object = None
    point_at: tuple[float, float] = (1.0, 0.0)
    history: object = None   # what a still view kept (:data:`CACHED` runs read it)


def block_values(visibility: np.ndarray, mixed: np.ndarray,
                 tolerance: float = TOLERANCE) -> np.ndarray:
    """Each block's value, (h, w) in the same rows as the inputs: the visibility its
    neighbourhood's points agree on, :data:`INTERPOLATE` where they all show geometry and
    differ by at most ``tolerance``, :data:`LOOKUP` where they differ more or the block's
    coverage is ``mixed``, :data:`SKIP` in the sky and where they agree on 0.

    ``visibility`` is the points', NaN where a point shows no geometry."""
    r = NEIGHBOURS // 2
    least, most = window_extremes(visibility, r, r)
    # Any point in the sky around the block (beyond the frame there is none).
    some_sky = window_extremes(np.isnan(visibility).astype(np.float32), r, r)[1] > 0.0
    smooth = ~some_sky & (most - least <= tolerance)
    values = np.where(least == most, least,
                      np.where(smooth, INTERPOLATE, LOOKUP)).astype(np.float32)
    values[values == 0.0] = SKIP
    values[np.isnan(visibility)] = SKIP   # the point in the sky, and none of the block covered
    values[mixed] = LOOKUP
    return values


def block_runs(values: np.ndarray, divisor: int, size: tuple[int, int]) -> Runs:
    """Join the blocks of ``values`` (GL rows: row 0 at the bottom) into runs along their rows
    and make their rectangles' vertices, clipped to the frame of ``size``."""
    h, w = values.shape
    starts = np.ones((h, w), bool)
    starts[:, 1:] = values[:, 1:] != values[:, :-1]
    rows, cols = np.nonzero(starts)
    ends = np.empty_like(cols)
    ends[:-1] = np.where(rows[1:] == rows[:-1], cols[1:], w)
    if len(ends):
        ends[-1] = w
    value = values[rows, cols]
    drawn = value != SKIP
    rows, cols, ends, value = rows[drawn], cols[drawn], ends[drawn], value[drawn]
    first, last, cols, ends, value = _stacked(rows, cols, ends, value)
    x0 = cols * divisor
    x1 = np.minimum(ends * divisor, size[0])
    y0 = first * divisor
    y1 = np.minimum((last + 1) * divisor, size[1])
    corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y0), (x1, y1), (x0, y1)]
    vertices = np.stack([np.stack([x, y, value], axis=1) for x, y in corners], axis=1)
    vertices = vertices.reshape(-1, 3).astype(np.float32)
    per_vertex = np.repeat(value, 6)
    counts = {"flat": int(np.sum(values >= 0.0)),
              "interpolated": int(np.sum(values == INTERPOLATE)),
              "lookup": int(np.sum(values == LOOKUP)), "skipped": int(np.sum(values == SKIP)),
              "cached": int(np.sum(values == CACHED))}
    lookup = per_vertex == LOOKUP
    return Runs(flat=vertices[~lookup], lookup=vertices[lookup], blocks=counts)


def _stacked(rows: np.ndarray, cols: np.ndarray, ends: np.ndarray, value: np.ndarray) -> tuple:
    """Runs of consecutive rows with the same columns and value joined into one rectangle:
    llvmpipe sets up and bins every triangle, and a frame's runs are many and thin. Returns
    each rectangle's first and last row, its columns and its value."""
    if not len(rows):   # nothing drawn: a view of the sky, or all in the umbra
        return rows, rows, cols, ends, value
    order = np.lexsort((rows, value, ends, cols))
    rows, cols, ends, value = rows[order], cols[order], ends[order], value[order]
    starts = np.ones(len(rows), bool)
    starts[1:] = ((cols[1:] != cols[:-1]) | (ends[1:] != ends[:-1])
                  | (value[1:] != value[:-1]) | (rows[1:] != rows[:-1] + 1))
    begin = np.flatnonzero(starts)
    finish = np.append(begin[1:], len(rows)) - 1
    return rows[begin], rows[finish], cols[begin], ends[begin], value[begin]


# The values' names in the shaders (soft_blocks.glsl).
BLOCK_DEFINES = {"BLOCK_LOOKUP": LOOKUP, "BLOCK_SKIP": SKIP, "BLOCK_INTERPOLATE": INTERPOLATE,
                 "BLOCK_SKY": SKY, "BLOCK_CACHED": CACHED, "BLOCK_REFINE_ADD": REFINE_ADD,
                 "BLOCK_REFINE_START": REFINE_START}
