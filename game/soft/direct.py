"""A raster soft method in the window: its visibility looked up in the composite pass itself.

A raster method (segment-maps, pcss) gives the same visibility every frame for the same view,
so the window neither accumulates nor filters it. Per frame:

1. **Points** (shaders/soft_subsample.frag): one G-buffer pixel per block of ``divisor`` x
   ``divisor``, always the same pixel of the block, so the maps' frusta, planned around these
   points, stay put while the view does (the statics' maps stay cached). The same pass marks
   the blocks whose coverage is mixed: some pixels geometry, some sky.
2. **The method** (game/soft/raster.py) plans its maps around the points, draws what changed
   and looks the visibility up at the points (a small pass, read back).
3. **Runs** (:func:`block_runs`, numpy): a block whose 3 x 3 neighbourhood of points agrees on
   one visibility takes that value; one whose points all show geometry and differ by at most
   :data:`TOLERANCE` (a smooth stretch of a wide penumbra) interpolates them bilinearly; the
   others (the penumbrae's edges, depth edges, mixed coverage) look it up at each of their
   pixels. Blocks in a row that share a class and a value join into one run, and runs with
   the same columns and value in consecutive rows into one rectangle of the frame.
4. **Composite** (game/soft/composite.py, ``draw_runs``): the frame's picture is copied, then
   the runs are drawn over it, the agreed ones with their value and the others with the
   method's lookup at each pixel. Runs in the sky or in the umbra (agreed visibility 0) gain
   nothing from the linear light and are not drawn.

So soft shadows cost one full-resolution pass over the blocks that change, and the per-pixel
lookup only where the shadow changes within a few blocks. A shadow narrower than the points'
spacing that falls wholly between them on a fully covered block is missed; the soft shadows
of a linear light are wide, and a thin caster against the sky is caught by the mixed
coverage.
"""

from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from game.gpu import resources
from game.gpu.fullscreen import fullscreen_pass
from game.soft.composite import LOOKUPS, SoftComposite
from game.soft.methods import TraceSettings
from game.soft.tracer import TEXTURE_UNITS, TraceResult
from game.soft.upsample import ReducedState, trace_size

LOOKUP = -1.0        # a block's value where each pixel looks the visibility up
SKIP = -2.0          # a block the linear light adds nothing to (sky, umbra): not drawn
INTERPOLATE = -3.0   # a block that interpolates its neighbourhood's points
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
    interpolating runs read; ``point_at`` the block's
    side and the pixel of the block each point lies on."""

    flat: np.ndarray
    lookup: np.ndarray
    blocks: dict
    points: object = None
    point_at: tuple[float, float] = (1.0, 0.0)


def block_values(visibility: np.ndarray, mixed: np.ndarray,
                 tolerance: float = TOLERANCE) -> np.ndarray:
    """Each block's value, (h, w) in the same rows as the inputs: the visibility its
    neighbourhood's points agree on, :data:`INTERPOLATE` where they all show geometry and
    differ by at most ``tolerance``, :data:`LOOKUP` where they differ more or the block's
    coverage is ``mixed``, :data:`SKIP` in the sky and where they agree on 0.

    ``visibility`` is the points', NaN where a point shows no geometry."""
    h, w = visibility.shape
    r = NEIGHBOURS // 2
    low = np.pad(np.where(np.isnan(visibility), np.inf, visibility), r, constant_values=np.inf)
    high = np.pad(np.where(np.isnan(visibility), -np.inf, visibility), r,
                  constant_values=-np.inf)
    least = np.full((h, w), np.inf, np.float32)
    most = np.full((h, w), -np.inf, np.float32)
    for dy in range(NEIGHBOURS):
        for dx in range(NEIGHBOURS):
            least = np.minimum(least, low[dy:dy + h, dx:dx + w])
            most = np.maximum(most, high[dy:dy + h, dx:dx + w])
    some_sky = np.zeros((h, w), bool)
    sky = np.pad(np.isnan(visibility), r, constant_values=False)   # beyond the frame: no say
    for dy in range(NEIGHBOURS):
        for dx in range(NEIGHBOURS):
            some_sky |= sky[dy:dy + h, dx:dx + w]
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
              "lookup": int(np.sum(values == LOOKUP)), "skipped": int(np.sum(values == SKIP))}
    lookup = per_vertex == LOOKUP
    return Runs(flat=vertices[~lookup], lookup=vertices[lookup], blocks=counts)


