"""``static-dynamic``: the "mixed cached shadow map" of current engines.

One cached map of every static plus one map of every character, re-rendered each frame; the
shading pass takes the minimum of the two. Planned like ``clumped``, with the same depth array,
bias rules and shading pass, so the benchmark compares like with like.
"""

from __future__ import annotations

import numpy as np

from game import transforms
from game.scene.geometry import PackedGeometry
from game.scene.model import Light
from game.shadows.collapse import coarse_statics_note
from game.shadows.light_kinds import fits_for_light, kind_of
from game.shadows.method import ShadowMethod, reached_characters, reached_statics
from game.shadows.plan import (
    KIND_ALL,
    KIND_CLUMP,
    MapRecord,
    ShadowPlan,
    ShadowSettings,
    map_names,
)


class StaticDynamicShadows(ShadowMethod):
    """One cached map of all statics and one map of all characters (re-rendered each frame).

    Both maps have ``settings.single_resolution`` texels per side: the same memory as two
    ``single`` maps, so the comparison with ``single`` isolates what caching buys. A point light
    among its casters gives either map the faces of a cube instead, as it does ``single``.
    """

    name = "static-dynamic"
    summary = ("the engines' cached map of every static plus one map of every character, "
               "re-rendered each frame")
    resolution_fields = ("single_resolution",)
    parameters = ("single_resolution",)

    @classmethod
    def min_layers(cls, settings: ShadowSettings, n_characters: int) -> int:
        return 2

    def __init__(self, geom: PackedGeometry, light: Light, settings: ShadowSettings,
                 max_layers: int, max_maps: int | None = None):
        super().__init__(geom, light, settings, max_layers, max_maps)
        self.set_light(light)

    @property
    def layers(self) -> int:
        return self._first_character_layer + kind_of(self.light).max_maps_per_caster

    @property
    def resolution(self) -> int:
        return self.settings.single_resolution

    def set_light(self, light: Light) -> None:
        """A new light refits (and re-renders) the static map."""
        self.light = light
        self._light_rot = kind_of(light).rotation(light)
        statics = reached_statics(self.geom, light)
        points = [self.geom.static_points[i] for i in statics]
        fits = fits_for_light(np.concatenate(points) if points else np.zeros((0, 3)), light,
                              self._light_rot, self.resolution)
        self.restate(coarse_statics_note(self, fits))
        objects = [self.geom.static_object(i) for i in statics]
        names = map_names("statics", len(fits))
        self._static = [MapRecord(name, KIND_CLUMP, fit, layer, self.resolution, objects)
                        for layer, (name, fit) in enumerate(zip(names, fits, strict=True))]
        self._first_character_layer = max(1, len(self._static))
        self._static_dirty = True

    def mark_rendered_lost(self) -> None:
        self._static_dirty = True

    def plan(self, models: np.ndarray, view=None) -> ShadowPlan:
        maps = list(self._static)
        render_static = list(range(len(maps))) if self._static_dirty else []
        render_dynamic = []
        characters = np.flatnonzero(reached_characters(self.geom, self.light, models))
        if len(characters):
            points = np.concatenate([
                transforms.transform_points(models[i], self.geom.character_points[i])
                for i in characters])
            fits = fits_for_light(points, self.light, self._light_rot, self.resolution)
            objects = [self.geom.character_object(i) for i in characters]
            for k, (name, fit) in enumerate(zip(map_names("characters", len(fits)), fits,
                                                strict=True)):
                render_dynamic.append(len(maps))
                # KIND_ALL, not KIND_CHARACTER: one map holds many characters.
                maps.append(MapRecord(name, KIND_ALL, fit, self._first_character_layer + k,
                                      self.resolution, objects))
        self._static_dirty = False
        return ShadowPlan(resolution=self.resolution, maps=maps, render_static=render_static,
                          render_dynamic=render_dynamic)
