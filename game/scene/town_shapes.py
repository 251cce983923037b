"""The shapes of a generated town (game/scene/generate.py): buildings and trees.

Templates (unit box, unit cylinder, unit sphere, unit cone) are built once per detail level, and
every building or tree is made by scaling and offsetting template vertices with numpy; trimesh
only wraps the final arrays, with ``process=False``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np
import trimesh

from game.scene.shapes import transform_mesh
from game.transforms import euler_xyz

STOREY_HEIGHT = 3.0  # metres
WINDOW_PITCH_AT_DETAIL_0 = 4.0  # metres between window centres; divided by (1 + detail)
WINDOW_HEIGHT = 1.4  # metres
WINDOW_SILL_Y = 0.9  # metres above each storey's floor
WINDOW_PROTRUSION = 0.12  # metres a window frame stands out of the wall
LEDGE_PROTRUSION = 0.2  # metres a storey ledge or the cornice stands out of the wall
LEDGE_THICKNESS = 0.25  # metres
CORNICE_HEIGHT = 0.6  # metres
ROOF_HOUSING_HEIGHT = 2.5  # metres
MAX_CROWN_SUBDIVISIONS = 5  # icosphere subdivisions at the highest detail (20480 triangles)


# --------------------------------------------------------------------------------------------
# Templates and instancing


_UNIT_BOX = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
_BOX_CORNERS = np.asarray(_UNIT_BOX.vertices, dtype=np.float64) + 0.5  # in [0, 1]^3
BOX_FACES = np.asarray(_UNIT_BOX.faces, dtype=np.int64)


def boxes(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (8N, 3) and faces (12N, 3) of N axis-aligned boxes from corners (N, 3)."""
    lo, hi = np.atleast_2d(lo), np.atleast_2d(hi)
    vertices = lo[:, None, :] + (hi - lo)[:, None, :] * _BOX_CORNERS[None]
    faces = BOX_FACES[None] + 8 * np.arange(len(lo))[:, None, None]
    return vertices.reshape(-1, 3), faces.reshape(-1, 3)


def mesh_of(parts: list[tuple[np.ndarray, np.ndarray]]) -> trimesh.Trimesh:
    """One mesh from (vertices, faces) parts, offsetting the face indices."""
    offsets = np.cumsum([0] + [len(v) for v, _ in parts[:-1]])
    vertices = np.concatenate([v for v, _ in parts])
    faces = np.concatenate([f + o for (_, f), o in zip(parts, offsets, strict=True)])
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)


@dataclass(frozen=True)
class Templates:
    """Unit meshes for the trees as (vertices, faces), built once per detail level."""

    trunk: tuple[np.ndarray, np.ndarray]  # radius 1, height 1, along +Y, centred
    sphere: tuple[np.ndarray, np.ndarray]  # radius 1, centred
    cone: tuple[np.ndarray, np.ndarray]  # radius 1, height 1, apex up, base at y = 0


def _arrays(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64)


@functools.lru_cache(maxsize=8)
def templates_for(detail: int) -> Templates:
    # trimesh builds cylinders and cones along +Z, the cone's base at z = 0.
    z_to_y = euler_xyz([-90.0, 0.0, 0.0])
    trunk = trimesh.creation.cylinder(radius=1.0, height=1.0, sections=6 + 2 * detail)
    sphere = trimesh.creation.icosphere(subdivisions=min(detail + 1, MAX_CROWN_SUBDIVISIONS))
    cone = trimesh.creation.cone(radius=1.0, height=1.0, sections=8 * (detail + 1))
    return Templates(trunk=_arrays(transform_mesh(trunk, z_to_y)), sphere=_arrays(sphere),
                     cone=_arrays(transform_mesh(cone, z_to_y)))


def place(template: tuple[np.ndarray, np.ndarray], scale: Any,
          offset: Any) -> tuple[np.ndarray, np.ndarray]:
    """A template scaled per axis, then moved by ``offset``."""
    vertices, faces = template
    return vertices * np.asarray(scale) + np.asarray(offset), faces


# --------------------------------------------------------------------------------------------
# Buildings and trees


