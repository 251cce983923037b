"""``csm``: cascaded shadow maps, the default of Bevy, Godot and Filament.

The view frustum is cut at the practical split distances (Zhang et al., "Parallel-split shadow
maps", 2006: a blend, ``lambda``, of logarithmic and uniform splits), each slice gets an
orthographic map fitted to its bounding sphere (so its texel size never changes as the camera
turns) and snapped to whole texels (no shimmering as it moves), and every cascade is re-rendered
every frame. The shading pass reads the finest cascade that holds the fragment
(shaders/shadow.glsl). Same depth array, bias rules and shading pass as ``clumped``.
"""

from __future__ import annotations

import math

import numpy as np

from game import transforms
from game.errors import GameError
from game.scene.geometry import PackedGeometry
from game.scene.model import Light
from game.shadows.fit import (
    MapFit,
    deciding_points,
    fit_squares,
)
from game.shadows.light_kinds import fits_for_light, kind_of
from game.shadows.method import ShadowMethod, reached_characters, reached_statics
from game.shadows.plan import (
    KIND_ALL,
    KIND_CASCADE,
    MapRecord,
    ShadowPlan,
    ShadowSettings,
    map_names,
)


def split_distances(near: float, far: float, count: int, blend: float) -> np.ndarray:
    """The practical split scheme: ``count + 1`` distances from ``near`` to ``far``.

    ``blend`` = 1 gives logarithmic splits (equal texel density per depth ratio), 0 uniform.
    """
    i = np.arange(count + 1) / count
    log = near * (far / near) ** i
    uniform = near + (far - near) * i
    d = blend * log + (1.0 - blend) * uniform
    d[0], d[-1] = near, far
    return d


def slice_corners(view: np.ndarray, proj: np.ndarray, d0: float, d1: float) -> np.ndarray:
    """(8, 3) world-space corners of the view frustum between view depths ``d0`` and ``d1``."""
    tx, ty = 1.0 / proj[0, 0], 1.0 / proj[1, 1]
    corners = np.array([[sx * tx * d, sy * ty * d, -d] for d in (d0, d1)
                        for sx in (-1, 1) for sy in (-1, 1)])
    return transforms.transform_points(np.linalg.inv(view), corners)


def bounding_sphere(points: np.ndarray) -> tuple[np.ndarray, float]:
    """A sphere holding a frustum slice, exact for its symmetric shape (centre on the axis)."""
    near, far = points[:4], points[4:]
    a, b = near.mean(axis=0), far.mean(axis=0)
    rn2 = float(np.sum((near[0] - a) ** 2))
    rf2 = float(np.sum((far[0] - b) ** 2))
    length = float(np.linalg.norm(b - a))
    if length < 1e-12:
        return a, math.sqrt(max(rn2, rf2))
    # Centre at distance s from a along the axis, equidistant from both rims, clamped to [0, L].
    s = float(np.clip((length ** 2 + rf2 - rn2) / (2 * length), 0.0, length))
    centre = a + (b - a) * (s / length)
    return centre, math.sqrt(max(s * s + rn2, (length - s) ** 2 + rf2))


def fit_cascade(centre_l: np.ndarray, radius: float, z_lo: float, z_hi: float,
                light_rot: np.ndarray, resolution: int) -> MapFit:
    """Orthographic map of a slice's bounding sphere, snapped to the world-fixed texel grid.

    ``centre_l`` is the sphere's centre in light space; ``z_lo``..``z_hi`` the light-space depth
    range the map holds.
    """
    return fit_squares(light_rot, np.array([centre_l[:2]], float), np.array([radius], float),
                       np.array([z_lo]), np.array([z_hi]), np.array([resolution]),
                       np.array([np.nan]))[0]


def _figure(x: float, digits: int = 2) -> str:
    """``digits`` significant figures, never in e-notation: a huge scene's texels are metres
    wide and its receivers kilometres away."""
    return f"{x:.{digits}g}" if x < 10 ** digits else f"{x:.0f}"


