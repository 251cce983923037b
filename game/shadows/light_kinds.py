"""What differs between light kinds, for planning shadow maps: one class per kind.

A scene file names a light's kind as a string (game/scene/); everything that plans maps asks
the kind object of :func:`kind_of` instead: how casters are seen from the light (the footprint
clumping works in), how a map is fitted to them, how many maps one caster set may take, and
from where a map looks. Adding a light kind means one class here, plus the GLSL that shades it
(shaders/shadow.glsl, the ``LIGHT_KINDS`` codes of game/gpu/blocks.py).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from game import transforms
from game.scene.model import Light
from game.shadows import clumping
from game.shadows.fit import (
    CUBE_FACES,
    MAX_TAN,
    MapFit,
    fit_cube_faces,
    fit_directional,
    fit_perspective,
    fit_spot,
    holds_in_one_frustum,
    outside_cone,
)
from game.shadows.octahedral import octahedral_encode

# A clump around a point light gets one frustum only when it is no wider than a cube face (45
# degrees either side of its axis): a wider one spreads its texels thinner than the faces do.
CUBE_FACE_TAN = 1.0

Footprint = Callable[[np.ndarray], np.ndarray]


class LightKind:
    """The shadow-map rules of one kind of light. Stateless: one instance per kind."""

    name = ""
    # Orthographic maps in one light space (a rectangle footprint per caster), or perspective
    # maps from the light's position.
    orthographic = False
    # The most maps one caster set may need (a cube's faces around a point light).
    max_maps_per_caster = 1
    # The widest half-angle tangent of one frustum holding a clump (perspective kinds).
    widest_tan = MAX_TAN
    # What :meth:`engine_fits` gives, in words.
    engine_maps = ""

    def eye(self, light: Light) -> np.ndarray | None:
        """Where the maps look from: the light's position, None for parallel light."""
        return np.asarray(light.position, float)

    def rotation(self, light: Light) -> np.ndarray | None:
        """The common world-to-light rotation of orthographic maps; None for perspective."""
        return None

    def limits_reach(self, light: Light) -> bool:
        """Whether a range or a cone keeps the light from reaching every caster."""
        return light.range is not None

    def finest_extent(self, light: Light, side: int, base_side: int) -> float | None:
        """The widest a clump may be, in footprint units, for its map of ``side`` texels to
        be no coarser than the baselines' map of ``base_side`` texels for this light; None
        where the density target alone bounds clumps (parallel light: its target, in metres,
        holds at every distance, as its maps' texels do)."""
        return None

    def footprint(self, light: Light, statics: list[np.ndarray]) -> tuple[Footprint, float]:
        """The light-space footprint function clumping measures casters with, and its units
        per metre at the casters' typical distance."""
        raise NotImplementedError

    def fit(self, light: Light, points: np.ndarray, resolution: int,
            rotation: np.ndarray | None, radius: float | None = None) -> MapFit | None:
        """One tight map of a caster (a character or a clump's frustum); None where the light
        cannot shadow it."""
        return fit_perspective(points, light.position, resolution)

    def one_frustum(self, light: Light, points: np.ndarray) -> bool:
        """Whether one map holds the caster ``points`` (else a cube's faces)."""
        return holds_in_one_frustum(points, light.position, self.widest_tan)

    def clump_fits(self, light: Light, points: np.ndarray, resolution: int,
                   rotation: np.ndarray | None, cube: bool,
                   depth_points: np.ndarray | None = None) -> list[MapFit]:
        """A clump's maps: the faces of a cube around the light (``cube``), else one map."""
        if cube:
            return fit_cube_faces(points, light.position, resolution)
        fit = self.fit(light, points, resolution, rotation)
        return [fit] if fit is not None else []

    def engine_fits(self, light: Light, points: np.ndarray, resolution: int,
                    rotation: np.ndarray | None) -> list[MapFit]:
        """The maps an engine gives one caster set (the baselines): see each kind."""
        raise NotImplementedError


class Directional(LightKind):
    """Parallel light (a sun, a moon): orthographic maps in one light space."""

    name = "directional"
    orthographic = True
    engine_maps = "one over every caster"

    def eye(self, light: Light) -> np.ndarray | None:
        return None

    def rotation(self, light: Light) -> np.ndarray | None:
        return transforms.light_rotation(light.direction)

    def limits_reach(self, light: Light) -> bool:
        return False

    def footprint(self, light: Light, statics: list[np.ndarray]) -> tuple[Footprint, float]:
        return clumping.directional_footprint(transforms.light_rotation(light.direction)), 1.0

    def fit(self, light: Light, points: np.ndarray, resolution: int,
            rotation: np.ndarray | None, radius: float | None = None) -> MapFit | None:
        return fit_directional(points, rotation, resolution, radius)

    def one_frustum(self, light: Light, points: np.ndarray) -> bool:
        return True

    def clump_fits(self, light: Light, points: np.ndarray, resolution: int,
                   rotation: np.ndarray | None, cube: bool,
                   depth_points: np.ndarray | None = None) -> list[MapFit]:
        return [fit_directional(points, rotation, resolution, depth_points=depth_points)]

    def engine_fits(self, light: Light, points: np.ndarray, resolution: int,
                    rotation: np.ndarray | None) -> list[MapFit]:
        """One orthographic map over every point."""
        return [fit_directional(points, rotation, resolution)]


