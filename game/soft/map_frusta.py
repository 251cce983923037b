"""Where the raster soft methods' depth maps look: one perspective frustum from each point of the
segment, fitted around the frame's receivers.

Planning only, numpy, no GL: :func:`plan` turns the G-buffer's covered points into one
:class:`MapFrustum` per light point, and the maps are drawn by game/soft/light_maps.py. Every map
of a frame covers the same receivers, so a receiver is inside all of them or none.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from game import transforms

# The nearest a near plane may be, as a share of the far one: a 32-bit float depth keeps
# millimetres at this ratio over the scenes' tens of metres.
NEAR_SHARE = 1e-3
# The widest a map may look, as the tangent of its half-angle (about 72 degrees). Receivers
# beside or behind a light point fall outside its map, and a lookup outside a map reads lit.
MAX_TAN = 3.0
# The receivers' hull is made of the cells of a grid of the scene's diagonal over this many
# cells, so a camera that moves a little keeps the same frusta, and the statics' maps cached.
SNAP_CELLS = 32
# Texels of margin around the receivers on each side of a map, so that the lookups' filters
# near a map's edge still read inside it.
EDGE_TEXELS = 2.0
FAR_MARGIN = 1.01  # the far plane beyond the farthest receiver corner
CONE_PASSES = 16   # passes of the cone around the receivers (each takes in the farthest corner)


@dataclass(frozen=True)
class MapFrustum:
    """One perspective depth map from a point of the segment."""

    eye: np.ndarray         # (3,) the light point
    view_proj: np.ndarray   # (4, 4) world -> clip
    near: float
    far: float
    texel: float            # metres per texel per metre of depth (the map's wider side)


def segment_points(a: np.ndarray, b: np.ndarray, count: int, phase: float = 0.5) -> np.ndarray:
    """``count`` points along the segment, one in each of its equal parts, at ``phase`` of the
    part (0.5: their centres): (count, 3)."""
    t = (np.arange(count) + phase) / count
    a = np.asarray(a, np.float64)
    return a + t[:, None] * (np.asarray(b, np.float64) - a)


def receiver_bounds(positions: np.ndarray, covered: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The box (lo, hi) of the covered G-buffer points; an empty frame gives a unit box at the
    origin (nothing reads its maps)."""
    points = _covered_points(positions, covered)
    if not len(points):
        return np.zeros(3), np.ones(3)
    return points.min(axis=0).astype(np.float64), points.max(axis=0).astype(np.float64)


def _covered_points(positions: np.ndarray, covered: np.ndarray) -> np.ndarray:
    """The finite xyz of the covered points, in raster order. Each coordinate is tested apart:
    numpy's ``all`` along a short last axis costs more than the three tests."""
    ok = covered.copy()
    for axis in range(3):
        ok &= np.isfinite(positions[..., axis])
    return positions[ok][:, :3]