class CascadedShadows(ShadowMethod):
    """Cascaded shadow maps for a directional light, all re-rendered every frame.

    The shadow distance is the camera's far plane, cut to the farthest corner of the scene's
    bounds (engines expose it as a setting; past the scene nothing receives a shadow). Each
    cascade draws only the casters whose light-space rectangle meets it. Spot and point lights
    have no cascades in engines; there this method draws the maps of ``single`` at
    ``cascade_resolution`` (one map over a spot light's cone; one frustum, or a cube's faces,
    around a point light) and says so in ``notes``.
    """

    name = "csm"
    summary = "cascaded shadow maps over the view frustum, all re-rendered every frame"
    resolution_fields = ("cascade_resolution",)
    parameters = ("cascades", "cascade_lambda", "cascade_resolution")

    @classmethod
    def min_layers(cls, settings: ShadowSettings, n_characters: int) -> int:
        return settings.cascades

    def __init__(self, geom: PackedGeometry, light: Light, settings: ShadowSettings,
                 max_layers: int, max_maps: int | None = None):
        super().__init__(geom, light, settings, max_layers, max_maps)
        if kind_of(light).orthographic and settings.cascades > max_layers:
            # Refused here, before the driver is asked for the array or the block for the maps.
            raise GameError(f"csm: {settings.cascades} cascades are more maps than a light may "
                            f"have on this GL ({max_layers}: the array's layers and the map "
                            "records, shared by the lights); use fewer --cascades")
        self.set_light(light)

    @property
    def layers(self) -> int:
        kind = kind_of(self.light)
        return self.settings.cascades if kind.orthographic else kind.max_maps_per_caster

    @property
    def resolution(self) -> int:
        return self.settings.cascade_resolution

    def set_light(self, light: Light) -> None:
        self.light = light
        g = self.geom
        # The scene's bounds, which the cascades' far distance reaches to.
        bounds = (g.positions.min(axis=0), g.positions.max(axis=0)) if len(
            g.positions) else (np.zeros(3), np.zeros(3))
        self._corners = np.array([[x, y, z] for x in (bounds[0][0], bounds[1][0])
                                  for y in (bounds[0][1], bounds[1][1])
                                  for z in (bounds[0][2], bounds[1][2])], float)
        kind = kind_of(light)
        if not kind.orthographic:
            self.note(f"csm: cascades need a directional light; for a {light.kind} light it "
                      f"draws the maps of single at cascade_resolution ({kind.engine_maps})")
            self._light_rot = None
            self._statics = reached_statics(g, light)
            points = [g.static_points[i] for i in self._statics]
            self._static_points = deciding_points(
                np.concatenate(points) if points else np.zeros((0, 3)), None)
            return
        self._light_rot = transforms.light_rotation(light.direction)
        # Light-space boxes of the statics, once per light: per-cascade culling is then a
        # rectangle test per static.
        boxes = [np.concatenate([(p @ self._light_rot.T).min(axis=0),
                                 (p @ self._light_rot.T).max(axis=0)]) for p in g.static_points]
        self._static_boxes = np.array(boxes).reshape(-1, 6)
        self._static_objects = np.array([g.static_object(i) for i in range(g.n_statics)], int)

    def _shadow_far(self, view: np.ndarray, near: float, far: float) -> float:
        depths = -transforms.transform_points(view, self._corners)[:, 2]
        return float(np.clip(depths.max(), near * 1.001, far))

    def splits(self, view) -> np.ndarray:
        """The view depths where the cascades meet, from the camera's near plane to the
        shadow distance (``cascades + 1`` of them)."""
        s = self.settings
        near = self._near(view)
        far = self._shadow_far(view.view, near, self._far(view))
        return split_distances(near, far, s.cascades, s.cascade_lambda)

    def view_note(self, view, maps: list[MapRecord], nearest: float) -> str | None:
        """Where half the cascades or more end before the nearest receiver in view, most of
        the maps are spent on empty space, and every shadow takes one of the wide slices that
        the practical split meant for the distance. A camera high above the scene is the
        common case; a nearest receiver past the first split alone is the scheme at work."""
        if self._light_rot is None or not maps or not np.isfinite(nearest):
            return None
        splits = self.splits(view)
        first = int(np.searchsorted(splits[1:-1], nearest, side="right"))
        if 2 * first < len(maps):
            return None
        empty = ("cascade 0, which ends" if first == 1
                 else f"cascades 0-{first - 1}, which end")
        texels = sorted(record.fit.texel * 100.0 for record in maps[first:])
        width = (f"{_figure(texels[0])} cm" if texels[-1] < texels[0] * 1.05
                 else f"{_figure(texels[0])}-{_figure(texels[-1])} cm")
        return (f"csm: nothing in view is nearer than {_figure(nearest, 3)} m, so {empty} at "
                f"{_figure(splits[first], 3)} m, hold no receiver, and its shadows take texels "
                f"{width} wide: the finer cascades are spent on the space before it")

    def plan(self, models: np.ndarray, view=None) -> ShadowPlan:
        if view is None:
            raise ValueError("csm needs the camera view to fit its cascades")
        s, g = self.settings, self.geom
        res = s.cascade_resolution
        character_points = [transforms.transform_points(models[i], g.character_points[i])
                            for i in range(g.n_characters)]
        character_objects = [g.character_object(i) for i in range(g.n_characters)]
        if not kind_of(self.light).orthographic:
            reached = np.flatnonzero(reached_characters(self.geom, self.light, models))
            points = np.concatenate([self._static_points,
                                     *(character_points[i] for i in reached)])
            fits = fits_for_light(points, self.light, None, res)
            objects = ([g.static_object(i) for i in self._statics]
                       + [character_objects[i] for i in reached])
            maps = [MapRecord(name, KIND_ALL, fit, k, res, objects)
                    for k, (name, fit) in enumerate(zip(map_names("csm", len(fits)), fits,
                                                        strict=True))]
            return ShadowPlan(resolution=res, maps=maps, render_dynamic=list(range(len(maps))))
        rot = self._light_rot
        boxes = self._static_boxes
        objects = self._static_objects
        if character_points:
            cb = np.array([np.concatenate([(p @ rot.T).min(axis=0), (p @ rot.T).max(axis=0)])
                           for p in character_points])
            boxes = np.concatenate([boxes, cb])
            objects = np.concatenate([objects, character_objects])
        splits = self.splits(view)
        # Every cascade holds the scene's whole depth range (receivers included), so a
        # fragment inside a cascade's rectangle is always inside its volume: the shader can pick
        # the first rectangle that holds it ("map-based cascade selection").
        scene_z = self._corners @ rot.T
        z_lo = float(scene_z[:, 2].min())
        z_hi = max(float(scene_z[:, 2].max()), float(boxes[:, 5].max()) if len(boxes) else 0.0)
        maps = []
        for c in range(s.cascades):
            corners = slice_corners(view.view, view.proj, splits[c], splits[c + 1])
            centre, radius = bounding_sphere(corners)
            fit = fit_cascade(rot @ centre, radius, z_lo, z_hi, rot, res)
            x0, y0, x1, y1 = fit.rect
            inside = ((boxes[:, 0] <= x1) & (boxes[:, 3] >= x0) & (boxes[:, 1] <= y1)
                      & (boxes[:, 4] >= y0))
            maps.append(MapRecord(f"cascade_{c}", KIND_CASCADE, fit, c, res,
                                  [int(o) for o in objects[inside]]))
        return ShadowPlan(resolution=res, maps=maps, render_dynamic=list(range(len(maps))))

    @staticmethod
    def _near(view) -> float:
        # Near and far planes back from the perspective matrix (transforms.perspective).
        a, b = view.proj[2, 2], view.proj[2, 3]
        return float(b / (a - 1.0))

    @staticmethod
    def _far(view) -> float:
        a, b = view.proj[2, 2], view.proj[2, 3]
        return float(b / (a + 1.0))