class Spot(LightKind):
    """A lamp with a cone: perspective maps; nothing outside the cone is lit."""

    name = "spot"
    engine_maps = "one over the cone"

    def limits_reach(self, light: Light) -> bool:
        return True

    def footprint(self, light: Light, statics: list[np.ndarray]) -> tuple[Footprint, float]:
        eye = np.asarray(light.position, float)
        typical = _typical_distance(eye, statics)
        view = transforms.look_at(eye, eye + light.direction)

        def spot(points: np.ndarray) -> np.ndarray:
            v = transforms.transform_points(view, points)
            depth = np.maximum(-v[:, 2], 1e-6 * typical)
            return v[:, :2] / depth[:, None]

        return spot, 1.0 / typical

    def one_frustum(self, light: Light, points: np.ndarray) -> bool:
        # A cone no wider than a cube's face: one map over it holds everything the light can
        # shadow, in one layer where a cube takes six, with texels no coarser than a face's.
        return _cone_tan(light) <= CUBE_FACE_TAN or super().one_frustum(light, points)

    def finest_extent(self, light: Light, side: int, base_side: int) -> float | None:
        # The baselines' one map spans the cone's tangents.
        return side * 2.0 * _cone_tan(light) / base_side

    def fit(self, light: Light, points: np.ndarray, resolution: int,
            rotation: np.ndarray | None, radius: float | None = None) -> MapFit | None:
        if outside_cone(points, light.position, light.direction, light.cone):
            return None
        own = fit_perspective(points, light.position, resolution)
        # A caster wider than the cone (a level's walls before the lamp) needs no texels
        # outside it: nothing there is lit. Aimed along the light and held to the cone, its
        # map is then no coarser than the engine's one map over the cone. A caster that
        # reaches behind the lamp (the lamp on it or among it) takes the map over the cone
        # too: its own map, aimed at its middle and widened around the lamp, may miss part
        # of the cone.
        behind = float(((points - light.position) @ light.direction).min()) <= 0.0
        if own is None or (not behind and (own.rect[2] - own.rect[0]) / 2 <= _cone_tan(light)):
            return own
        cone = fit_spot(points, light.position, light.direction, light.cone, resolution)
        return cone if cone is not None and (behind or cone.texel < own.texel) else own

    def engine_fits(self, light: Light, points: np.ndarray, resolution: int,
                    rotation: np.ndarray | None) -> list[MapFit]:
        """One perspective map over the cone."""
        fit = fit_spot(points, light.position, light.direction, light.cone, resolution)
        return [fit] if fit is not None else []


class Point(LightKind):
    """A lamp shining every way: one frustum per caster, or a cube's faces around the light."""

    name = "point"
    engine_maps = "one frustum, or a cube's faces around the light"
    max_maps_per_caster = CUBE_FACES
    widest_tan = CUBE_FACE_TAN

    def footprint(self, light: Light, statics: list[np.ndarray]) -> tuple[Footprint, float]:
        eye = np.asarray(light.position, float)
        typical = _typical_distance(eye, statics)

        def point(points: np.ndarray) -> np.ndarray:
            d = np.asarray(points, float) - eye
            # A caster's vertex at the light (a lamp on a wall's corner) has no direction: it
            # is NaN, which object_summaries skips; the caster's other points span its cone.
            at_light = ~d.any(axis=1)
            if not at_light.any():
                return octahedral_encode(d)
            d[at_light] = 1.0
            e = octahedral_encode(d)
            e[at_light] = np.nan
            return e

        # An octahedral unit spans about pi/2 radians.
        return point, 1.0 / (typical * math.pi / 2)

    def finest_extent(self, light: Light, side: int, base_side: int) -> float | None:
        # A face of the baselines' cube spans pi/2 radians, about one octahedral unit.
        return side / base_side

    def engine_fits(self, light: Light, points: np.ndarray, resolution: int,
                    rotation: np.ndarray | None) -> list[MapFit]:
        """One frustum, or the faces of a cube when the casters surround the light."""
        if holds_in_one_frustum(points, light.position):
            fit = fit_perspective(points, light.position, resolution)
            return [fit] if fit is not None else []
        return fit_cube_faces(points, light.position, resolution)


def _cone_tan(light: Light) -> float:
    """The tangent of a spot light's half-angle, as :func:`fit_spot` holds its map."""
    return math.tan(math.radians(min(light.cone, 179.0) / 2))


def _typical_distance(eye: np.ndarray, statics: list[np.ndarray]) -> float:
    """The median distance from the light to the casters' centres (at least a micrometre)."""
    distances = [np.linalg.norm(p.mean(axis=0) - eye) for p in statics] or [1.0]
    return max(float(np.median(distances)), 1e-6)


KINDS: dict[str, LightKind] = {kind.name: kind for kind in (Directional(), Spot(), Point())}


def kind_of(light: Light) -> LightKind:
    """The shadow-map rules of ``light``'s kind."""
    return KINDS[light.kind]


def fits_for_light(points: np.ndarray, light: Light, rotation: np.ndarray | None,
                   resolution: int) -> list[MapFit]:
    """The maps that hold ``points`` for a scene light, as an engine would give one caster set
    (:meth:`LightKind.engine_fits`); empty when there are no points, or none the light can
    reach."""
    if not len(points):
        return []
    return kind_of(light).engine_fits(light, points, resolution, rotation)
