"""The soft composite: a rendered frame lit again through a traced visibility.

The linear light is one more light: its soft shadows add its diffuse term to the shading pass's
picture, which keeps every scene light with its hard shadows. For the ``traced`` hard-shadow
method the hard light's exact shadows replace its maps' instead. The composite is one
full-screen pass over the frame's G-buffer (shaders/composite.frag): the scene is not drawn
again.

A raster soft method in the window (game/soft/direct.py) lights most of the frame in the
shading pass itself, from one value per block, and the composite draws over runs of blocks
instead (:meth:`SoftComposite.draw_runs`): the frame's picture is copied, then the runs whose
pixels each look the visibility up are lit from the raster method's maps, at the world position
the lean G-buffer's depth gives back.
"""

from __future__ import annotations

import moderngl
import numpy as np

from game import transforms
from game.gpu import blocks, glsl, resources
from game.gpu.fullscreen import fullscreen_pass
from game.soft.block_values import BLOCK_DEFINES
from game.soft.tracer import TEXTURE_UNITS

# Where the composite's visibility comes from (VIS_SOURCE in shaders/composite.frag).
VIS_TEXTURE, VIS_RUNS = 0, 1
LOOKUPS = {"segment-maps": 0, "pcss": 1}   # LOOKUP in shaders/composite.frag
RUN_FLOATS = 3       # per vertex of a run: x, y (pixels), visibility
VIS_RUNS_KIND = 0    # the runs light by the linear light alone: no light kind

# The G-buffer on the tracer's units, the surface the frame is lit again with, and the traced
# visibility.
UNITS = {**TEXTURE_UNITS, "u_shading": blocks.TEXTURE_UNITS["composite_shading"],
         "u_albedo": blocks.TEXTURE_UNITS["composite_albedo"],
         "u_visibility": blocks.TEXTURE_UNITS["soft_visibility"]}
# What the runs read: the lean G-buffer, the points and what a still view kept (direct.py).
LEAN_UNITS = {"u_colour": TEXTURE_UNITS["u_colour"],
              "u_depth": blocks.TEXTURE_UNITS["lean_depth"],
              "u_packed_normal": blocks.TEXTURE_UNITS["lean_normal"],
              "u_light": blocks.TEXTURE_UNITS["lean_light"],
              "u_soft_points": blocks.TEXTURE_UNITS["soft_points"],
              "u_soft_history": blocks.TEXTURE_UNITS["soft_history"]}


