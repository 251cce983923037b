"""Fitting one shadow map's projection tightly to one caster (a clump or a character).

Directional lights get orthographic maps in a common light space (rows of
``transforms.light_rotation``), so every map's footprint is a rectangle in the same plane and its
texel grid can be snapped to world-fixed positions. Spot and point lights get one perspective
frustum per caster, aimed from the light at the caster, and a caster set that surrounds a point
light gets the faces of a cube around it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from game import transforms

MARGIN_TEXELS = 1          # empty texels kept around each footprint (snapping needs one)
DEPTH_MARGIN = 0.01        # share of a map's depth range added before near and beyond far
MAX_TAN = math.tan(math.radians(80.0))  # widest half-angle of a perspective map
MIN_NEAR_SHARE = 1e-3      # nearest near plane, as a share of the caster's farthest depth


@dataclass(frozen=True)
class MapFit:
    """One map's projection and what the shading pass needs to know of it."""

    view_proj: np.ndarray   # (4, 4) world -> clip
    texel: float            # orthographic: metres per texel; perspective: per metre of depth
    perspective: bool
    eye: np.ndarray         # (3,) the light's position (perspective) or zeros
    rect: np.ndarray        # (4,) light-space footprint (orthographic maps), else the tan bounds
    near: float             # distances of the near and far planes along the map's view axis
    far: float


def fit_directional(points: np.ndarray, light_rot: np.ndarray, resolution: int,
                    radius: float | None = None,
                    depth_points: np.ndarray | None = None,
                    texel: float | None = None,
                    centre: np.ndarray | None = None) -> MapFit:
    """Orthographic map of ``points`` for a directional light.

    Parameters
    ----------
    points
        (N, 3) world-space points of the caster (its vertices).
    light_rot
        3x3 world-to-light rotation; light-space +z points towards the light.
    resolution
        Texels per side the map may use.
    radius
        For a moving caster: its bounding-sphere radius. The texel size then depends only on it,
        not on the caster's pose, so with the snapped origin the map moves in whole texels and
        the shadow does not shimmer as the caster walks and turns.
    depth_points
        More casters drawn into the map where they cross it (faces shared with other maps):
        they widen its depth range, not its rectangle.
    texel
        The texel size to keep (a group of moving casters keeps its finest member's, so its
        texels stay on the same world-fixed grid); the caster must fit ``resolution`` texels.
    centre
        With ``radius``: the light-space (x, y) the caster lies within ``radius`` of (a
        character's origin, about which its radius is measured), instead of the middle of
        ``points``; then ``points`` only need to bound its depth.
    """
    q = np.asarray(points, float) @ light_rot.T
    lo, hi = q.min(axis=0), q.max(axis=0)
    if depth_points is not None and len(depth_points):
        z = np.asarray(depth_points, float) @ light_rot[2]
        lo[2], hi[2] = min(lo[2], float(z.min())), max(hi[2], float(z.max()))
    if radius is not None:
        centre = (lo + hi) / 2 if centre is None else np.asarray(centre, float)
        half = radius
    else:
        centre = (lo + hi) / 2
        half = max(hi[0] - lo[0], hi[1] - lo[1]) / 2
    half = max(half, 1e-6 * max(1.0, float(np.abs(q).max())))
    return fit_squares(light_rot, np.array([centre[:2]], float), np.array([half], float),
                       np.array([lo[2]]), np.array([hi[2]]), np.array([resolution]),
                       np.array([np.nan if texel is None else texel]))[0]


def fit_squares(light_rot: np.ndarray, centres: np.ndarray, halves: np.ndarray,
                z_lo: np.ndarray, z_hi: np.ndarray, resolutions: np.ndarray,
                texels: np.ndarray) -> list[MapFit]:
    """Orthographic maps of many casters at once, each given by its light-space square
    (``centres`` (n, 2), ``halves``) and depth range (``z_lo``, ``z_hi``), at its resolution;
    a finite ``texels[k]`` is the texel size to keep (see :func:`fit_directional`), NaN fits
    the texels to the square.

    The square is snapped to the world-fixed texel grid with ``MARGIN_TEXELS`` of margin.
    """
    res = np.asarray(resolutions, float)
    usable = res - 2 * MARGIN_TEXELS - 1
    given = np.isfinite(texels)
    texel = np.where(given, texels, 2 * halves / usable)
    too_wide = given & (2 * halves > usable * texel * (1 + 1e-9))
    if too_wide.any():
        k = int(np.flatnonzero(too_wide)[0])
        raise ValueError(f"a caster {2 * halves[k]:.4g} wide does not fit {int(usable[k])} "
                         f"texels of {texel[k]:.4g}")
    x0 = (np.floor((centres[:, 0] - halves) / texel) - MARGIN_TEXELS) * texel
    y0 = (np.floor((centres[:, 1] - halves) / texel) - MARGIN_TEXELS) * texel
    x1, y1 = x0 + res * texel, y0 + res * texel
    margin = DEPTH_MARGIN * (z_hi - z_lo) + 2 * texel
    # View space looks down -z: a point at light-space z lies at distance -z.
    near, far = -z_hi - margin, -z_lo + margin
    view = np.eye(4)
    view[:3, :3] = light_rot
    view_proj = transforms.ortho_many(x0, x1, y0, y1, near, far) @ view
    rects = np.stack([x0, y0, x1, y1], axis=1)
    eye = np.zeros(3)
    eye.flags.writeable = False  # one for every fit
    return [MapFit(view_proj=v, texel=t, perspective=False, eye=eye, rect=r, near=n, far=f)
            for v, t, r, n, f in zip(view_proj, texel.tolist(), rects, near.tolist(),
                                     far.tolist(), strict=True)]


