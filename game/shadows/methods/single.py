"""``single``: the baseline of one map fitted to every caster, re-rendered every frame (for a
point light among its casters, the six faces of a cube, as an engine gives it). A spot or point
light with a range fits only the casters within it."""

from __future__ import annotations

import numpy as np

from game import transforms
from game.scene.geometry import PackedGeometry
from game.scene.model import Light
from game.shadows.collapse import coarse_statics_note
from game.shadows.fit import deciding_points
from game.shadows.light_kinds import fits_for_light, kind_of
from game.shadows.method import ShadowMethod, reached_characters, reached_statics
from game.shadows.plan import KIND_ALL, MapRecord, ShadowPlan, ShadowSettings, map_names


class SingleShadows(ShadowMethod):
    """The baseline: one map over every caster, all re-rendered every frame."""

    name = "single"
    summary = "one map over every caster, re-rendered every frame"
    resolution_fields = ("single_resolution",)
    parameters = ("single_resolution",)

    def __init__(self, geom: PackedGeometry, light: Light, settings: ShadowSettings,
                 max_layers: int, max_maps: int | None = None):
        super().__init__(geom, light, settings, max_layers, max_maps)
        self.set_light(light)

    @property
    def layers(self) -> int:
        return kind_of(self.light).max_maps_per_caster

    @property
    def resolution(self) -> int:
        return self.settings.single_resolution

    def set_light(self, light: Light) -> None:
        """Keep only the statics' extreme points for this light; refitting is then cheap."""
        self.light = light
        self._light_rot = kind_of(light).rotation(light)
        self._statics = reached_statics(self.geom, light)
        points = [self.geom.static_points[i] for i in self._statics]
        self._static_points = deciding_points(
            np.concatenate(points) if points else np.zeros((0, 3)), self._light_rot)
        self.restate(coarse_statics_note(self, fits_for_light(self._static_points, light,
                                                              self._light_rot, self.resolution)))

    def update_statics(self, geom: PackedGeometry, changed: set[str]) -> list[int]:
        """Statics changed: the one map is re-fitted (it is re-rendered every frame anyway)."""
        self.geom = geom
        self.set_light(self.light)
        return []

    def update_characters(self, geom: PackedGeometry) -> None:
        self.geom = geom

    def plan(self, models: np.ndarray, view=None) -> ShadowPlan:
        res = self.settings.single_resolution
        characters = np.flatnonzero(reached_characters(self.geom, self.light, models))
        parts = [self._static_points] + [
            transforms.transform_points(models[i], self.geom.character_points[i])
            for i in characters]
        points = np.concatenate(parts)
        objects = ([self.geom.static_object(i) for i in self._statics]
                   + [self.geom.character_object(i) for i in characters])
        fits = fits_for_light(points, self.light, self._light_rot, res)
        names = map_names("single", len(fits))
        maps = [MapRecord(name, KIND_ALL, fit, layer, res, objects)
                for layer, (name, fit) in enumerate(zip(names, fits, strict=True))]
        return ShadowPlan(resolution=res, maps=maps, render_dynamic=list(range(len(maps))))
