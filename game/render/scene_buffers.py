"""The scene's triangles on the GPU: one vertex and one index buffer, shared by every pass."""

from __future__ import annotations

import numpy as np

from game.scene import geometry
from game.scene.model import Scene

VERTEX_FORMAT = ("3f 1i", "in_position", "in_object")  # world (or local) position, object index


class SceneBuffers:
    """Vertices (position, object index) and the index buffer in the order of
    :func:`game.scene.geometry.layout`. Owns both buffers."""

    def __init__(self, ctx, scene: Scene):
        self.ctx = ctx
        self.geom = geometry.pack(scene)
        self.layout = geometry.layout(self.geom)
        self.vbo = ctx.buffer(self._vertices())
        self.ibo = ctx.buffer(self.layout.indices.tobytes())
        self._pieces: list[geometry.Piece] | None = None

    def _vertices(self) -> bytes:
        vertices = np.empty(len(self.geom.positions), dtype=[("p", "<f4", 3), ("o", "<i4")])
        vertices["p"] = self.geom.positions
        vertices["o"] = self.geom.objects
        return vertices.tobytes()

    def vertex_array(self, program, index_buffer=None):
        """A vertex array of ``program`` over these vertices, indexed by ``index_buffer``
        (default: the scene's index buffer). Its owner releases it."""
        return self.ctx.vertex_array(program, [(self.vbo, *VERTEX_FORMAT)],
                                     index_buffer or self.ibo, 4)

    def order_statics(self, pieces: list[geometry.Piece] | None) -> bool:
        """Put the statics in ``pieces`` (a method's clump order) in the index buffer; True
        when the buffer changed. A method keeps one list until it re-clumps, so identity says
        "unchanged"."""
        if pieces is None or pieces is self._pieces:
            return False
        self.layout = geometry.layout(self.geom, pieces)
        self.ibo.write(self.layout.indices.tobytes())
        self._pieces = pieces
        return True

    def repack(self, scene: Scene) -> None:
        """The geometry of the changed scene, into the same buffers (grown when needed)."""
        self.geom = geometry.pack(scene)
        self.layout = geometry.layout(self.geom)
        self._pieces = None  # the next plan's order is applied afresh
        for buffer, data in ((self.vbo, self._vertices()),
                             (self.ibo, self.layout.indices.tobytes())):
            buffer.orphan(max(len(data), 4))
            buffer.write(data)

    def gl_objects(self) -> int:
        return 2

    def release(self) -> None:
        self.vbo.release()
        self.ibo.release()
