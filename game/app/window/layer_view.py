"""The overlay's viewer of the shadow-map texture array: one layer drawn as a grey image.

The depth array samples with depth compare on (game/gpu/depth_array.py); a sampler object with
compare off, bound over it, reads raw depths. The viewer owns its small colour target, program
and sampler; the overlay owns the viewer and releases it.
"""

from __future__ import annotations

import moderngl

from game.gpu import blocks, context
from game.gpu.fullscreen import fullscreen_pass

VIEW_SIZE = 256          # texels per side of the viewer's image
MAPS_UNIT = blocks.TEXTURE_UNITS["layer_view"]


class LayerViewer:
    def __init__(self, ctx):
        self.ctx = ctx
        self.program, self.vao = fullscreen_pass(ctx, "layer_view.frag")
        self.sampler = ctx.sampler(filter=(moderngl.NEAREST, moderngl.NEAREST),
                                   compare_func="", repeat_x=False, repeat_y=False)
        self.texture = ctx.texture((VIEW_SIZE, VIEW_SIZE), 4)
        self.target = ctx.framebuffer([self.texture])

    def draw(self, array, layer: int, extent: float, offset: tuple[float, float] = (0.0, 0.0)
             ) -> None:
        """Draw the square of ``layer`` at uv ``offset``, the share ``extent`` of its side,
        into :attr:`texture`."""
        ctx = self.ctx
        self.target.use()
        self.target.viewport = (0, 0, VIEW_SIZE, VIEW_SIZE)
        ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)
        array.bind(MAPS_UNIT)
        self.sampler.use(MAPS_UNIT)
        self.program["u_maps"].value = MAPS_UNIT
        self.program["u_layer"].value = int(layer)
        self.program["u_extent"].value = float(extent)
        self.program["u_offset"].value = tuple(float(v) for v in offset)
        self.vao.render(moderngl.TRIANGLES, vertices=3)
        self.sampler.clear(MAPS_UNIT)  # the shading pass samples with compare on again

    def release(self) -> None:
        context.unbind_program()  # a program in use would outlive its release
        self.ctx.detect_framebuffer(0).use()
        for obj in (self.target, self.texture, self.sampler, self.vao, self.program):
            obj.release()