class SoftComposite:
    """Owns its programs (one per light kind and mode), the visibility texture and the target
    it draws into (:attr:`framebuffer`, :attr:`texture`), all released by :meth:`release`."""

    def __init__(self, ctx, defines: dict):
        self.ctx = ctx
        self.defines = defines
        self._programs: dict[tuple, object] = {}
        self._vao: dict[tuple, object] = {}
        self.size: tuple[int, int] | None = None
        self.visibility = self.texture = self.framebuffer = None
        self._runs = None            # the runs' vertices (made on first use, grown in place)
        self._measured = self._measured_framebuffer = None   # OUT_VISIBILITY's target

    def _program(self, light_kind: int, hard: bool, source: int = VIS_TEXTURE,
                 out_visibility: bool = False, lookup: tuple[int, dict] | None = None,
                 refine: bool = False):
        lookup_runs = lookup is not None
        lookup = lookup or (-1, {})
        key = (light_kind, hard, source, out_visibility, lookup[0],
               tuple(sorted(lookup[1].items())), refine)
        if key not in self._programs:
            defines = {**self.defines, **lookup[1], **BLOCK_DEFINES, "LOOKUP": lookup[0],
                       "LIGHT_KIND": light_kind, "HARD": hard,
                       "VIS_SOURCE": source, "OUT_VISIBILITY": out_visibility,
                       "LOOKUP_RUNS": lookup_runs, "REFINE": refine}
            if source == VIS_TEXTURE:
                self._programs[key], self._vao[key] = fullscreen_pass(
                    self.ctx, "composite.frag", defines)
            else:
                self._programs[key], self._vao[key] = self._runs_pass("composite.frag", defines)
        return self._programs[key], self._vao[key]

    def _runs_pass(self, fragment: str, defines: dict):
        """A program over runs of blocks (soft_blocks.vert) and its vertex array."""
        ctx = self.ctx
        if self._runs is None:
            self._runs = ctx.buffer(reserve=4 * RUN_FLOATS * 6)
        program = ctx.program(vertex_shader=glsl.build("soft_blocks.vert"),
                              fragment_shader=glsl.build(fragment, defines))
        try:
            # A lookup variant reads no run value: the compiler drops in_vis.
            layout = ((self._runs, "2f 1f", "in_pixel", "in_vis") if "in_vis" in program
                      else (self._runs, "2f 4x", "in_pixel"))
            return program, ctx.vertex_array(program, [layout])
        except BaseException:
            program.release()
            raise

    def prepare(self, size: tuple[int, int]) -> None:
        """Make the target for frames of ``size`` (again, if the size changed)."""
        self._resize(size)

    def _resize(self, size: tuple[int, int]) -> None:
        if size == self.size:
            return
        self._release_target()
        self.size = size
        self.visibility = self.ctx.texture(size, 1, dtype="f4")
        self.texture = self.ctx.texture(size, 4)
        self.framebuffer = self.ctx.framebuffer([self.texture])

    def draw(self, textures, size: tuple[int, int], visibility, light_kind: int,
             hard: bool, soft_light: np.ndarray | None = None,
             soft_radiance: np.ndarray | None = None) -> None:
        """Light the frame through ``visibility`` into :attr:`framebuffer`: an (H, W) array
        (row 0 at the top; NaN where no geometry), uploaded here, or a one-channel texture of
        ``size`` already on the GPU (the upsampled reduced trace, game/soft/upsample.py).
        ``textures`` are the frame's (position, normal, colour, shading normal, albedo); the
        Frame block must be bound as the frame left it. Soft (not ``hard``): the linear light
        at ``soft_light`` (the segment's midpoint) with ``soft_radiance`` (linear RGB) adds to
        the colour the shading pass drew."""
        self._resize(size)
        if isinstance(visibility, np.ndarray):
            vis = np.nan_to_num(visibility[::-1], nan=1.0).astype(np.float32)
            self.visibility.write(np.ascontiguousarray(vis).tobytes())
            visibility = self.visibility
        prog, vao = self._program(light_kind, hard)
        self._bind(prog, textures, visibility)
        if not hard:
            prog["u_soft_light"].value = tuple(float(x) for x in soft_light)
            prog["u_soft_radiance"].value = tuple(float(x) for x in soft_radiance)
        fb = self.framebuffer
        fb.use()
        fb.viewport = (0, 0, *size)
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)
        vao.render(moderngl.TRIANGLES, vertices=3)

    def copy_picture(self, colour) -> None:
        """Copy the frame's picture (an RGBA8 texture of the target's size) into the target,
        texel for texel (glCopyImageSubData: no framebuffer's read buffer is involved)."""
        from OpenGL import GL

        w, h = self.size
        GL.glCopyImageSubData(colour.glo, GL.GL_TEXTURE_2D, 0, 0, 0, 0, self.texture.glo,
                              GL.GL_TEXTURE_2D, 0, 0, 0, 0, w, h, 1)

    def draw_runs(self, target, runs, clip_to_world: np.ndarray, lookup: tuple[int, dict],
                  bind_lookup, soft_radiance: np.ndarray, out_visibility: bool = False,
                  refine: bool = False) -> None:
        """Light the frame over ``runs`` (game/soft/direct.py's :class:`~game.soft.direct.
        Runs`) into :attr:`framebuffer`, which :meth:`prepare` made and :meth:`copy_picture`
        filled with the frame's picture: the runs that look the visibility up, with the raster
        method's lookup ``lookup`` (its :data:`LOOKUPS` number and #defines), bound by
        ``bind_lookup(program)``, at the positions that ``target``'s lean G-buffer and
        ``clip_to_world`` (the frame's clip space to world) give. With ``out_visibility`` every
        run's visibility goes into :meth:`measured` instead (to measure). With ``refine`` the
        runs are a still view's refining ones (their vertices in ``runs.flat``): they add to what
        the view kept and leave the picture as it is."""
        parts = [(runs.flat if refine else runs.lookup, True)]
        if out_visibility:
            parts.insert(0, (runs.flat, False))
        data = np.concatenate([vertices for vertices, _ in parts]).astype(np.float32)
        if self._runs is None:
            self._runs = self.ctx.buffer(reserve=max(data.nbytes, 4 * RUN_FLOATS * 6))
        elif data.nbytes > self._runs.size:
            self._runs.orphan(data.nbytes)
        if data.nbytes:
            self._runs.write(data.tobytes())
        self.ctx.disable(moderngl.DEPTH_TEST | moderngl.CULL_FACE | moderngl.BLEND)
        fb = self._measured_target() if out_visibility else self.framebuffer
        fb.use()
        fb.viewport = (0, 0, *self.size)
        textures = {"u_colour": target.colour, "u_depth": target.depth,
                    "u_packed_normal": target.packed_normal, "u_light": target.light,
                    "u_soft_points": runs.points, "u_soft_history": runs.history}
        first = 0
        for vertices, looked_up in parts:
            count = len(vertices)
            if count:
                prog, vao = self._program(VIS_RUNS_KIND, False, VIS_RUNS, out_visibility,
                                          lookup if looked_up else None, refine)
                for name, tex in textures.items():
                    if name in prog:   # the compiler drops what goes unread
                        tex.use(LEAN_UNITS[name])
                        prog[name].value = LEAN_UNITS[name]
                prog["u_size"].value = tuple(float(x) for x in self.size)
                if "u_point_at" in prog:
                    prog["u_point_at"].value = runs.point_at
                if looked_up:
                    prog["u_clip_to_world"].write(transforms.gl_bytes(clip_to_world))
                    bind_lookup(prog)
                if "u_soft_radiance" in prog:
                    prog["u_soft_radiance"].value = tuple(float(x) for x in soft_radiance)
                vao.render(moderngl.TRIANGLES, vertices=count, first=first)
            first += count

    def compile_refining(self, lookup: tuple[int, dict]) -> None:
        """Build the refining runs' program for ``lookup`` now (``draw_runs`` with ``refine``
        would at its first use): a still view's first refining frame then costs no compile."""
        self._program(VIS_RUNS_KIND, False, VIS_RUNS, False, lookup, True)

    def _bind(self, prog, textures, visibility) -> None:
        for tex, (name, unit) in zip((*textures, visibility), UNITS.items(), strict=True):
            if tex is not None and name in prog:  # the compiler drops what goes unread
                tex.use(unit)
                prog[name].value = unit

    def _measured_target(self):
        if self._measured is None:
            self._measured = self.ctx.texture(self.size, 1, dtype="f4")
            self._measured_framebuffer = self.ctx.framebuffer([self._measured])
        # The runs left out (the sky, the umbra) read 0: the umbra's visibility.
        self._measured_framebuffer.clear(0.0, 0.0, 0.0, 0.0)
        return self._measured_framebuffer

    def measured(self) -> np.ndarray:
        """The visibility the last ``out_visibility`` draw wrote, (H, W) float32, row 0 at the
        top; NaN where a drawn pixel shows no geometry, 0 in the sky of the runs left out."""
        w, h = self.size
        vis = np.frombuffer(self._measured.read(), np.float32).reshape(h, w)[::-1]
        return np.where(vis < 0.0, np.nan, vis).astype(np.float32)

    def read(self) -> np.ndarray:
        """The composited image, (H, W, 3) uint8, row 0 at the top."""
        w, h = self.size
        rgb = np.frombuffer(self.framebuffer.read(components=3), np.uint8)
        return np.ascontiguousarray(rgb.reshape(h, w, 3)[::-1])

    def gl_objects(self) -> int:
        programs = list(self._programs.values())
        target = 0 if self.size is None else 3
        held = (self._runs, self._measured, self._measured_framebuffer)
        return (len(programs) + resources.attached_shaders(programs) + len(self._vao) + target
                + sum(x is not None for x in held))

    def _release_target(self) -> None:
        resources.release_targets(self.ctx, (self.framebuffer, self.texture, self.visibility,
                                             self._measured_framebuffer, self._measured))
        self._measured = self._measured_framebuffer = None
        self.size = None
        self.visibility = self.texture = self.framebuffer = None

    def release(self) -> None:
        self._release_target()
        for obj in (*self._vao.values(), *self._programs.values()):
            obj.release()
        self._programs, self._vao = {}, {}
        if self._runs is not None:
            self._runs.release()
            self._runs = None
