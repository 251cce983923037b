"""The frame's render target: its colour, the G-buffer when kept, and depth, in one framebuffer."""

from __future__ import annotations

from enum import IntEnum

import numpy as np
from OpenGL import GL

from game.errors import GameError
from game.gpu import resources

SKY = (0.58, 0.68, 0.80)   # the clear colour: pixels with no geometry


class GBuffer(IntEnum):
    """What the frame target keeps beside its colour (GBUFFER in shaders/shade.frag).

    ``FULL``, for the dumps, the tracer and the soft composite over the whole frame: world
    position and object index, the geometric normal and the hard light's visibility (RGBA32F
    each), the shading normal (RGBA16F) and the base colour (RGBA8). ``LEAN``, for the window's
    raster soft shadows (game/soft/direct.py): the geometric normal packed in RGBA8, the linear
    light's diffuse factor in RGBA8, and depth as a texture, from which the composite finds the
    world position again. llvmpipe writes 8-bit targets at a fraction of the cost of float ones.
    """

    NONE = 0
    LEAN = 1
    FULL = 2


# Bytes per pixel of the target on the GPU (colour and depth, and the G-buffer's textures), and
# the most a frame may take: what is read back to the host is larger still.
BYTES_PER_PIXEL = {GBuffer.NONE: 8, GBuffer.LEAN: 16, GBuffer.FULL: 52}
MAX_FRAME_BYTES = 2 * 2**30


def check_size(ctx, size: tuple[int, int], gbuffer: GBuffer) -> None:
    """Refuse, in one line, a frame the GL cannot hold or that would take more than
    :data:`MAX_FRAME_BYTES`, before anything is allocated."""
    w, h = size
    most = min(int(ctx.info["GL_MAX_TEXTURE_SIZE"]), int(ctx.info["GL_MAX_RENDERBUFFER_SIZE"]))
    if max(w, h) > most:
        raise GameError(f"a {w}x{h} frame is larger than this GL allows ({most} per side)")
    need = w * h * BYTES_PER_PIXEL[gbuffer]
    if need > MAX_FRAME_BYTES:
        what = " with its G-buffer (--dump, --soft)" if gbuffer != GBuffer.NONE else ""
        raise GameError(f"a {w}x{h} frame{what} needs {need / 2**30:.1f} GiB of GPU memory; "
                        f"at most {MAX_FRAME_BYTES / 2**30:.0f} GiB")


class FrameTarget:
    """Colour (RGBA8; alpha is 1 + the maps a pixel read, over 255, and 0 where there is no
    geometry), depth, and the G-buffer :class:`GBuffer` names. Owns its textures, renderbuffer
    and framebuffer.

    :attr:`covers` is how many pixels of the target the view's clip space spans: the target's
    size, or for a target of one point per block of a larger frame, that frame's size over the
    block's side (the points then lie at the blocks' centres, whatever the frame's size)."""

    def __init__(self, ctx, size: tuple[int, int], gbuffer: GBuffer):
        self.ctx = ctx
        self._make((int(size[0]), int(size[1])), GBuffer(gbuffer))
        self.covers: tuple[float, float] | None = None

    def _make(self, size: tuple[int, int], gbuffer: GBuffer) -> None:
        ctx = self.ctx
        check_size(ctx, size, gbuffer)
        self.size, self.gbuffer = size, gbuffer
        self.colour = ctx.texture(size, 4)
        self.position = self.normal = self.shading = self.albedo = None
        self.packed_normal = self.light = None
        attachments = [self.colour]
        if gbuffer == GBuffer.FULL:
            self.position = ctx.texture(size, 4, dtype="f4")
            self.normal = ctx.texture(size, 4, dtype="f4")
            self.shading = ctx.texture(size, 4, dtype="f2")
            self.albedo = ctx.texture(size, 4)
            attachments += [self.position, self.normal, self.shading, self.albedo]
        if gbuffer == GBuffer.LEAN:
            self.packed_normal = ctx.texture(size, 4)
            self.light = ctx.texture(size, 4)
            attachments += [self.packed_normal, self.light]
            self.depth = ctx.depth_texture(size)
            self.depth.compare_func = ""   # read as depth, not compared
        else:
            self.depth = ctx.depth_renderbuffer(size)
        self.framebuffer = ctx.framebuffer(attachments, self.depth)

    def remake(self, size: tuple[int, int], gbuffer: GBuffer) -> None:
        """Make the target anew at ``size`` with the G-buffer ``gbuffer``, if either changed."""
        size = (int(size[0]), int(size[1]))
        if (size, gbuffer) != (self.size, self.gbuffer):
            self.release()
            self._make(size, gbuffer)

    sky = SKY  # the clear colour of this scene's frames (dimmer at night)

    def begin(self) -> None:
        """Draw into the whole target from here, cleared to the sky."""
        fb = self.framebuffer
        fb.use()
        fb.viewport = (0, 0, *self.size)
        fb.clear(*self.sky, 0.0)
        if self.covers is not None:
            GL.glViewportIndexedf(0, 0.0, 0.0, float(self.covers[0]), float(self.covers[1]))

    def read_colour(self) -> np.ndarray:
        """(H, W, 4) uint8, row 0 at the top."""
        w, h = self.size
        rgba = np.frombuffer(self.framebuffer.read(components=4, attachment=0), np.uint8)
        return rgba.reshape(h, w, 4)[::-1]

    def read_gbuffer(self, covered: np.ndarray) -> dict[str, np.ndarray]:
        """The dump arrays (docs/reference.md, section 3): NaN and -1 where nothing is seen."""
        w, h = self.size
        fb = self.framebuffer
        pos = np.frombuffer(fb.read(components=4, attachment=1, dtype="f4"), np.float32)
        nrm = np.frombuffer(fb.read(components=4, attachment=2, dtype="f4"), np.float32)
        pos = pos.reshape(h, w, 4)[::-1]
        nrm = nrm.reshape(h, w, 4)[::-1]
        position = np.where(covered[..., None], pos[..., :3], np.nan).astype(np.float32)
        normal = np.where(covered[..., None], nrm[..., :3], np.nan).astype(np.float32)
        obj = np.where(covered, np.rint(pos[..., 3]), -1).astype(np.int32)
        lit = np.where(covered, nrm[..., 3], np.nan).astype(np.float32)
        return {"position": position, "normal": normal, "object": obj, "lit": lit}

    def gl_objects(self) -> int:
        """Textures, the depth renderbuffer (or texture) and the framebuffer."""
        return 3 + {GBuffer.NONE: 0, GBuffer.LEAN: 2, GBuffer.FULL: 4}[self.gbuffer]

    def release(self) -> None:
        resources.release_targets(self.ctx, (self.framebuffer, self.depth, self.colour,
                                             self.position, self.normal, self.shading,
                                             self.albedo, self.packed_normal, self.light))