def _window_boxes(centre: np.ndarray, half: np.ndarray, axis: int, sign: float, storeys: int,
                  pitch: float, sills: bool) -> tuple[np.ndarray, np.ndarray]:
    """Corners (lo, hi) of the window frames (and sills) of the facade facing ``sign * axis``.

    Frames straddle the wall plane, so half of each box is hidden inside the building and the
    other half stands out by WINDOW_PROTRUSION; no box needs to know which side is outside.
    """
    other = 2 - axis  # the facade's horizontal direction: x for a z-facing facade and back
    span = 2.0 * half[other]
    columns = max(1, int(span // pitch))
    width = 0.6 * span / columns
    u = centre[other] - half[other] + (np.arange(columns) + 0.5) * span / columns
    y = np.arange(storeys) * STOREY_HEIGHT + WINDOW_SILL_Y
    uu, yy = (a.ravel() for a in np.meshgrid(u, y))
    wall = centre[axis] + sign * half[axis]
    lo, hi = np.empty((len(uu), 3)), np.empty((len(uu), 3))
    lo[:, other], hi[:, other] = uu - 0.5 * width, uu + 0.5 * width
    lo[:, 1], hi[:, 1] = yy, yy + WINDOW_HEIGHT
    lo[:, axis], hi[:, axis] = wall - WINDOW_PROTRUSION, wall + WINDOW_PROTRUSION
    if not sills:
        return lo, hi
    sill_lo, sill_hi = lo.copy(), hi.copy()
    sill_lo[:, other] -= 0.1
    sill_hi[:, other] += 0.1
    sill_lo[:, 1], sill_hi[:, 1] = yy - 0.12, yy
    sill_lo[:, axis], sill_hi[:, axis] = wall - 2 * WINDOW_PROTRUSION, wall + 2 * WINDOW_PROTRUSION
    return np.concatenate([lo, sill_lo]), np.concatenate([hi, sill_hi])


def building_mesh(rng: np.random.Generator, x: float, z: float, width: float, depth: float,
                  storeys: int, detail: int) -> trimesh.Trimesh:
    """A box building standing on y = 0 with a cornice, a roof housing, ledges and windows."""
    height = storeys * STOREY_HEIGHT
    centre = np.array([x, 0.0, z])
    half = np.array([0.5 * width, 0.0, 0.5 * depth])
    p = LEDGE_PROTRUSION
    lo = [[x - half[0], 0.0, z - half[2]], [x - half[0] - p, height, z - half[2] - p]]
    hi = [[x + half[0], height, z + half[2]],
          [x + half[0] + p, height + CORNICE_HEIGHT, z + half[2] + p]]
    # The roof housing stands on the cornice, somewhere on the roof.
    hw, hd = 0.5 * width * rng.uniform(0.2, 0.4), 0.5 * depth * rng.uniform(0.2, 0.4)
    hx = x + rng.uniform(-1.0, 1.0) * (half[0] - hw)
    hz = z + rng.uniform(-1.0, 1.0) * (half[2] - hd)
    top = height + CORNICE_HEIGHT
    lo.append([hx - hw, top, hz - hd])
    hi.append([hx + hw, top + ROOF_HOUSING_HEIGHT, hz + hd])
    if detail >= 1:  # a ledge slab through the building between storeys
        ys = np.arange(1, storeys) * STOREY_HEIGHT
        for y in ys:
            lo.append([x - half[0] - p, y - 0.5 * LEDGE_THICKNESS, z - half[2] - p])
            hi.append([x + half[0] + p, y + 0.5 * LEDGE_THICKNESS, z + half[2] + p])
    los, his = [np.array(lo)], [np.array(hi)]
    pitch = WINDOW_PITCH_AT_DETAIL_0 / (1 + detail)
    for axis in (0, 2):
        for sign in (-1.0, 1.0):
            w_lo, w_hi = _window_boxes(centre, half, axis, sign, storeys, pitch, detail >= 2)
            los.append(w_lo)
            his.append(w_hi)
    return mesh_of([boxes(np.concatenate(los), np.concatenate(his))])


def tree_mesh(templates: Templates, x: float, z: float, crown: float, trunk: float,
              conifer: bool) -> trimesh.Trimesh:
    """A trunk standing on y = 0 with a cone or sphere crown that overlaps its top."""
    trunk_radius = 0.08 + 0.08 * crown
    parts = [place(templates.trunk, (trunk_radius, trunk, trunk_radius), (x, 0.5 * trunk, z))]
    if conifer:
        parts.append(place(templates.cone, (crown, 2.5 * crown, crown), (x, 0.6 * trunk, z)))
    else:
        parts.append(place(templates.sphere, crown, (x, trunk + 0.75 * crown, z)))
    return mesh_of(parts)
