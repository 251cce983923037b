"""The scene's triangles on the GPU: one vertex and one index buffer, shared by every pass."""

from __future__ import annotations

import numpy as np

from game.errors import SceneError
from game.scene import geometry
from game.scene.model import Scene

VERTEX_FORMAT = ("3f 1i", "in_position", "in_object")  # world (or local) position, object index
# What only the shading pass reads: the shading normal and the object's base colour (linear RGB;
# negative where the scene gave none). Each is 12 bytes.
SURFACE_ATTRIBUTES = ("in_normal", "in_colour")


class SceneBuffers:
    """Vertices (position, object index), their surface (shading normal, base colour) and the
    index buffer in the order of :func:`game.scene.geometry.layout`. Owns the three buffers."""

    def __init__(self, ctx, scene: Scene):
        self.ctx = ctx
        self.geom = geometry.pack(scene)
        if not len(self.geom.positions):  # GL makes no empty buffer, and there is no picture
            raise SceneError(f"{scene.source or scene.name}: the scene has nothing to draw: give "
                             "it a [[floor]], a [[static]], a [[character]] or a [generate] town")
        self.layout = geometry.layout(self.geom)
        self.vbo = ctx.buffer(self._vertices())
        self.surface = ctx.buffer(self._surface())
        self.ibo = ctx.buffer(self.layout.indices.tobytes())
        self._pieces: list[geometry.Piece] | None = None

    def _vertices(self) -> bytes:
        vertices = np.empty(len(self.geom.positions), dtype=[("p", "<f4", 3), ("o", "<i4")])
        vertices["p"] = self.geom.positions
        vertices["o"] = self.geom.objects
        return vertices.tobytes()

    def _surface(self) -> bytes:
        surface = np.empty(len(self.geom.positions), dtype=[("n", "<f4", 3), ("c", "<f4", 3)])
        surface["n"] = self.geom.normals
        surface["c"] = self.geom.colours
        return surface.tobytes()

    def vertex_array(self, program, index_buffer=None, surface: bool = False):
        """A vertex array of ``program`` over these vertices, indexed by ``index_buffer``
        (default: the scene's index buffer); with ``surface``, the shading normals and colours
        too. Its owner releases it."""
        content = [(self.vbo, *VERTEX_FORMAT)]
        if surface:
            # A variant that shows no lighting (a debug view) has no use for some attributes,
            # and the compiler drops them: their bytes are skipped.
            used = [name for name in SURFACE_ATTRIBUTES if name in program]
            layout = " ".join("3f" if name in program else "12x" for name in SURFACE_ATTRIBUTES)
            if used:
                content.append((self.surface, layout, *used))
        return self.ctx.vertex_array(program, content, index_buffer or self.ibo, 4)

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
        for buffer, data in ((self.vbo, self._vertices()), (self.surface, self._surface()),
                             (self.ibo, self.layout.indices.tobytes())):
            buffer.orphan(max(len(data), 4))
            buffer.write(data)

    def gl_objects(self) -> int:
        return 3

    def release(self) -> None:
        self.vbo.release()
        self.surface.release()
        self.ibo.release()
