"""Depth bounds of a depth array's cached maps: per block of texels, how near and far they lie.

Why: on a CPU rasteriser a shadow lookup costs mostly its memory traffic. A fragment reads one
texel, and neighbouring fragments read texels far apart wherever the map's texels are finer than
the screen's pixels, as a tight map's are: every read is a cache miss. A block's bounds answer
most fragments without the texel: a fragment nearer the light than the bounds allow at the
texels its lookup would read is lit, one farther than they allow is in shadow. So the answer is
exact, and the bounds, 1 / (:data:`BLOCK` ** 2) of the texels, stay in the cache. Only fragments
whose depth lies within their block's bounds read the texel itself.

A block's bounds take one of two forms (shaders/depth_bounds.glsl): its nearest and farthest
depth, or a plane through its depths and how far they lie from it. The plane settles a caster's
own sloped surface, whose fragments lie only the bias nearer the light than its texels, but
within its nearest and farthest; near a shadow's edge the nearest and farthest are kept.

Bounds are made when a map is drawn into the array and kept while the map is: for the maps that
are drawn once and cached (static clumps), never for those drawn every frame, where making them
would cost a pass over the texels per frame.

The array of bounds is RG32UI, one texel per block, layer for layer with the depth array; a
compute pass (shaders/depth_bounds.comp) reads the depth texels through a sampler of its own
that does not compare.
"""

from __future__ import annotations

import moderngl

from game.gpu import glsl, resources

BLOCK = 16          # depth texels per side of a block
TEXEL_BYTES = 8     # RG32UI: a block's bounds in either form
LOCAL_SIZE = 8      # shaders/depth_bounds.comp's work group side


def side(resolution: int) -> int:
    """Blocks per side of a layer of ``resolution`` depth texels."""
    return max(1, resolution // BLOCK)


def layer_bytes(resolution: int) -> int:
    """The bytes of one layer's bounds."""
    return TEXEL_BYTES * side(resolution) ** 2


def holds(origin: tuple[int, int], side: int) -> bool:
    """Whether a map's square (its first texel and side) is made of whole blocks."""
    return side >= BLOCK and side % BLOCK == 0 and origin[0] % BLOCK == 0 \
        and origin[1] % BLOCK == 0


class DepthBounds:
    """The bounds of a ``resolution`` x ``resolution`` x ``layers`` depth array. Owns its
    texture array, its compute program and the sampler that reads depth without comparing."""

    def __init__(self, ctx, resolution: int, layers: int):
        self.ctx = ctx
        self.resolution = resolution
        self.side = side(resolution)
        self.layers = layers
        self.texture = ctx.texture_array((self.side, self.side, layers), 2, dtype="u4")
        self.texture.filter = (moderngl.NEAREST, moderngl.NEAREST)
        self.program = ctx.compute_shader(glsl.build("depth_bounds.comp", {"BOUNDS_BLOCK": BLOCK}))
        self.sampler = ctx.sampler(filter=(moderngl.NEAREST, moderngl.NEAREST), compare_func="")

    @property
    def bytes(self) -> int:
        return layer_bytes(self.resolution) * self.layers

    def build(self, depth, unit: int, squares: list[tuple[int, int, int, int]]) -> None:
        """Make the bounds of the ``squares`` (layer, x, y, side in depth texels, each made of
        whole blocks, :func:`holds`) of ``depth`` (a DepthArray), read through texture unit
        ``unit``; the shading pass may read them after this returns."""
        if not squares:
            return
        prog = self.program
        depth.bind(unit)
        self.sampler.use(unit)
        prog["u_depth"].value = unit
        self.texture.bind_to_image(0, read=False, write=True)
        prog["u_bounds"].value = 0
        for layer, x, y, side in squares:
            blocks = side // BLOCK
            prog["u_square"].value = (x // BLOCK, y // BLOCK, layer)
            prog["u_side"].value = blocks
            groups = -(-blocks // LOCAL_SIZE)
            prog.run(groups, groups, 1)
        # The depth array's own comparing state again for whoever samples it next.
        self.sampler.clear(unit)
        self.ctx.memory_barrier(moderngl.TEXTURE_FETCH_BARRIER_BIT
                                | moderngl.SHADER_IMAGE_ACCESS_BARRIER_BIT)

    def bind(self, unit: int) -> None:
        self.texture.use(unit)

    def gl_objects(self) -> int:
        """The texture, the program and its attached shader, the sampler."""
        if self.texture is None:
            return 0
        return 3 + resources.attached_shaders([self.program])

    def release(self) -> None:
        for obj in (self.sampler, self.program, self.texture):
            if obj is not None:
                obj.release()
        self.sampler = self.program = self.texture = None