def _stacked(rows: np.ndarray, cols: np.ndarray, ends: np.ndarray, value: np.ndarray) -> tuple:
    """Runs of consecutive rows with the same columns and value joined into one rectangle:
    llvmpipe sets up and bins every triangle, and a frame's runs are many and thin. Returns
    each rectangle's first and last row, its columns and its value."""
    order = np.lexsort((rows, value, ends, cols))
    rows, cols, ends, value = rows[order], cols[order], ends[order], value[order]
    starts = np.ones(len(rows), bool)
    starts[1:] = ((cols[1:] != cols[:-1]) | (ends[1:] != ends[:-1])
                  | (value[1:] != value[:-1]) | (rows[1:] != rows[:-1] + 1))
    begin = np.flatnonzero(starts)
    finish = np.append(begin[1:], len(rows)) - 1
    return rows[begin], rows[finish], cols[begin], ends[begin], value[begin]


class DirectRaster:
    """Owns the points' program, their G-buffer (position, normal, colour) and its framebuffer,
    released by :meth:`release`; the targets are made again when the frame's size changes."""

    def __init__(self, ctx, divisor: int):
        self.ctx = ctx
        self.divisor = divisor
        self._program, self._vao = fullscreen_pass(ctx, "soft_subsample.frag")
        self.size = self.cells = None
        self._targets: list = []
        self.state: ReducedState | None = None
        self.runs: Runs | None = None

    def _resize(self, size: tuple[int, int], divisor: int) -> None:
        cells = trace_size(size, divisor)
        if (size, divisor) == (self.size, self.divisor) and self._targets:
            return
        self._release_targets()
        self.size, self.divisor, self.cells = size, divisor, cells
        ctx = self.ctx
        self.position = ctx.texture(cells, 4, dtype="f4")
        self.normal = ctx.texture(cells, 4, dtype="f4")
        self.colour = ctx.texture(cells, 4)
        self.framebuffer = ctx.framebuffer([self.position, self.normal, self.colour])
        self.points_visibility = ctx.texture(cells, 1, dtype="f4")
        self.points_visibility.repeat_x = self.points_visibility.repeat_y = False
        self._targets = [self.framebuffer, self.position, self.normal, self.colour,
                         self.points_visibility]

    def points(self, textures, size: tuple[int, int], divisor: int) -> tuple:
        """Draw the points' G-buffer from the frame's ``textures`` (position, normal, colour);
        returns it, as the raster method's trace reads it."""
        self._resize(size, divisor)
        prog = self._program
        for tex, (name, unit) in zip(textures, TEXTURE_UNITS.items(), strict=True):
            tex.use(unit)
            prog[name].value = unit
        middle = divisor // 2
        prog["u_divisor"].value = divisor
        prog["u_phase"].value = (middle, middle)
        fb = self.framebuffer
        fb.use()
        fb.viewport = (0, 0, *self.cells)
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)
        self._vao.render(moderngl.TRIANGLES, vertices=3)
        return self.position, self.normal, self.colour

    def classify(self, result: TraceResult) -> Runs:
        """The runs of this frame, from the points' traced ``result`` and their coverage."""
        w, h = self.cells
        colour = np.frombuffer(self.colour.read(), np.uint8).reshape(h, w, 4)
        vis = np.ascontiguousarray(result.visibility[::-1])
        mixed = colour[..., 0] > 0
        values = block_values(vis, mixed)
        self.points_visibility.write(np.nan_to_num(vis, nan=0.0).tobytes())
        self.runs = block_runs(values, self.divisor, self.size)
        self.runs.points = self.points_visibility
        self.runs.point_at = (float(self.divisor), float(self.divisor // 2))
        self.state = ReducedState(size=self.cells, divisor=self.divisor, traced=True, round=0,
                                  rounds=1, phase=1, phases=1, full=True)
        return self.runs

    def composite(self, composite: SoftComposite, raster, textures, settings: TraceSettings,
                  light_kind: int, soft_light: np.ndarray, radiance: np.ndarray,
                  out_visibility: bool = False) -> None:
        """The frame's picture (``textures[2]``) copied into ``composite``'s target, then this
        frame's runs drawn over it with ``raster``'s maps (or, ``out_visibility``, the
        visibility they give, to measure). ``textures`` as the composite reads them."""
        composite.prepare(self.size)
        if not out_visibility:
            composite.copy_picture(textures[2])
        method = settings.method
        composite.draw_runs(textures, self.runs, light_kind, LOOKUPS[method], raster.defines(),
                            lambda prog: raster.bind_lookup(prog, method), soft_light,
                            radiance, out_visibility)
        raster.unbind_lookup()

    def gl_objects(self) -> int:
        return 2 + resources.attached_shaders([self._program]) + len(self._targets)

    def _release_targets(self) -> None:
        resources.release_targets(self.ctx, self._targets)
        self._targets = []
        self.size = self.cells = None

    def release(self) -> None:
        self._release_targets()
        for obj in (self._vao, self._program):
            if obj is not None:
                obj.release()
        self._vao = self._program = None
