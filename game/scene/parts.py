"""A static mesh split into parts, so that a level that arrives as one mesh file can be clumped.

Clumps are groups of parts, never of whole ``[[static]]`` entries only: a level of 125,000
triangles in one file would otherwise get one map. A mesh is split by its file's own structure
first (the objects and material groups of an OBJ, the nodes and primitives of a glTF: see
game/scene/mesh_files.py), then into connected components (triangles that share a corner, with
corners at the same position welded, since files duplicate them across normals and UVs). Where
that gives more than :data:`MAX_PARTS` parts (a triangle soup), neighbouring parts are merged by
a median split of their centres until :data:`MAX_PARTS` groups are left, so what the clumping
works on stays bounded whatever the file holds.
"""

from __future__ import annotations

import re
from typing import BinaryIO

import numpy as np

MAX_PARTS = 4096
"""Most parts one mesh is split into: the clumping handles tens of thousands of objects, and
one entry must leave room for the rest of the level."""

OBJ_SCAN_BYTES = 16 * 2**20
"""How much of an OBJ file :func:`obj_part_count` holds at a time."""
_OBJ_STATEMENT = re.compile(rb"^[ \t]*(o|g|usemtl)(?:[ \t]+([^\n]*))?$", re.M)
_OBJ_FACE = re.compile(rb"^[ \t]*f[ \t]", re.M)

WELD_SHARE = 1e-6
"""Corners closer than this share of the mesh's largest extent are one corner."""


def _welded(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``faces`` over welded vertex ids: corners at the same position share one id."""
    if not len(vertices):
        return faces
    low = vertices.min(axis=0)
    step = max(float(np.ptp(vertices, axis=0).max()) * WELD_SHARE, 1e-12)
    keys = np.round((vertices - low) / step).astype(np.int64)
    _, ids = np.unique(keys, axis=0, return_inverse=True)
    return ids.reshape(-1)[faces]


def connected_components(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Per face, the index (0..n-1) of its connected component.

    Label propagation with pointer jumping over the welded corners: every round hooks each
    triangle's corners to their smallest label, then shortcuts the label chains, so the rounds
    grow with the logarithm of a component's size rather than its diameter.
    """
    if not len(faces):
        return np.zeros(0, np.int64)
    corners = _welded(np.asarray(vertices, float), np.asarray(faces, np.int64))
    label = np.arange(int(corners.max()) + 1)
    while True:
        lowest = label[corners].min(axis=1)
        hooked = label.copy()
        for k in range(3):
            np.minimum.at(hooked, label[corners[:, k]], lowest)
        while True:
            jumped = hooked[hooked]
            if np.array_equal(jumped, hooked):
                break
            hooked = jumped
        if np.array_equal(hooked, label):
            break
        label = hooked
    return np.unique(label[corners[:, 0]], return_inverse=True)[1].reshape(-1)


def median_groups(centres: np.ndarray, count: int) -> np.ndarray:
    """Per centre, one of at most ``count`` groups of neighbours: a recursive median split
    along the axis of largest spread, halving the group count each level."""
    labels = np.zeros(len(centres), np.int64)
    if count <= 1 or len(centres) <= count:
        return np.arange(len(centres)) if count > 1 else labels
    next_label = 0
    stack = [(np.arange(len(centres)), count)]
    while stack:
        members, groups = stack.pop()
        if groups <= 1 or len(members) <= 1:
            labels[members] = next_label
            next_label += 1
            continue
        points = centres[members]
        axis = int(np.argmax(np.ptp(points, axis=0)))
        order = members[np.argsort(points[:, axis], kind="stable")]
        left_groups = groups // 2
        cut = len(order) * left_groups // groups
        stack.append((order[cut:], groups - left_groups))
        stack.append((order[:cut], left_groups))
    return labels


def mesh_parts(vertices: np.ndarray, faces: np.ndarray, file_parts: np.ndarray | None = None,
               limit: int = MAX_PARTS) -> np.ndarray:
    """Per face, its part (0..n-1, n <= ``limit``): the file's structure (``file_parts``, one
    label per face, or None), then connected components, then median groups of their centres
    where there are more than ``limit``."""
    faces = np.asarray(faces, np.int64)
    if not len(faces):
        return np.zeros(0, np.int64)
    components = connected_components(vertices, faces)
    if file_parts is not None:
        keys = np.stack([np.asarray(file_parts, np.int64), components], axis=1)
        components = np.unique(keys, axis=0, return_inverse=True)[1].reshape(-1)
    n = int(components.max()) + 1
    if n <= limit:
        return components
    centroids = np.asarray(vertices, float)[faces].mean(axis=1)
    sums = np.zeros((n, 3))
    np.add.at(sums, components, centroids)
    centres = sums / np.bincount(components, minlength=n)[:, None]
    return median_groups(centres, limit)[components]


def obj_part_count(obj: BinaryIO, limit: int) -> int:
    """How many parts trimesh would split an OBJ file (open for reading at its start) into, by
    object (``o``), group (``g``) and material (``usemtl``): the distinct (object, group,
    material) names that hold faces. One streaming pass over the file, stopping once the count
    passes ``limit``."""
    current: dict[bytes, bytes | None] = {b"o": None, b"g": None, b"usemtl": None}
    seen: set[tuple] = set()
    carry = b""
    while len(seen) <= limit:
        block = obj.read(OBJ_SCAN_BYTES)
        text = carry + block
        cut = text.rfind(b"\n") + 1 if block else len(text)
        text, carry = text[:cut], text[cut:]
        start = 0
        for statement in _OBJ_STATEMENT.finditer(text):
            if _OBJ_FACE.search(text, start, statement.start()):
                seen.add(tuple(current.values()))
            current[statement.group(1)] = (statement.group(2) or b"").strip()
            start = statement.end()
        if _OBJ_FACE.search(text, start):
            seen.add(tuple(current.values()))
        if not block:
            break
    return len(seen)
