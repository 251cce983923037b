"""The scene's triangles packed for the GPU: one vertex array, one index array per object.

Floors and statics are stored in world space, characters in their local space (the vertex shader
applies their model matrix). Each vertex carries its object index, in the global order of
``Scene.object_names()``: floors, statics, characters.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from game.scene.mesh_files import FILE_COLOUR, FILE_NORMAL, FILE_PART, NO_COLOUR
from game.scene.model import Scene
from game.scene.normals import split_by_normal
from game.scene.parts import mesh_parts


@dataclass
class PackedGeometry:
    """CPU-side arrays the renderer uploads; built once per scene."""

    positions: np.ndarray        # (V, 3) float32
    objects: np.ndarray          # (V,) int32
    # (V, 3) float32: the shading normal (game/scene/normals.py), zero where the corner is flat
    # (the shader then takes the triangle's own); a vertex is split where its corners' normals
    # differ, so positions repeat where a smooth surface meets a crease.
    normals: np.ndarray
    # (V, 3) float32: the base colour of each vertex's faces, linear RGB: the file's material's,
    # else the scene's `color`; negative: neither (the shader's palette). Vertices are split
    # where colours differ.
    colours: np.ndarray
    triangles: list[np.ndarray]  # per object: (Fi, 3) uint32 indices into positions
    names: list[str]
    n_floors: int
    n_statics: int
    n_characters: int
    static_points: list[np.ndarray]  # per static: (Ni, 3) float64 world-space vertices
    character_points: list[np.ndarray]  # per character: (Ni, 3) float64 local vertices
    character_radius: np.ndarray     # per character: bounding-sphere radius about its origin
    closed: np.ndarray               # per object: a closed, outward-wound volume (cullable)
    # Per static: its faces' parts (game/scene/parts.py), what the clumping groups. A mesh file
    # splits into its structure and connected components; an analytic shape is one part.
    static_parts: list[np.ndarray]

    @property
    def first_static(self) -> int:
        return self.n_floors

    @property
    def first_character(self) -> int:
        return self.n_floors + self.n_statics

    def static_object(self, i: int) -> int:
        """Global object index of static i."""
        return self.n_floors + i

    def character_object(self, i: int) -> int:
        """Global object index of character i."""
        return self.n_floors + self.n_statics + i

    def triangle_count(self, objects) -> int:
        return int(sum(len(self.triangles[o]) for o in objects))

    def static_corners(self, i: int, faces: np.ndarray | None = None) -> np.ndarray:
        """World-space corners (3 per face, float64) of static ``i``'s ``faces`` (local
        indices; all of them when None)."""
        tri = self.triangles[self.static_object(i)]
        if faces is not None:
            tri = tri[faces]
        return self.positions[tri.reshape(-1)].astype(np.float64)


def pack(scene: Scene) -> PackedGeometry:
    """Pack every mesh of the scene."""
    meshes = ([b.mesh for b in scene.floors] + [b.mesh for b in scene.statics]
              + [c.mesh for c in scene.characters])
    bodies = [*scene.floors, *scene.statics, *scene.characters]
    positions, objects, triangles, shading, colours = [], [], [], [], []
    base = 0
    for index, mesh in enumerate(meshes):
        face_colour = _face_colours(mesh, bodies[index].colour)
        given = mesh.vertex_attributes.get(FILE_NORMAL)
        source, n, f = split_by_normal(mesh.vertices, mesh.faces, face_key=face_colour,
                                       given=given)
        positions.append(np.asarray(mesh.vertices, dtype=np.float32)[source])
        shading.append(n)
        # Every corner of a split vertex shares its faces' colour (the colour is in the key).
        vertex_colour = np.empty((len(source), 3), np.float32)
        vertex_colour[f.reshape(-1)] = np.repeat(face_colour, 3, axis=0)
        colours.append(vertex_colour)
        objects.append(np.full(len(source), index, dtype=np.int32))
        triangles.append((f + base).astype(np.uint32))
        base += len(source)
    character_points = [np.asarray(c.mesh.vertices, float) for c in scene.characters]
    # Back faces of closed volumes can never be seen from outside them: the shading pass culls
    # them (on llvmpipe that halved the shading time of the 1 M-triangle town).
    closed = np.array([bool(m.is_volume) for m in meshes], dtype=bool)
    return PackedGeometry(
        positions=np.concatenate(positions) if positions else np.zeros((0, 3), np.float32),
        objects=np.concatenate(objects) if objects else np.zeros(0, np.int32),
        normals=np.concatenate(shading) if shading else np.zeros((0, 3), np.float32),
        colours=np.concatenate(colours) if colours else np.zeros((0, 3), np.float32),
        triangles=triangles,
        names=scene.object_names(),
        n_floors=len(scene.floors),
        n_statics=len(scene.statics),
        n_characters=len(scene.characters),
        static_points=[np.asarray(b.mesh.vertices, float) for b in scene.statics],
        character_points=character_points,
        character_radius=np.array([float(np.linalg.norm(p, axis=1).max()) if len(p) else 0.0
                                   for p in character_points]),
        closed=closed,
        static_parts=[_parts(b.mesh) for b in scene.statics],
    )


def _face_colours(mesh, colour) -> np.ndarray:
    """(F, 3) float32 linear base colours: the file's materials', else the scene's ``colour``
    (sRGB, or None: :data:`NO_COLOUR`)."""
    given = np.full(3, NO_COLOUR) if colour is None else srgb_to_linear(colour)
    faces = np.tile(given.astype(np.float32), (len(mesh.faces), 1))
    if FILE_COLOUR in mesh.face_attributes:
        from_file = np.asarray(mesh.face_attributes[FILE_COLOUR], np.float32).reshape(-1, 3)
        has = from_file[:, 0] >= 0.0
        faces[has] = from_file[has]
    return faces


def srgb_to_linear(srgb) -> np.ndarray:
    """sRGB components in [0, 1] as linear RGB (the sRGB transfer function, inverted)."""
    c = np.clip(np.asarray(srgb, np.float64), 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _parts(mesh) -> np.ndarray:
    if FILE_PART not in mesh.face_attributes:  # an analytic shape: one connected piece
        return np.zeros(len(mesh.faces), np.int64)
    return mesh_parts(mesh.vertices, mesh.faces, mesh.face_attributes[FILE_PART])


Piece = tuple[int, np.ndarray]
"""Some faces of one static: its index and its faces' (local) indices. A method that clumps
parts orders the index buffer by pieces, so that each clump's faces lie side by side."""


