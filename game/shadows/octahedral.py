"""The octahedral map of directions from a spot or point light, and which of its cells can see
each of the light's maps: the light space of a lamp's map grid (game/shadows/map_grid.py).

A cell's directions are spanned by eight of them (its corners and where the octahedron's fold
crosses it), so a cone round those eight holds the cell. A map is listed in a cell where the
cell's directions can meet the map's frustum and, when the map carries its casters' bounding
spheres, the cone from the light through one of them. Both tests are conservative.
"""

from __future__ import annotations

import functools

import numpy as np

from game.shadows.fit import MapFit

OCTAHEDRAL_GRID = 64      # cells per side; even, so that no cell straddles an octant boundary


def octahedral_decode(e: np.ndarray) -> np.ndarray:
    """Unit directions for octahedral coordinates (N, 2) in [-1, 1]^2."""
    e = np.asarray(e, float)
    z = 1.0 - np.abs(e[:, 0]) - np.abs(e[:, 1])
    x, y = e[:, 0].copy(), e[:, 1].copy()
    lower = z < 0
    x[lower] = (1.0 - np.abs(e[lower, 1])) * np.where(e[lower, 0] >= 0, 1.0, -1.0)
    y[lower] = (1.0 - np.abs(e[lower, 0])) * np.where(e[lower, 1] >= 0, 1.0, -1.0)
    d = np.stack([x, y, z], axis=1)
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def octahedral_encode(d: np.ndarray) -> np.ndarray:
    """Octahedral coordinates of directions (N, 3); the inverse of :func:`octahedral_decode`."""
    d = np.asarray(d, float)
    d = d / np.abs(d).sum(axis=1, keepdims=True)
    e = d[:, :2].copy()
    lower = d[:, 2] < 0
    sx = np.where(d[lower, 0] >= 0, 1.0, -1.0)
    sy = np.where(d[lower, 1] >= 0, 1.0, -1.0)
    e[lower, 0] = (1.0 - np.abs(d[lower, 1])) * sx
    e[lower, 1] = (1.0 - np.abs(d[lower, 0])) * sy
    return e


def _cell_points(size: int) -> np.ndarray:
    """Per cell, 8 octahedral points whose directions span the cell's cone of directions.

    A cell never straddles an axis (size is even), but the diamond |u| + |v| = 1 between the
    upper and lower hemispheres may cross it; the crossing points join the 4 corners, so the
    convex cone of the 8 directions holds the cell's whole cone.
    """
    edges = np.linspace(-1.0, 1.0, size + 1)
    u0, v0 = np.meshgrid(edges[:-1], edges[:-1])
    u1, v1 = np.meshgrid(edges[1:], edges[1:])
    u0, v0, u1, v1 = (a.ravel() for a in (u0, v0, u1, v1))
    su = np.where(u0 + u1 >= 0, 1.0, -1.0)
    sv = np.where(v0 + v1 >= 0, 1.0, -1.0)
    corners = [np.stack([u0, v0], 1), np.stack([u1, v0], 1), np.stack([u0, v1], 1),
               np.stack([u1, v1], 1)]
    extra = []
    # The diamond in this quadrant: su * u + sv * v = 1.
    for u in (u0, u1):
        v = sv * (1.0 - su * u)
        ok = (v >= v0) & (v <= v1)
        extra.append(np.stack([u, np.where(ok, v, v0)], 1))
    for v in (v0, v1):
        u = su * (1.0 - sv * v)
        ok = (u >= u0) & (u <= u1)
        extra.append(np.stack([np.where(ok, u, u0), v], 1))
    return np.stack(corners + extra, axis=1)  # (cells, 8, 2)


@functools.lru_cache(maxsize=4)
def _cell_directions(size: int) -> np.ndarray:
    """The unit directions of :func:`_cell_points`, (cells * 8, 3): the same for every light
    and frame, so made once."""
    directions = octahedral_decode(_cell_points(size).reshape(-1, 2))
    directions.flags.writeable = False
    return directions


@functools.lru_cache(maxsize=4)
def _cell_cones(size: int) -> tuple[np.ndarray, np.ndarray]:
    """Per cell a cone holding its cone of directions: the unit axis (cells, 3) through the mean
    of :func:`_cell_points`' directions and the widest angle (cells,) from it to one of them."""
    dirs = _cell_directions(size).reshape(-1, 8, 3)
    axis = dirs.sum(axis=1)
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    half = np.arccos(np.clip(np.einsum("cj,ckj->ck", axis, dirs), -1.0, 1.0)).max(axis=1)
    for a in (axis, half):
        a.flags.writeable = False
    return axis, half