def fit_perspective(points: np.ndarray, eye: np.ndarray, resolution: int,
                    axis: np.ndarray | None = None, max_tan: float = MAX_TAN) -> MapFit | None:
    """Perspective map of ``points`` seen from a light at ``eye``; None if nothing is in front.

    The frustum is aimed at the caster's bounding-box centre (or along ``axis``) and bounded by
    the extreme directions of its points, at most ``max_tan`` either side of its axis, with
    square texels. Points at or behind the light's plane (a light inside a caster's bounds)
    cannot be held by one frustum; they are clipped at a near plane.
    """
    p = np.asarray(points, float)
    eye = np.asarray(eye, float)
    if axis is None:
        axis = (p.min(axis=0) + p.max(axis=0)) / 2 - eye
    if np.linalg.norm(axis) < 1e-9:
        axis = np.array([0.0, -1.0, 0.0])
    view = transforms.look_at(eye, eye + axis)
    v = transforms.transform_points(view, p)
    depth = -v[:, 2]
    far_depth = float(depth.max())
    if far_depth <= 0:
        return None
    near_floor = MIN_NEAR_SHARE * far_depth
    front = depth > near_floor
    tx = np.clip(v[front, 0] / depth[front], -max_tan, max_tan)
    ty = np.clip(v[front, 1] / depth[front], -max_tan, max_tan)
    if not front.all():
        # Part of the caster surrounds the light: widen to the maximum angle on those sides.
        tx = np.concatenate([tx, [-max_tan, max_tan]])
        ty = np.concatenate([ty, [-max_tan, max_tan]])
    lo = np.array([tx.min(), ty.min()])
    hi = np.array([tx.max(), ty.max()])
    usable = resolution - 2 * MARGIN_TEXELS - 1
    half = max(float((hi - lo).max()) / 2, 1e-9)
    texel = 2 * half / usable
    centre_t = (lo + hi) / 2
    x0 = centre_t[0] - half - MARGIN_TEXELS * texel
    y0 = centre_t[1] - half - MARGIN_TEXELS * texel
    size = resolution * texel
    # A triangle with a corner behind the near floor crosses every depth in front of it, down
    # to the floor: a near plane at its nearest corner in front would clip the part between.
    near = float(depth.min()) if front.all() else near_floor
    span = far_depth - near
    near = max(near - DEPTH_MARGIN * span, near_floor)
    far = far_depth + DEPTH_MARGIN * span + 1e-6 * far_depth
    proj = transforms.frustum(x0 * near, (x0 + size) * near, y0 * near, (y0 + size) * near,
                              near, far)
    return MapFit(view_proj=proj @ view, texel=texel, perspective=True, eye=eye.copy(),
                  rect=np.array([x0, y0, x0 + size, y0 + size]), near=near, far=far)


def outside_cone(points: np.ndarray, eye: np.ndarray, direction: np.ndarray,
                 cone_deg: float) -> bool:
    """True when a caster lies wholly outside a spot light's cone (it needs no map)."""
    centre = (points.min(axis=0) + points.max(axis=0)) / 2
    radius = float(np.linalg.norm(points - centre, axis=1).max())
    to_centre = centre - eye
    distance = float(np.linalg.norm(to_centre))
    if distance <= radius:
        return False
    half = math.radians(cone_deg / 2)
    angle = math.acos(np.clip(to_centre @ direction / distance, -1.0, 1.0))
    return angle - math.asin(min(1.0, radius / distance)) > half


