"""Matrix conventions, tested once and wrapped (tests/test_transforms.py).

Every matrix in this project is a float64 numpy array in the column-vector convention of
docs/reference.md: ``clip = proj @ view @ [x, y, z, 1]``. pyrr builds its matrices for row vectors
(``v @ M``), so each pyrr result is transposed here and nowhere else. Uploading to GLSL, whose
``mat4`` is column-major, takes the transpose's bytes: :func:`gl_bytes`.
"""

from __future__ import annotations

import numpy as np
from pyrr import matrix44

WORLD_UP = np.array([0.0, 1.0, 0.0])
# Below this |cos| between a view direction and the up vector, lookAt would be singular: use
# another up axis (the exactly vertical sun of the stability sweep).
UP_PARALLEL_COS = 0.99


def gl_bytes(m: np.ndarray) -> bytes:
    """The bytes of a column-vector matrix (or a stack of them) laid out as GLSL mat4 expects."""
    m = np.asarray(m, dtype=np.float32)
    return np.ascontiguousarray(np.swapaxes(m, -1, -2)).tobytes()


def up_for(direction: np.ndarray) -> np.ndarray:
    """An up vector that is never parallel to ``direction``."""
    return ups_for(np.asarray(direction, float)[None])[0]


def ups_for(directions: np.ndarray) -> np.ndarray:
    """(n, 3) up vectors, each never parallel to its row of ``directions``: the world's up, or
    near it the horizontal axis on the side the direction leans."""
    d = np.asarray(directions, float)
    d = d / np.linalg.norm(d, axis=-1)[:, None]
    side = np.where((d[:, 1] < 0)[:, None], [0.0, 0.0, -1.0], [0.0, 0.0, 1.0])
    return np.where((np.abs(d @ WORLD_UP) < UP_PARALLEL_COS)[:, None], WORLD_UP, side)


def look_at(eye: np.ndarray, target: np.ndarray, up: np.ndarray | None = None) -> np.ndarray:
    """World-to-view matrix of a camera at ``eye`` looking at ``target`` (view looks down -Z)."""
    eye = np.asarray(eye, float)
    target = np.asarray(target, float)
    if up is None:
        up = up_for(target - eye)
    return matrix44.create_look_at(eye, target, np.asarray(up, float), dtype=np.float64).T


def light_rotation(direction: np.ndarray) -> np.ndarray:
    """3x3 rotation whose rows are the light-space x, y, z axes, z = -direction.

    Light-space xy is the plane of a directional light's maps; a larger z is nearer the light.
    """
    return look_at(np.zeros(3), np.asarray(direction, float))[:3, :3]


def perspective(fov_y_deg: float, aspect: float, near: float, far: float) -> np.ndarray:
    """OpenGL perspective projection (NDC z in [-1, 1])."""
    return matrix44.create_perspective_projection(fov_y_deg, aspect, near, far, dtype=np.float64).T


def frustum(left: float, right: float, bottom: float, top: float, near: float, far: float
            ) -> np.ndarray:
    """Off-centre perspective projection; the bounds are on the near plane."""
    return matrix44.create_perspective_projection_from_bounds(
        left, right, bottom, top, near, far, dtype=np.float64).T


def ortho_many(left: np.ndarray, right: np.ndarray, bottom: np.ndarray, top: np.ndarray,
               near: np.ndarray, far: np.ndarray) -> np.ndarray:
    """(n, 4, 4) OpenGL orthographic projections, one per element of the bounds; near and far
    are distances along -Z and may be negative. Built with numpy, not pyrr, since a frame fits
    a hundred character maps at once (the same arithmetic as pyrr's, to the bit)."""
    m = np.zeros((len(left), 4, 4))
    m[:, 0, 0] = 2.0 / (right - left)
    m[:, 1, 1] = 2.0 / (top - bottom)
    m[:, 2, 2] = -2.0 / (far - near)
    m[:, 0, 3] = -(right + left) / (right - left)
    m[:, 1, 3] = -(top + bottom) / (top - bottom)
    m[:, 2, 3] = -(far + near) / (far - near)
    m[:, 3, 3] = 1.0
    return m


def look_at_many(eyes: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """(n, 4, 4) world-to-view matrices, one per row of ``eyes`` and ``targets``, each as
    :func:`look_at` makes it with its own :func:`up_for` (pyrr's arithmetic, with numpy: a
    frame plans a map from each of many points of a light)."""
    eyes = np.asarray(eyes, float)
    forward = np.asarray(targets, float) - eyes
    forward = forward / np.sqrt(np.sum(forward ** 2, axis=-1))[:, None]
    side = np.cross(forward, ups_for(forward))
    side = side / np.sqrt(np.sum(side ** 2, axis=-1))[:, None]
    up = np.cross(side, forward)
    up = up / np.sqrt(np.sum(up ** 2, axis=-1))[:, None]
    m = np.zeros((len(eyes), 4, 4))
    m[:, 0, :3], m[:, 1, :3], m[:, 2, :3] = side, up, -forward
    m[:, 0, 3] = -np.sum(side * eyes, axis=1)
    m[:, 1, 3] = -np.sum(up * eyes, axis=1)
    m[:, 2, 3] = np.sum(forward * eyes, axis=1)
    m[:, 3, 3] = 1.0
    return m


def frustum_many(left: np.ndarray, right: np.ndarray, bottom: np.ndarray, top: np.ndarray,
                 near: np.ndarray, far: np.ndarray) -> np.ndarray:
    """(n, 4, 4) off-centre perspective projections, one per element of the bounds, each as
    :func:`frustum` makes it (pyrr's arithmetic, with numpy)."""
    m = np.zeros((len(left), 4, 4))
    m[:, 0, 0] = 2.0 * near / (right - left)
    m[:, 1, 1] = 2.0 * near / (top - bottom)
    m[:, 0, 2] = (right + left) / (right - left)
    m[:, 1, 2] = (top + bottom) / (top - bottom)
    m[:, 2, 2] = -(far + near) / (far - near)
    m[:, 2, 3] = -2.0 * far * near / (far - near)
    m[:, 3, 2] = -1.0
    return m


def translation(t: np.ndarray) -> np.ndarray:
    """4x4 translation."""
    m = np.eye(4)
    m[:3, 3] = t
    return m


def euler_xyz(degrees: np.ndarray) -> np.ndarray:
    """3x3 rotation for Euler angles about X first, then Y, then Z: R = Rz @ Ry @ Rx."""
    ax, ay, az = np.radians(np.asarray(degrees, float))
    cx, sx, cy, sy, cz, sz = np.cos(ax), np.sin(ax), np.cos(ay), np.sin(ay), np.cos(az), np.sin(az)
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def transform_points(m: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a 4x4 affine matrix to (N, 3) points."""
    p = np.asarray(points, float)
    return p @ m[:3, :3].T + m[:3, 3]


def project_points(m: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a 4x4 projective matrix to (N, 3) points, returning homogeneous (N, 4) clip coords."""
    p = np.asarray(points, float)
    return p @ m[:, :3].T + m[:, 3]
