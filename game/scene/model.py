"""The scene model: one camera, hard-shadow lights, an optional linear light, and rigid objects.

Floors and statics are stored in world space, so nothing downstream needs their transforms;
characters keep a local mesh and are placed every frame by :meth:`Character.model_matrix`.
"""

from __future__ import annotations

import functools
import hashlib
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

DEFAULT_FOV_DEG = 60.0
DEFAULT_NEAR = 0.1  # metres
DEFAULT_FAR = 200.0  # metres
DEFAULT_SPEED = 1.0  # metres per second
LIGHT_KINDS = ("directional", "spot", "point")


@dataclass(frozen=True)
class Camera:
    """The start view: a look-at camera with a vertical field of view in degrees."""

    position: np.ndarray
    target: np.ndarray
    fov: float = DEFAULT_FOV_DEG
    near: float = DEFAULT_NEAR
    far: float = DEFAULT_FAR


@dataclass(frozen=True)
class Light:
    """The hard-shadow light.

    ``direction`` is the unit vector the light travels along (directional and spot), ``position``
    its origin (spot and point), ``cone`` the full cone angle in degrees (spot). Fields a kind
    does not use are None.
    """

    kind: str
    direction: np.ndarray | None
    position: np.ndarray | None
    cone: float | None
    color: tuple[float, float, float] = (1.0, 1.0, 1.0)  # sRGB in [0, 1]
    intensity: float = 1.0
    range: float | None = None   # spot and point: metres beyond which it lights nothing

    @property
    def parallel(self) -> bool:
        """Whether its rays are parallel (a sun or a moon: no position)."""
        return self.kind == "directional"

    def reaches(self, centre: np.ndarray, radius: float) -> bool:
        """Whether any point of the sphere (``centre``, ``radius``) is within the light's range
        (and, for a spot light, its cone)."""
        if self.position is None:
            return True
        offset = np.asarray(centre, float) - self.position
        distance = float(np.linalg.norm(offset))
        if self.range is not None and distance - radius > self.range:
            return False
        if self.kind == "spot" and distance > radius:
            # The cone widened by the sphere's angular radius.
            angle = math.degrees(math.acos(float(np.clip(offset @ self.direction / distance,
                                                         -1.0, 1.0))))
            return angle - math.degrees(math.asin(radius / distance)) <= self.cone / 2
        return True


@dataclass(frozen=True)
class LinearLight:
    """The soft-shadow light: the segment from ``a`` to ``b``."""

    a: np.ndarray
    b: np.ndarray


@dataclass
class Body:
    """A floor or a static object, its mesh already in world space."""

    name: str
    kind: str
    mesh: trimesh.Trimesh
    colour: np.ndarray | None = None   # sRGB in [0, 1] (the file's `color`); None: a palette's


@dataclass
class Character:
    """A rigid shape walking a closed loop.

    ``mesh`` is in local space: analytic shapes are centred on the origin, mesh files keep their
    own coordinates; the optional rotation and scale keys are already applied. The walk adds a yaw
    about +Y that turns local +Z to the direction of travel, then the translation to the path.
    """

    name: str
    mesh: trimesh.Trimesh
    path: np.ndarray
    speed: float
    phase: float
    colour: np.ndarray | None = None   # sRGB in [0, 1] (the file's `color`); None: a palette's

    def pose(self, t: float) -> tuple[np.ndarray, float]:
        """Position (3,) and yaw in radians about +Y at scene time ``t`` seconds.

        The position is the point at arc length ``speed * (t + phase)`` along the closed path
        (last point back to the first), modulo the loop length. The yaw is ``atan2(dx, dz)`` of
        the segment being walked, so local +Z faces the direction of travel. A one-point path
        stands still with yaw 0.
        """
        points, deltas, lengths, starts, loop = self._segments
        if len(points) == 1 or loop <= 0.0:
            return points[0].copy(), 0.0
        s = (self.speed * (t + self.phase)) % loop
        if s >= loop:  # float modulo of a tiny negative number can return the divisor itself
            s = 0.0
        # The last segment starting at or before s; zero-length segments share their start with
        # the next one, so side="right" skips them and the yaw never comes from a zero vector.
        i = int(np.searchsorted(starts, s, side="right")) - 1
        f = (s - starts[i]) / lengths[i]
        position = points[i] + f * deltas[i]
        yaw = math.atan2(float(deltas[i, 0]), float(deltas[i, 2]))
        return position, yaw

    @functools.cached_property
    def _segments(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
        """The closed path's points, segment vectors, lengths and start arc lengths, and the
        loop's length: the same every frame, so worked out once (a crowd poses every walker
        every frame)."""
        points = np.asarray(self.path, dtype=np.float64)
        deltas = np.roll(points, -1, axis=0) - points
        lengths = np.linalg.norm(deltas, axis=1)
        starts = np.concatenate(([0.0], np.cumsum(lengths)[:-1]))
        return points, deltas, lengths, starts, float(lengths.sum())

    def model_matrix(self, t: float) -> np.ndarray:
        """The (4, 4) local-to-world matrix at time ``t``: ``T(position) @ Ry(yaw)``."""
        position, yaw = self.pose(t)
        c, s = math.cos(yaw), math.sin(yaw)
        m = np.eye(4)
        m[:3, :3] = [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
        m[:3, 3] = position
        return m


@dataclass
class Scene:
    """A loaded scene: the view, the lights and every object, in file order within each kind.

    ``lights`` holds the hard-shadow lights in file order (one ``[light]`` table or a
    ``[[light]]`` array); :attr:`light` is the first, whose visibility the dumps' ``lit`` holds.
    """

    name: str
    source: Path | None
    camera: Camera
    lights: list[Light]
    linear_light: LinearLight | None
    floors: list[Body]
    statics: list[Body]
    characters: list[Character]
    sha256: str = ""  # of the scene file's bytes (of the text, for a scene given as text)

    @property
    def light(self) -> Light:
        return self.lights[0]

    @light.setter
    def light(self, light: Light) -> None:
        self.lights[0] = light

    @property
    def given(self) -> str:
        """How the stats and dumps name the scene: its file's path as given, else its name."""
        return str(self.source) if self.source else self.name

    @property
    def folder_name(self) -> str:
        """The scene's name as one safe path component: ``captures/<folder_name>/``.

        A name is free text, so anything but letters (of any script), digits, ``.``, ``_`` and
        ``-`` becomes ``_``, and leading dots go: a name such as ``../x`` cannot leave
        ``captures/``. A name that had to change gets six hex digits of its own hash, so that
        two names never share a folder (``a/b`` and ``a b``).
        """
        for candidate in (self.name, self.source.stem if self.source else ""):
            safe = re.sub(r"[^\w.-]", "_", candidate).lstrip(".")[:100]
            if safe.strip("_"):
                if safe != candidate:
                    safe += "-" + hashlib.sha256(candidate.encode()).hexdigest()[:6]
                return safe
        return "scene"

    def object_names(self) -> list[str]:
        """Floors, then statics, then characters: the global object index used everywhere."""
        return ([b.name for b in self.floors] + [b.name for b in self.statics]
                + [c.name for c in self.characters])