# -- a light inside a caster's bounds ------------------------------------------------------------
# One frustum holds at most MAX_TAN either side of its axis. When a clump's casters surround the
# light, fit_perspective clips them at the near plane or at MAX_TAN and their shadows would be
# lost; such a clump gets the six faces of a cube around the light instead, each a 90-degree
# frustum (plus a texel margin) over the same casters.
CUBE_AXES = ((1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, -1.0, 0.0),
             (0.0, 0.0, 1.0), (0.0, 0.0, -1.0))


def holds_in_one_frustum(points: np.ndarray, eye: np.ndarray, max_tan: float = MAX_TAN) -> bool:
    """True when ``fit_perspective`` holds every point (none clipped by the near plane or angle)
    within ``max_tan`` of its axis."""
    p = np.asarray(points, float)
    eye = np.asarray(eye, float)
    axis = (p.min(axis=0) + p.max(axis=0)) / 2 - eye
    if np.linalg.norm(axis) < 1e-9:
        return False
    v = transforms.transform_points(transforms.look_at(eye, eye + axis), p)
    depth = -v[:, 2]
    far_depth = float(depth.max())
    if far_depth <= 0 or np.any(depth <= MIN_NEAR_SHARE * far_depth):
        return False
    return bool(np.all(np.abs(v[:, :2]) <= max_tan * depth[:, None]))


def fit_cube_faces(points: np.ndarray, eye: np.ndarray, resolution: int) -> list[MapFit]:
    """Perspective maps on the faces of a cube around ``eye`` that face any of ``points``."""
    p = np.asarray(points, float)
    eye = np.asarray(eye, float)
    extent = float(np.linalg.norm(p - eye, axis=1).max())
    usable = resolution - 2 * MARGIN_TEXELS - 1
    texel = 2.0 / usable
    half = 1.0 + MARGIN_TEXELS * texel  # a 90-degree face and a texel of overlap
    fits = []
    for axis in CUBE_AXES:
        view = transforms.look_at(eye, eye + np.array(axis))
        depth = -transforms.transform_points(view, p)[:, 2]
        if depth.max() <= 0:
            continue
        far = extent * (1.0 + DEPTH_MARGIN) + 1e-6 * extent
        near = max(MIN_NEAR_SHARE * far, 1e-9)
        x0 = y0 = -half
        size = resolution * texel
        proj = transforms.frustum(x0 * near, (x0 + size) * near, y0 * near, (y0 + size) * near,
                                  near, far)
        fits.append(MapFit(view_proj=proj @ view, texel=texel, perspective=True,
                           eye=eye.copy(), rect=np.array([x0, y0, x0 + size, y0 + size]),
                           near=near, far=far))
    return fits


def cube_face_reach(points: np.ndarray, eye: np.ndarray, reach: float | None = None
                    ) -> list[tuple[np.ndarray, float]]:
    """For each face of :func:`fit_cube_faces` (same faces, same order), the centre and the
    width of what it may hold: a face is as wide as twice the depth of the farthest point in
    front of it (what lies within its 90 degrees, a wall's middle between corners outside
    them among it, is no deeper), held to ``reach`` (a light's range: nothing beyond is lit)."""
    p = np.asarray(points, float) - np.asarray(eye, float)
    out = []
    for axis in CUBE_AXES:
        a = np.asarray(axis)
        far = float((p @ a).max())
        if far <= 0:
            continue
        if reach is not None:
            far = min(far, reach)
        out.append((np.asarray(eye, float) + a * far / 2, 2.0 * far))
    return out


def fit_spot(points: np.ndarray, eye: np.ndarray, direction: np.ndarray, cone_deg: float,
             resolution: int) -> MapFit | None:
    """Perspective map of ``points`` for a spot light: aimed along the light and no wider than
    its cone, since nothing outside the cone is lit. Casters on every side of the light give a
    map of the whole cone; None when no point is in front of the light."""
    half = math.radians(min(cone_deg, 179.0) / 2)
    return fit_perspective(points, eye, resolution, axis=np.asarray(direction, float),
                           max_tan=min(MAX_TAN, math.tan(half)))


CUBE_FACES = len(CUBE_AXES)
"""The most maps :func:`fits_for_light` gives one caster set (a point light's cube)."""


def deciding_points(points: np.ndarray, light_rot: np.ndarray | None) -> np.ndarray:
    """The points of a static caster that can decide its fit, computed once per light.

    Directional light (``light_rot`` given): the extremes along each light-space axis. Spot and
    point lights: every distinct point, because a perspective fit is aimed at the moving centre
    of all casters and any point of the convex hull may become the widest direction (the hull
    itself would need scipy).
    """
    if not len(points):
        return points
    if light_rot is not None:
        q = points @ light_rot.T
        return points[np.unique(np.concatenate([q.argmin(axis=0), q.argmax(axis=0)]))]
    return np.unique(points, axis=0)
