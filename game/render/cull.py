"""Triangle culling for the camera pass, in compute: only triangles that can cover a pixel
centre reach the rasteriser, in their original order.

Why: on a large scene seen at a small image size most triangles lie between pixel centres,
and llvmpipe transforms, clips and sets up every triangle on the application's one thread, so
drawing them all cost every method the same large share of its frame, whatever the fragment
shader did. A compute pass runs on llvmpipe's worker threads instead
(docs/design/triangle-culling.md).

The technique is the one GPU-driven renderers use (G. Wihlidal, "Optimizing the Graphics
Pipeline with Compute", GDC 2016): per triangle, frustum, back-face (closed volumes only) and
small-primitive tests, then an order-preserving compaction into an index buffer drawn with
``glMultiDrawElementsIndirect``. Every test keeps the doubtful cases (see shaders/cull.comp), so
the frame is the same, pixel for pixel, as drawing every triangle; tests/render/test_cull.py
checks that. Keeping the order keeps which of two equally deep triangles wins.

:class:`TriangleCuller` owns its programs and buffers and releases them in
:meth:`TriangleCuller.release`; its owner, the renderer, releases it.
"""

from __future__ import annotations

import moderngl
import numpy as np

from game.gpu import blocks, context, glsl, resources
from game.gpu.blocks import CHUNK_DTYPE, CULL_DTYPE, DRAW_COMMAND_DTYPE
from game.render.scene_buffers import SceneBuffers

CHUNK = 32                # triangles per mask word; keep in sync with shaders/cull.comp
LOCAL_SIZE = 64           # invocations per workgroup of the mask and write stages
MAX_GROUPS = 65535        # GL_MAX_COMPUTE_WORK_GROUP_COUNT's guaranteed minimum
STAGES = {"STAGE_MASK": 0, "STAGE_SCAN": 1, "STAGE_WRITE": 2}
BINDING_NAMES = ("Corners", "Indices", "Chunks", "Culled", "Commands")


def _chunks(triangles: int) -> int:
    return (triangles + CHUNK - 1) // CHUNK


class TriangleCuller:
    """Culls the scene's index buffer (closed volumes first, then open meshes; see
    game/scene/geometry.py) for one view; :meth:`draw` then draws what is left."""

    def __init__(self, ctx, defines: dict, buffers: SceneBuffers):
        self.ctx = ctx
        self.buffers = buffers  # the write stage copies from their index buffer
        defines = {**defines, **STAGES}
        self.programs = [ctx.compute_shader(glsl.build("cull.comp", {**defines, "STAGE": stage}))
                         for stage in STAGES.values()]
        self.params = ctx.buffer(reserve=CULL_DTYPE.itemsize)
        self.corners = ctx.buffer(reserve=36)
        self.chunks = ctx.buffer(reserve=CHUNK_DTYPE.itemsize)
        self.output = ctx.buffer(reserve=12)
        self.commands = ctx.buffer(reserve=2 * DRAW_COMMAND_DTYPE.itemsize)
        self._params = np.zeros(1, CULL_DTYPE)
        self.groups = 0  # workgroups of the mask and write stages
        try:
            self.set_layout()
        except BaseException:
            self.release()
            raise

    @staticmethod
    def fits(n_indices: int) -> bool:
        """Whether one dispatch per stage can cull this many indices."""
        return _chunks(n_indices // 3) + 1 <= MAX_GROUPS * LOCAL_SIZE

    def set_layout(self) -> None:
        """The index buffer changed: upload each triangle's corners in its order. The buffers
        grow in place (no new GL objects)."""
        geom, layout = self.buffers.geom, self.buffers.layout
        n_indices = len(layout.indices)
        if not self.fits(n_indices):
            raise ValueError(f"{n_indices // 3} triangles are too many to cull in one dispatch")
        closed, total = layout.n_closed // 3, n_indices // 3
        p = self._params
        p["closed_triangles"], p["triangles"] = closed, total
        p["closed_chunks"] = _chunks(closed)
        p["chunks"] = _chunks(closed) + _chunks(total - closed)
        self.groups = (int(p["chunks"][0]) + LOCAL_SIZE - 1) // LOCAL_SIZE
        # The characters end each of the two groups (geometry.layout): at most two ranges.
        characters = layout.ranges(geom.character_object(i) for i in range(geom.n_characters))
        if len(characters) > 2:
            raise ValueError("the characters' triangles are not at the ends of the index buffer")
        keep = [x // 3 for first, count in characters for x in (first, first + count)]
        keep += [0] * (4 - len(keep))
        p["keep_closed"], p["keep_open"] = keep[:2], keep[2:]
        corners = geom.positions[layout.indices].astype(np.float32).tobytes()
        for buf, data_size in ((self.corners, len(corners)),
                               (self.chunks, CHUNK_DTYPE.itemsize * int(p["chunks"][0])),
                               (self.output, 4 * n_indices)):
            size = max(data_size, 12)
            if buf.size != size:
                buf.orphan(size)
        self.corners.write(corners)

    def gl_objects(self) -> int:
        """GL objects held: the programs, their attached shader objects, the buffers."""
        return (len(self.programs) + resources.attached_shaders(self.programs)
                + 5 * bool(self.programs))

    def run(self, viewport: tuple[int, int]) -> None:
        """Cull for the view in the bound Frame block (its view-projection); the result stays
        on the GPU, in :attr:`output` and the draw commands."""
        self._params["viewport"] = (float(viewport[0]), float(viewport[1]))
        self.params.write(self._params.tobytes())
        self.params.bind_to_uniform_block(blocks.BINDINGS["CullParams"])
        buffers = (self.corners, self.buffers.ibo, self.chunks, self.output, self.commands)
        for buf, name in zip(buffers, BINDING_NAMES, strict=True):
            buf.bind_to_storage_buffer(blocks.BINDINGS[name])
        for prog, groups in zip(self.programs, (self.groups, 1, self.groups), strict=True):
            if groups:
                prog.run(groups)
            # The next stage reads what this one wrote; the draw reads indices and commands.
            self.ctx.memory_barrier()
        context.unbind_program()

    def draw(self, vao) -> None:
        """Draw the kept triangles with ``vao``, whose index buffer is :attr:`output`: closed
        volumes with back faces culled, then open meshes."""
        ctx = self.ctx
        ctx.enable(moderngl.CULL_FACE)
        vao.render_indirect(self.commands, moderngl.TRIANGLES, count=1, first=0)
        ctx.disable(moderngl.CULL_FACE)
        vao.render_indirect(self.commands, moderngl.TRIANGLES, count=1, first=1)

    def kept(self) -> int:
        """Triangles the last :meth:`run` kept (reads back; for statistics and tests)."""
        commands = np.frombuffer(self.commands.read(), DRAW_COMMAND_DTYPE)
        return int(commands["count"].sum()) // 3

    def release(self) -> None:
        for obj in [*self.programs, self.params, self.corners, self.chunks, self.output,
                    self.commands]:
            obj.release()
        self.programs = []