def _sphere_cells(spheres: np.ndarray, eye: np.ndarray, grow: float, cells: np.ndarray,
                  size: int) -> np.ndarray:
    """Which of the cells ``cells`` (bool mask) have cones that meet the cone from ``eye``
    through one of ``spheres`` ((K, 4) centres and radii), its half-angle grown by ``grow``
    radians; the others stay False."""
    axis, half = _cell_cones(size)
    to = np.asarray(spheres, float)[:, :3] - eye
    dist = np.linalg.norm(to, axis=1)
    radius = np.asarray(spheres, float)[:, 3]
    inside = dist <= radius * (1.0 + 1e-6)   # the light within a sphere: every direction
    if inside.any():
        return cells.copy()
    cone = np.arcsin(np.clip(radius / dist, 0.0, 1.0)) + grow
    which = np.flatnonzero(cells)
    axis, half = axis[which], half[which]
    meet = np.zeros(len(which), bool)
    # In slices, so that a clump of thousands of pieces stays small in memory.
    for lo in range(0, len(to), 512):
        unit = to[lo:lo + 512] / dist[lo:lo + 512, None]
        apart = np.arccos(np.clip(axis @ unit.T, -1.0, 1.0))
        # A sliver of slack, as the shader computes the cell in float32.
        meet |= (apart <= half[:, None] + cone[None, lo:lo + 512] + 1e-4).any(axis=1)
    out = np.zeros(len(cells), bool)
    out[which] = meet
    return out


def map_hits(fits: list[MapFit], eye: np.ndarray,
             spheres: list[np.ndarray | None] | None = None, reach: float = 0.0,
             size: int = OCTAHEDRAL_GRID) -> tuple[np.ndarray, np.ndarray]:
    """The (cell, map) pairs, as two index arrays in cell order, where a cell of the ``size``
    grid over the directions from ``eye`` lists map j of ``fits``: its cone meets the map's
    frustum and, when ``spheres`` gives the map's casters, the cone through one of them grown
    by ``reach`` texels. Only the cells whose cones can meet the cone round the frustum are
    projected, so a narrow map (a walker's) costs a few cells, not the grid."""
    eye = np.asarray(eye, float)
    dirs = _cell_directions(size)
    axis, half = _cell_cones(size)
    cells = len(dirs) // 8
    hom = np.concatenate([eye + dirs, np.ones((len(dirs), 1))], axis=1).reshape(cells, 8, 4)
    hits = np.zeros((cells, len(fits)), bool)
    for j, fit in enumerate(fits):
        # A texel's offset of ``texel`` per metre of depth turns the ray by at most as many
        # radians.
        grow = reach * fit.texel
        near = _near_frustum(fit, eye, axis, half, grow)
        clip = hom[near] @ fit.view_proj.T
        w = clip[..., 3]
        front = w > 1e-12
        ndc = clip[..., :2] / np.where(front, w, 1.0)[..., None]
        lo = np.where(front[..., None], ndc, np.inf).min(axis=1)
        hi = np.where(front[..., None], ndc, -np.inf).max(axis=1)
        overlap = (lo[:, 0] <= 1) & (hi[:, 0] >= -1) & (lo[:, 1] <= 1) & (hi[:, 1] >= -1)
        hits[near, j] = np.where(front.all(axis=1), overlap, front.any(axis=1))
        own = spheres[j] if spheres is not None else None
        if own is not None and len(own):
            hits[:, j] = _sphere_cells(own, eye, grow, hits[:, j], size)
    return np.nonzero(hits)


def _near_frustum(fit: MapFit, eye: np.ndarray, axis: np.ndarray, half: np.ndarray,
                  grow: float) -> np.ndarray:
    """The cells (indices) whose cones (``axis``, ``half``) meet the cone from ``eye`` round
    the map's frustum, grown by ``grow`` radians; every cell where that cone is not narrower
    than a hemisphere, or the map looks from another point."""
    every = np.arange(len(axis))
    if not fit.perspective or not np.allclose(fit.eye, eye):
        return every
    try:
        inverse = np.linalg.inv(fit.view_proj)
    except np.linalg.LinAlgError:
        return every
    corners = np.array([[x, y, 0.0, 1.0] for x in (-1.0, 1.0) for y in (-1.0, 1.0)]) @ inverse.T
    if not np.all(np.abs(corners[:, 3]) > 1e-12):
        return every
    edges = corners[:, :3] / corners[:, 3:] - eye
    length = np.linalg.norm(edges, axis=1, keepdims=True)
    if not np.all(length > 1e-12):
        return every
    edges /= length
    centre = edges.sum(axis=0)
    if np.linalg.norm(centre) < 1e-9:
        return every
    centre /= np.linalg.norm(centre)
    width = float(np.arccos(np.clip(edges @ centre, -1.0, 1.0)).max()) + grow
    if width >= np.pi / 2:
        return every
    # A sliver of slack, as the shader computes the cell in float32.
    apart = np.arccos(np.clip(axis @ centre, -1.0, 1.0))
    return np.flatnonzero(apart <= half + width + 1e-4)