@dataclass
class IndexLayout:
    """The index buffer's order, in units: a floor, a character, a static or a piece of one.

    Closed volumes come first, open meshes after ``n_closed`` indices, so the shading pass
    draws each group in one call, with and without back-face culling.
    """

    indices: np.ndarray               # (3 * F,) uint32
    spans: np.ndarray                 # (U, 2): each unit's first index and index count
    object_units: list[list[int]]     # per object: its units
    piece_units: list[int]            # per piece given to :func:`layout`: its unit
    n_closed: int                     # indices of closed volumes, at the start

    def ranges(self, objects) -> list[tuple[int, int]]:
        """Draw ranges (first, count) covering the objects, adjacent ranges merged."""
        return self._merged(u for o in objects for u in self.object_units[o])

    def piece_ranges(self, pieces) -> list[tuple[int, int]]:
        """Draw ranges covering the pieces (indices into the pieces given to :func:`layout`)."""
        return self._merged(self.piece_units[p] for p in pieces)

    def _merged(self, units) -> list[tuple[int, int]]:
        spans = sorted((int(self.spans[u, 0]), int(self.spans[u, 1])) for u in units
                       if self.spans[u, 1] > 0)
        merged: list[tuple[int, int]] = []
        for first, count in spans:
            if merged and merged[-1][0] + merged[-1][1] == first:
                merged[-1] = (merged[-1][0], merged[-1][1] + count)
            else:
                merged.append((first, count))
        return merged


def layout(geom: PackedGeometry, pieces: list[Piece] | None = None) -> IndexLayout:
    """Order the index buffer: closed volumes, then open meshes; within each, floors, statics
    (as ``pieces``, e.g. by clump, which must hold every static face once; whole statics in
    their order when None), characters.

    Putting each clump's pieces side by side lets its map be drawn in few calls.
    """
    units: list[tuple[int, np.ndarray | None]] = [(o, None) for o in range(geom.n_floors)]
    if pieces is None:
        units += [(geom.static_object(i), None) for i in range(geom.n_statics)]
    else:
        units += [(geom.static_object(i), faces) for i, faces in pieces]
    units += [(geom.character_object(i), None) for i in range(geom.n_characters)]
    order = ([u for u, (o, _) in enumerate(units) if geom.closed[o]]
             + [u for u, (o, _) in enumerate(units) if not geom.closed[o]])
    spans = np.zeros((len(units), 2), np.int64)
    object_units: list[list[int]] = [[] for _ in geom.triangles]
    chunks, position = [], 0
    for u in order:
        o, faces = units[u]
        tri = geom.triangles[o] if faces is None else geom.triangles[o][faces]
        spans[u] = position, 3 * len(tri)
        position += 3 * len(tri)
        chunks.append(tri.reshape(-1))
        object_units[o].append(u)
    indices = np.concatenate(chunks).astype(np.uint32) if chunks else np.zeros(0, np.uint32)
    n_closed = int(sum(spans[u, 1] for u in order if geom.closed[units[u][0]]))
    first_piece = geom.n_floors
    piece_units = list(range(first_piece, first_piece + len(pieces))) if pieces else []
    return IndexLayout(indices=indices, spans=spans, object_units=object_units,
                       piece_units=piece_units, n_closed=n_closed)
