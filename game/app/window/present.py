"""The window's picture: the scene frame, scaled to the window when it was rendered smaller and
anti-aliased with FXAA (``antialias``; shaders/present.frag). FXAA works on the finished picture,
so the renderer's target, its G-buffer and every dump stay exactly as they are.

Rendering the scene below the window's resolution (``play --render-scale``) is the usual answer
to a fill-bound renderer, and Mesa llvmpipe is fill-bound: the shading pass costs about the
number of pixels. The overlay is then drawn at the window's full resolution on top.

A full-size frame, and any frame saved as a screenshot, goes through :attr:`Presenter.target`, a
window-sized colour framebuffer that can be read back (moderngl cannot read the window's own) and is
then blitted to the window; a smaller frame is otherwise drawn scaled straight into the window
(game/app/window/walkaround.py says which is cheaper when). A :class:`Presenter` owns that
framebuffer and the scaling program; the window (game/app/window/walkaround.py) owns the presenter
and releases it.
"""

from __future__ import annotations

import moderngl

from game.gpu import blocks, context
from game.gpu.fullscreen import fullscreen_pass

FRAME_UNIT = blocks.TEXTURE_UNITS["present_frame"]


class Presenter:
    """A window-sized colour target that the scene frame is copied or scaled into."""

    def __init__(self, ctx, antialias: bool = True):
        self.ctx = ctx
        self.antialias = antialias
        self.program, self.vao = fullscreen_pass(ctx, "present.frag", {"FXAA": antialias})
        self.size: tuple[int, int] | None = None
        self.texture = None
        self.target = None

    def resize(self, size: tuple[int, int]) -> None:
        if size == self.size:
            return
        self._release_target()
        self.size = size
        self.texture = self.ctx.texture(size, 4)
        self.target = self.ctx.framebuffer([self.texture])

    def show(self, frame_target, frame_texture) -> None:
        """Put the renderer's frame into :attr:`target`: a copy, or a draw (scaled, or
        anti-aliased)."""
        # A copy needs the same attachments: a target with a G-buffer is drawn instead.
        if (not self.antialias and tuple(frame_texture.size) == self.size
                and len(frame_target.color_attachments) == 1):
            self.ctx.copy_framebuffer(self.target, frame_target)
            return
        self.draw(frame_texture, self.target, self.size)

    def draw(self, frame_texture, into, size: tuple[int, int]) -> None:
        """Draw the frame over all of ``into`` (``size`` pixels), filtered linearly (and
        anti-aliased, with :attr:`antialias`)."""
        into.use()
        into.viewport = (0, 0, *size)
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)
        frame_texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        frame_texture.use(FRAME_UNIT)
        self.program["u_frame"].value = FRAME_UNIT
        self.vao.render(moderngl.TRIANGLES, vertices=3)

    def _release_target(self) -> None:
        if self.target is not None:
            self.ctx.detect_framebuffer(0).use()
            self.target.release()
            self.texture.release()
        self.target = self.texture = None

    def release(self) -> None:
        # A program still in use is only flagged for deletion, its shaders kept alive with it.
        context.unbind_program()
        self._release_target()
        self.vao.release()
        self.program.release()