def receiver_cells(positions: np.ndarray, covered: np.ndarray, cell: float) -> np.ndarray:
    """The corners (M, 3) of the grid cells of ``cell`` metres that hold a covered G-buffer
    point: a hull of the receivers that follows their shape (a box around a wide floor and a
    tall tower would take in the empty air beside the tower), snapped to the grid so that a
    camera that moves a little keeps the same corners. An empty frame gives a unit cell at the
    origin (nothing reads its maps)."""
    points = _covered_points(positions, covered)
    if not len(points):
        return box_corners(np.zeros(3), np.ones(3))
    # Axis by axis (3, N): numpy reduces the rows of an (N, 3) array many times slower.
    cells = np.floor(points.T.astype(np.float64) / cell).astype(np.int64)
    lo = cells.min(axis=1)
    span = cells.max(axis=1) - lo + 2  # room for the far corners too
    # One integer per cell: np.unique on integers is a sort, where on rows it is many times
    # slower; neighbouring pixels mostly share a cell, so repeats in a row go before the sort.
    d = cells - lo[:, None]
    keys = (d[0] * span[1] + d[1]) * span[2] + d[2]
    keys = np.unique(keys[np.r_[True, keys[1:] != keys[:-1]]])
    offsets = box_corners(np.zeros(3), np.ones(3)).astype(np.int64)
    keys = np.unique((keys[:, None] + (offsets * np.array([span[1] * span[2], span[2], 1])
                                       ).sum(axis=1)[None]).ravel())
    corners = np.stack([keys // (span[1] * span[2]), keys // span[2] % span[1], keys % span[2]],
                       axis=1) + lo
    return corners * cell


def box_corners(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The 8 corners of an axis-aligned box, (8, 3)."""
    pick = np.array([[(i >> k) & 1 for k in range(3)] for i in range(8)], bool)
    return np.where(pick, hi, lo)


def _distance_to_box(points: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Each point's (n, 3) distance to the box, 0 inside it."""
    return np.linalg.norm(np.maximum(np.maximum(lo - points, points - hi), 0.0), axis=1)


def _axes(eyes: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Where a map from each of ``eyes`` (n, 3) looks: the axis of a narrow cone around the
    directions to the corners (Ritter's bounding sphere, "An Efficient Bounding Sphere", 1990,
    on the unit sphere), so the widest corner is as near the axis as it can be; the direction to
    the corners' centre would leave a light above one side of a wide floor looking past the
    floor's near edge. Every eye's cone grows in the same passes, each until it holds all."""
    to = corners[None] - eyes[:, None]                               # (n, m, 3)
    length = np.linalg.norm(to, axis=2)
    ok = length > 1e-9                      # a corner at the eye has no direction
    to = np.where(ok[..., None], to / np.where(ok, length, 1.0)[..., None], 0.0)
    rows = np.arange(len(eyes))
    axis = to.sum(axis=1)
    norm = np.linalg.norm(axis, axis=1)
    first = to[rows, np.argmax(ok, axis=1)]
    axis = np.where((norm > 1e-9)[:, None], axis / np.where(norm > 1e-9, norm, 1.0)[:, None],
                    first)
    angle = np.zeros(len(eyes))
    growing = ok.any(axis=1)
    for _ in range(CONE_PASSES):
        cos = np.where(ok, np.clip((to @ axis[:, :, None])[..., 0], -1.0, 1.0), 2.0)
        far = np.argmin(cos, axis=1)
        cos_far = cos[rows, far]
        widest = np.arccos(np.minimum(cos_far, 1.0))
        growing &= widest > angle
        # Grow the cone just enough to hold the farthest direction, turning its axis toward it.
        side = to[rows, far] - cos_far[:, None] * axis
        side_norm = np.linalg.norm(side, axis=1)
        growing &= side_norm >= 1e-12
        if not growing.any():
            break
        turn = (widest - angle) / 2
        side = side / np.where(growing, side_norm, 1.0)[:, None]
        turned = np.cos(turn)[:, None] * axis + np.sin(turn)[:, None] * side
        axis = np.where(growing[:, None], turned, axis)
        angle = np.where(growing, (widest + angle) / 2, angle)
    axis = np.where(ok.any(axis=1)[:, None], axis, -transforms.WORLD_UP)
    return axis / np.linalg.norm(axis, axis=1)[:, None]


def fit(eye: np.ndarray, corners: np.ndarray, casters: tuple[np.ndarray, np.ndarray],
        resolution: int) -> MapFrustum:
    """The tightest perspective map from ``eye`` around the receivers' hull ``corners`` (M, 3),
    with its near plane no farther than the casters' box (no caster between a receiver and the
    eye is clipped)."""
    return plan(np.asarray(eye, np.float64)[None], corners, casters, resolution)[0]


def plan(points: np.ndarray, corners: np.ndarray, casters: tuple[np.ndarray, np.ndarray],
         resolution: int) -> list[MapFrustum]:
    """One frustum per light point (rows of ``points``), each the tightest perspective map from
    it around the same receivers' hull ``corners`` (M, 3), with its near plane no farther than
    the casters' box (no caster between a receiver and the eye is clipped). All points at once:
    a frame plans a map from each of many points of the segment."""
    eyes = np.asarray(points, np.float64).reshape(-1, 3)
    corners = np.asarray(corners, np.float64)
    views = transforms.look_at_many(eyes, eyes + _axes(eyes, corners))
    local = corners @ np.swapaxes(views[:, :3, :3], 1, 2) + views[:, None, :3, 3]
    depth = -local[..., 2]
    far = np.maximum(depth.max(axis=1), 1e-3) * FAR_MARGIN
    # Where the receivers reach beside or behind the eye, the map is as wide as a map may look.
    ahead = (depth > (far * NEAR_SHARE)[:, None]).all(axis=1)
    safe = np.where(ahead[:, None], depth, 1.0)
    tx, ty = local[..., 0] / safe, local[..., 1] / safe
    left = np.where(ahead, np.maximum(tx.min(axis=1), -MAX_TAN), -MAX_TAN)
    right = np.where(ahead, np.minimum(tx.max(axis=1), MAX_TAN), MAX_TAN)
    bottom = np.where(ahead, np.maximum(ty.min(axis=1), -MAX_TAN), -MAX_TAN)
    top = np.where(ahead, np.minimum(ty.max(axis=1), MAX_TAN), MAX_TAN)
    pad = EDGE_TEXELS / resolution
    grow_x, grow_y = (right - left) * pad, (top - bottom) * pad
    left, right, bottom, top = left - grow_x, right + grow_x, bottom - grow_y, top + grow_y
    # A point at distance d from the eye inside the frustum is at depth d * cos(angle) or more.
    widest = np.maximum(abs(left), abs(right)) ** 2 + np.maximum(abs(bottom), abs(top)) ** 2
    nearest = _distance_to_box(eyes, *casters) / np.sqrt(1.0 + widest)
    near = np.minimum(np.maximum(nearest, far * NEAR_SHARE), far * 0.5)
    proj = transforms.frustum_many(left * near, right * near, bottom * near, top * near, near,
                                   far)
    texel = np.maximum(right - left, top - bottom) / resolution
    view_proj = proj @ views
    return [MapFrustum(eye=eyes[k], view_proj=view_proj[k], near=float(near[k]),
                       far=float(far[k]), texel=float(texel[k])) for k in range(len(eyes))]


def frusta_key(frusta: list[MapFrustum], resolution: int) -> bytes:
    """What the statics' maps depend on: every map's matrix and the resolution."""
    parts = [np.asarray(resolution, np.int64).tobytes()]
    parts += [np.ascontiguousarray(f.view_proj).tobytes() for f in frusta]
    return b"".join(parts)
