"""Shading normals: smooth across soft edges, hard across creases.

A triangle corner's shading normal is the mean of the normals of the triangles that meet at its
position, each weighted by its angle there (so a quad counts the same however it is split),
leaving out those that bend away from its own triangle by more than :data:`CREASE_ANGLE_DEG`.
So a sphere, a cylinder's side or a cone's side shades smoothly, while a box's edges, a
cylinder's rim and a roof's ridge stay hard. Corners are compared by position, not by vertex
index, so a mesh whose file splits vertices (texture seams) still shades smoothly across them.
A mesh file that gives its vertices normals (glTF NORMAL, OBJ ``vn``) is shaded with those
instead, where it gives them.

Only the shading pass reads these normals. The shadow bias, the dumps and the reference keep the
geometric normal of each triangle, so shading cannot move a shadow.
"""

from __future__ import annotations

import math

import numpy as np

CREASE_ANGLE_DEG = 40.0   # adjacent faces bending more than this keep a hard edge
# A position where more triangles meet than this (a fan's hub, a degenerate pile-up) is shaded
# flat: the work per corner grows with the number of its neighbours.
MAX_CORNER_VALENCE = 64
CREASED_DECIMALS = 5
FLAT_COS = 1.0 - 1e-6   # a corner normal this close to its triangle's is the triangle's


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit normals (zero for a degenerate face) and areas of every face."""
    corners = vertices[faces]
    cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    double_area = np.linalg.norm(cross, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = np.where(double_area[:, None] > 0.0, cross / double_area[:, None], 0.0)
    return unit, 0.5 * double_area


def corner_normals(vertices: np.ndarray, faces: np.ndarray,
                   crease_deg: float = CREASE_ANGLE_DEG) -> np.ndarray:
    """The shading normal of every corner, (F, 3, 3) float32 (zero where it is undefined)."""
    return _corners(np.asarray(vertices, np.float64), np.asarray(faces, np.int64),
                    crease_deg)[0]


def _corners(vertices: np.ndarray, faces: np.ndarray,
             crease_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`corner_normals`, and the faces' own unit normals (F, 3) float32 beside them."""
    n_faces = len(faces)
    if n_faces == 0:
        return np.zeros((0, 3, 3), np.float32), np.zeros((0, 3), np.float32)
    normal, _ = face_normals(vertices, faces)
    normal = normal.astype(np.float32)
    weighted = normal[np.repeat(np.arange(n_faces), 3)] * _corner_angles(vertices, faces)[:, None]
    # The corners, grouped by their welded position and, within that, largest groups first:
    # pass k below then works on a prefix of this order.
    corner_vertex = _welded(vertices)[faces.reshape(-1)]
    counts = np.bincount(corner_vertex)
    group_size = counts[corner_vertex]
    order = np.lexsort((corner_vertex, -group_size))
    sorted_vertex = corner_vertex[order]
    first = np.flatnonzero(np.r_[True, sorted_vertex[1:] != sorted_vertex[:-1]])
    size = np.diff(np.r_[first, len(order)])
    group_start = np.repeat(first, size)
    group_size = np.repeat(size, size)
    rank = np.arange(len(order)) - group_start
    face = order // 3
    # A group's sum is the same sum for each of its corners: corners whose every neighbour is
    # within the crease angle then get bit-identical normals and stay one vertex.
    group_total = np.add.reduceat(weighted[order], first, axis=0)
    total = group_total[np.repeat(np.arange(len(first)), size)]
    cos_crease = np.float32(math.cos(math.radians(crease_deg)))
    creased = np.zeros(len(order), bool)
    # The largest groups come first: those past MAX_CORNER_VALENCE are shaded flat, and pass k
    # below works on the groups of more than k corners that follow them.
    n_flat = int(np.searchsorted(-group_size, -MAX_CORNER_VALENCE, side="left"))
    # Pass k meets each corner with the corner k places after it in its group (cyclically), so
    # every ordered pair of a group is met once; a neighbour past the crease is taken out again.
    for k in range(1, min(int(size.max()), MAX_CORNER_VALENCE)):
        count = int(np.searchsorted(-group_size, -k, side="left"))
        if count <= n_flat:
            break
        span = slice(n_flat, count)
        other = order[group_start[span] + (rank[span] + k) % group_size[span]]
        hard = np.einsum("ij,ij->i", normal[face[span]], normal[other // 3]) <= cos_crease
        total[span][hard] -= weighted[other[hard]]
        creased[span] |= hard
    total[:n_flat] = normal[face[:n_flat]]
    length = np.linalg.norm(total, axis=1)
    unit = np.zeros_like(total)
    np.divide(total, length[:, None], out=unit, where=length[:, None] > 0.0)
    # A creased corner's sum lost its terms in an order of its own: rounded, the corners of one
    # side of a crease agree to the bit and share a vertex.
    unit[creased] = np.round(unit[creased], CREASED_DECIMALS)
    corners = np.empty_like(unit)
    corners[order] = unit
    return corners.reshape(n_faces, 3, 3), normal


def _corner_angles(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The angle of each triangle at each of its corners, (3F,) float32 radians."""
    corners = vertices[faces]
    a = np.roll(corners, -1, axis=1) - corners
    b = np.roll(corners, 1, axis=1) - corners
    la, lb = np.linalg.norm(a, axis=2), np.linalg.norm(b, axis=2)
    with np.errstate(invalid="ignore", divide="ignore"):
        cos = np.einsum("fkj,fkj->fk", a, b) / (la * lb)
    return np.arccos(np.clip(np.nan_to_num(cos, nan=1.0), -1.0, 1.0)).astype(np.float32).reshape(-1)


def _welded(vertices: np.ndarray) -> np.ndarray:
    """For each vertex, one index shared by every vertex at exactly its position."""
    if len(vertices) == 0:
        return np.zeros(0, np.int64)
    order = np.lexsort(vertices.T[::-1])
    ordered = vertices[order]
    new = np.r_[True, np.any(ordered[1:] != ordered[:-1], axis=1)]
    welded = np.empty(len(vertices), np.int64)
    welded[order] = np.cumsum(new) - 1
    return welded


def split_by_normal(vertices: np.ndarray, faces: np.ndarray,
                    crease_deg: float = CREASE_ANGLE_DEG, face_key: np.ndarray | None = None,
                    given: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices split where their corners' shading normals differ (or their faces'
    ``face_key`` rows, such as a colour). ``given``, (V, 3) unit normals with NaN rows, are
    the normals a mesh file gives its vertices: they replace the rule's where they are finite.

    Returns ``(source, normals, faces)``: for each new vertex the index of the vertex it copies
    and its unit shading normal (float32; zero where the corner is flat, its triangle's own
    normal), and the faces re-indexed. The triangles keep their exact positions; a vertex whose
    corners all share one normal and key stays one vertex.
    """
    faces = np.asarray(faces, np.int64)
    corners, own = _corners(np.asarray(vertices, np.float64), faces, crease_deg)
    normals = corners.reshape(-1, 3)
    if given is not None:
        from_file = np.asarray(given, np.float32)[faces.reshape(-1)]
        known = np.isfinite(from_file).all(axis=1)
        normals[known] = from_file[known]
    # A corner whose normal is its own triangle's carries none (zero): the shading pass then uses
    # the triangle's geometric normal, and the flat corners of a vertex stay one vertex, so a box
    # keeps its 8 vertices and a flat-sided level its vertex count.
    flat = np.einsum("ij,ij->i", normals, np.repeat(own, 3, axis=0)) > FLAT_COS
    normals[flat] = 0.0
    extra = (np.zeros((len(normals), 0), np.uint32) if face_key is None else
             np.repeat(np.ascontiguousarray(face_key, np.float32).reshape(len(faces), -1), 3,
                       axis=0).view(np.uint32))
    # One key per corner: its vertex, and a hash of its normal's (and face key's) bits; equal
    # keys become one vertex. Sorting one integer key is several times faster than sorting rows.
    bits = np.column_stack([normals.view(np.uint32), extra]).astype(np.uint64)
    mixed = np.zeros(len(bits), np.uint64)
    for column in range(bits.shape[1]):
        mixed = (mixed * np.uint64(0x9E3779B1) + bits[:, column]) & np.uint64(0xFFFFFFFF)
    keys = (faces.reshape(-1).astype(np.uint64) << np.uint64(32)) | mixed
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    source, split = faces.reshape(-1)[first], normals[first]
    rows = np.column_stack([normals.view(np.uint32), extra])
    if not np.array_equal(rows[first][inverse], rows):  # two corners of one vertex hashed alike
        rows = np.column_stack([faces.reshape(-1, 1).view(np.uint32).reshape(-1, 2), rows])
        _, first, inverse = np.unique(rows, axis=0, return_index=True, return_inverse=True)
        source, split = faces.reshape(-1)[first], normals[first]
    return source, np.ascontiguousarray(split), inverse.reshape(faces.shape)
