"""The analytic shapes of the scene format (docs/reference.md, section 1), built with trimesh.

Every shape is centred on the origin with its axis along +Y, as the format defines them.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import trimesh

from game.scene.mesh_files import FILE_NORMAL, turn_normals
from game.transforms import euler_xyz

SPHERE_SUBDIVISIONS = 2  # icosphere, 320 triangles
ROUND_SECTIONS = 24  # segments around cylinders and cones
CAPSULE_COUNT = (16, 16)  # (around, along) segments of trimesh's capsule


def transform_mesh(mesh: trimesh.Trimesh, linear: np.ndarray,
                   translation: np.ndarray | None = None) -> trimesh.Trimesh:
    """``linear @ v + translation`` for every vertex, keeping the faces outward-facing.

    A mirroring transform (negative determinant) turns every triangle's winding inside out, so
    the faces are flipped back.
    """
    vertices = np.asarray(mesh.vertices, dtype=np.float64) @ np.asarray(linear).T
    if translation is not None:
        vertices = vertices + translation
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if np.linalg.det(linear) < 0:
        faces = faces[:, ::-1]
    vertex_attributes = {}
    if FILE_NORMAL in mesh.vertex_attributes:  # a file's normals turn with its vertices
        vertex_attributes[FILE_NORMAL] = turn_normals(
            np.asarray(mesh.vertex_attributes[FILE_NORMAL], np.float64), linear)
    return trimesh.Trimesh(vertices=vertices, faces=np.ascontiguousarray(faces), process=False,
                           face_attributes=dict(mesh.face_attributes),
                           vertex_attributes=vertex_attributes)


def _plain(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """A copy with float64 vertices and int64 faces and nothing cached."""
    return trimesh.Trimesh(vertices=np.asarray(mesh.vertices, dtype=np.float64),
                           faces=np.asarray(mesh.faces, dtype=np.int64), process=False)


# trimesh builds cylinders, capsules and cones along +Z; turning -90 degrees about X maps +Z to +Y.
_Z_TO_Y = euler_xyz([-90.0, 0.0, 0.0])


def box_mesh(size: Iterable[float]) -> trimesh.Trimesh:
    """An axis-aligned box of ``size`` = [x, y, z], centred on the origin."""
    return _plain(trimesh.creation.box(extents=np.asarray(list(size), dtype=np.float64)))


def sphere_mesh(radius: float) -> trimesh.Trimesh:
    """An icosphere of ``radius``, centred on the origin."""
    return _plain(trimesh.creation.icosphere(subdivisions=SPHERE_SUBDIVISIONS, radius=radius))


def cylinder_mesh(radius: float, height: float) -> trimesh.Trimesh:
    """A cylinder along +Y, centred on the origin."""
    mesh = trimesh.creation.cylinder(radius=radius, height=height, sections=ROUND_SECTIONS)
    return transform_mesh(mesh, _Z_TO_Y)


def capsule_mesh(radius: float, height: float) -> trimesh.Trimesh:
    """A capsule along +Y, centred on the origin; ``height`` is the total including both caps."""
    # trimesh's `height` is the distance between the cap centres.
    mesh = trimesh.creation.capsule(height=height - 2.0 * radius, radius=radius,
                                    count=list(CAPSULE_COUNT))
    return transform_mesh(mesh, _Z_TO_Y)


def cone_mesh(radius: float, height: float) -> trimesh.Trimesh:
    """A cone along +Y with its apex up, its bounding box centred on the origin."""
    # trimesh puts the base at z = 0 and the apex at z = height.
    mesh = trimesh.creation.cone(radius=radius, height=height, sections=ROUND_SECTIONS)
    return transform_mesh(mesh, _Z_TO_Y, np.array([0.0, -0.5 * height, 0.0]))
