"""A depth texture array with one framebuffer per layer, made through PyOpenGL.

Why this route: moderngl 5.13 cannot create a depth texture array nor attach one layer of it to
a framebuffer. The other known route (render into an R32F colour array with MIN blending) gives
up the hardware depth test while rendering and the hardware depth compare while sampling, and
needs a colour clear per layer. Here the array is a real GL_DEPTH_COMPONENT32F array made with
glTexStorage3D; glFramebufferTextureLayer attaches each layer to its own framebuffer, which
moderngl wraps with ``ctx.detect_framebuffer`` so that every draw call stays in moderngl. The
shading pass samples it as a ``sampler2DArrayShadow``. Seen working on Mesa llvmpipe.

Only this module calls PyOpenGL for it; the shadow-map pass (game/render/shadow_pass.py) owns
the array and releases it explicitly.
"""

from __future__ import annotations

import ctypes

from game.errors import GameError


class DepthArray:
    """``layers`` square depth maps of ``resolution`` texels in one GL texture array."""

    def __init__(self, ctx, resolution: int, layers: int):
        from OpenGL import GL
        from OpenGL.error import GLError

        self._gl = GL
        self._far = (ctypes.c_float * 1)(1.0)
        self.ctx = ctx
        self.resolution = int(resolution)
        self.layers = int(layers)
        max_size = int(ctx.info["GL_MAX_TEXTURE_SIZE"])
        max_layers = int(ctx.info["GL_MAX_ARRAY_TEXTURE_LAYERS"])
        if not 1 <= self.resolution <= max_size:
            raise GameError(f"shadow map resolution {resolution} is outside 1..{max_size} "
                            "(GL_MAX_TEXTURE_SIZE)")
        if not 1 <= self.layers <= max_layers:
            raise GameError(f"{layers} shadow maps exceed GL_MAX_ARRAY_TEXTURE_LAYERS "
                            f"({max_layers})")
        self.texture = int(GL.glGenTextures(1))
        GL.glBindTexture(GL.GL_TEXTURE_2D_ARRAY, self.texture)
        # PyOpenGL raises on a GL error by itself; without its error checking, glGetError says.
        try:
            GL.glTexStorage3D(GL.GL_TEXTURE_2D_ARRAY, 1, GL.GL_DEPTH_COMPONENT32F,
                              self.resolution, self.resolution, self.layers)
            refused = GL.glGetError() != GL.GL_NO_ERROR
        except GLError:
            refused = True
        if refused:
            GL.glBindTexture(GL.GL_TEXTURE_2D_ARRAY, 0)
            GL.glDeleteTextures(1, [self.texture])
            raise GameError(f"the driver refused a {self.resolution}x{self.resolution}x"
                            f"{self.layers} depth array (out of memory?)")
        for name, value in (
            (GL.GL_TEXTURE_COMPARE_MODE, GL.GL_COMPARE_REF_TO_TEXTURE),
            (GL.GL_TEXTURE_COMPARE_FUNC, GL.GL_LEQUAL),
            (GL.GL_TEXTURE_MIN_FILTER, GL.GL_NEAREST),
            (GL.GL_TEXTURE_MAG_FILTER, GL.GL_NEAREST),
            (GL.GL_TEXTURE_WRAP_S, GL.GL_CLAMP_TO_EDGE),
            (GL.GL_TEXTURE_WRAP_T, GL.GL_CLAMP_TO_EDGE),
        ):
            GL.glTexParameteri(GL.GL_TEXTURE_2D_ARRAY, name, value)
        GL.glBindTexture(GL.GL_TEXTURE_2D_ARRAY, 0)
        self._fbo_ids: list[int] = []
        self.framebuffers = []
        for layer in range(self.layers):
            fbo = int(GL.glGenFramebuffers(1))
            GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, fbo)
            GL.glFramebufferTextureLayer(GL.GL_FRAMEBUFFER, GL.GL_DEPTH_ATTACHMENT,
                                         self.texture, 0, layer)
            GL.glDrawBuffer(GL.GL_NONE)
            GL.glReadBuffer(GL.GL_NONE)
            status = GL.glCheckFramebufferStatus(GL.GL_FRAMEBUFFER)
            self._fbo_ids.append(fbo)
            if status != GL.GL_FRAMEBUFFER_COMPLETE:
                self.release()
                raise GameError(f"depth array layer {layer} is not a complete framebuffer "
                                f"(status 0x{status:x})")
            self.framebuffers.append(ctx.detect_framebuffer(fbo))
        # The whole array as one layered framebuffer, for draws that pick gl_Layer per vertex.
        fbo = int(GL.glGenFramebuffers(1))
        GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, fbo)
        GL.glFramebufferTexture(GL.GL_FRAMEBUFFER, GL.GL_DEPTH_ATTACHMENT, self.texture, 0)
        GL.glDrawBuffer(GL.GL_NONE)
        GL.glReadBuffer(GL.GL_NONE)
        self._fbo_ids.append(fbo)
        status = GL.glCheckFramebufferStatus(GL.GL_FRAMEBUFFER)
        if status != GL.GL_FRAMEBUFFER_COMPLETE:
            self.release()
            raise GameError(f"the layered depth array is not a complete framebuffer "
                            f"(status 0x{status:x})")
        self.layered = ctx.detect_framebuffer(fbo)
        # Leave moderngl's idea of the bound framebuffer true.
        ctx.detect_framebuffer(0).use()

    @property
    def bytes(self) -> int:
        """GPU memory of the depth texels."""
        return self.resolution * self.resolution * self.layers * 4

    def gl_objects(self) -> int:
        """The texture and the framebuffers (one per layer and the layered one)."""
        return (1 if self.texture else 0) + len(self._fbo_ids)

    def clear(self, layer: int, size: int, origin: tuple[int, int] = (0, 0)) -> None:
        """Set the ``size`` x ``size`` square of a layer at texel ``origin`` to the far depth
        (1.0).

        glClearTexSubImage (GL 4.4, GL_ARB_clear_texture) fills texels directly: on llvmpipe,
        this is several times cheaper than drawing one depth quad per corner into the layered
        framebuffer.
        """
        GL = self._gl
        GL.glClearTexSubImage(self.texture, 0, int(origin[0]), int(origin[1]), int(layer),
                              int(size), int(size), 1,
                              GL.GL_DEPTH_COMPONENT, GL.GL_FLOAT, self._far)

    def bind(self, unit: int) -> None:
        """Bind the array to a texture unit for sampling."""
        GL = self._gl
        GL.glActiveTexture(GL.GL_TEXTURE0 + unit)
        GL.glBindTexture(GL.GL_TEXTURE_2D_ARRAY, self.texture)

    def release(self) -> None:
        """Delete the framebuffers and the texture."""
        GL = self._gl
        self.ctx.detect_framebuffer(0).use()  # never leave moderngl bound to a deleted name
        # The detect_framebuffer wrappers are references: the GL names are ours to delete.
        self.framebuffers = []
        self.layered = None
        if self._fbo_ids:
            GL.glDeleteFramebuffers(len(self._fbo_ids), self._fbo_ids)
            self._fbo_ids = []
        if self.texture:
            GL.glDeleteTextures(1, [self.texture])
            self.texture = 0
