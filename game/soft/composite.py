"""The soft composite: a rendered frame lit again through a traced visibility.

The linear light's soft shadows, or (for the ``traced`` hard-shadow method) the hard light's
exact ones, replace the shading pass's lighting. The composite is one full-screen pass over the
frame's G-buffer (shaders/composite.frag): the scene is not drawn again.
"""

from __future__ import annotations

import moderngl
import numpy as np

from game.gpu import blocks, resources
from game.gpu.fullscreen import fullscreen_pass
from game.soft.tracer import TEXTURE_UNITS

# The G-buffer on the tracer's units, the surface the frame is lit again with, and the traced
# visibility.
UNITS = {**TEXTURE_UNITS, "u_shading": blocks.TEXTURE_UNITS["composite_shading"],
         "u_albedo": blocks.TEXTURE_UNITS["composite_albedo"],
         "u_visibility": blocks.TEXTURE_UNITS["soft_visibility"]}


class SoftComposite:
    """Owns its programs (one per light kind and mode), the visibility texture and the target
    it draws into (:attr:`framebuffer`, :attr:`texture`), all released by :meth:`release`."""

    def __init__(self, ctx, defines: dict):
        self.ctx = ctx
        self.defines = defines
        self._programs: dict[tuple[int, bool], object] = {}
        self._vao: dict[tuple[int, bool], object] = {}
        self.size: tuple[int, int] | None = None
        self.visibility = self.texture = self.framebuffer = None

    def _program(self, light_kind: int, hard: bool):
        key = (light_kind, hard)
        if key not in self._programs:
            defines = {**self.defines, "LIGHT_KIND": light_kind, "HARD": hard}
            self._programs[key], self._vao[key] = fullscreen_pass(self.ctx, "composite.frag",
                                                                  defines)
        return self._programs[key], self._vao[key]

    def _resize(self, size: tuple[int, int]) -> None:
        if size == self.size:
            return
        self._release_target()
        self.size = size
        self.visibility = self.ctx.texture(size, 1, dtype="f4")
        self.texture = self.ctx.texture(size, 4)
        self.framebuffer = self.ctx.framebuffer([self.texture])

    def draw(self, textures, size: tuple[int, int], visibility, light_kind: int,
             hard: bool, soft_light: np.ndarray | None = None) -> None:
        """Light the frame through ``visibility`` into :attr:`framebuffer`: an (H, W) array
        (row 0 at the top; NaN where no geometry), uploaded here, or a one-channel texture of
        ``size`` already on the GPU (the upsampled reduced trace, game/soft/upsample.py).
        ``textures`` are the frame's (position, normal, colour, shading normal, albedo); the
        Frame block must be bound as the frame left it."""
        self._resize(size)
        if isinstance(visibility, np.ndarray):
            vis = np.nan_to_num(visibility[::-1], nan=1.0).astype(np.float32)
            self.visibility.write(np.ascontiguousarray(vis).tobytes())
            visibility = self.visibility
        prog, vao = self._program(light_kind, hard)
        for tex, (name, unit) in zip((*textures, visibility), UNITS.items(), strict=True):
            tex.use(unit)
            if name in prog:  # a directional light needs no position: the compiler drops it
                prog[name].value = unit
        if not hard:
            prog["u_soft_light"].value = tuple(float(x) for x in soft_light)
        fb = self.framebuffer
        fb.use()
        fb.viewport = (0, 0, *size)
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)
        vao.render(moderngl.TRIANGLES, vertices=3)

    def read(self) -> np.ndarray:
        """The composited image, (H, W, 3) uint8, row 0 at the top."""
        w, h = self.size
        rgb = np.frombuffer(self.framebuffer.read(components=3), np.uint8)
        return np.ascontiguousarray(rgb.reshape(h, w, 3)[::-1])

    def gl_objects(self) -> int:
        programs = list(self._programs.values())
        target = 0 if self.size is None else 3
        return len(programs) + resources.attached_shaders(programs) + len(self._vao) + target

    def _release_target(self) -> None:
        if self.framebuffer is not None:
            self.ctx.detect_framebuffer(0).use()
            for obj in (self.framebuffer, self.texture, self.visibility):
                obj.release()
        self.size = None
        self.visibility = self.texture = self.framebuffer = None

    def release(self) -> None:
        self._release_target()
        for obj in (*self._vao.values(), *self._programs.values()):
            obj.release()
        self._programs, self._vao = {}, {}
