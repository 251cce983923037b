"""Each light's map grid for a frame, and the visibility of every light apart (dumps).

The grid lists, per cell of a light's space, the maps that can shadow it
(game/shadows/map_grid.py); the shading pass walks a cell's list instead of every map.
"""

from __future__ import annotations

import numpy as np

from game.scene.model import Light
from game.shadows.light_kinds import kind_of
from game.shadows.lights import LightSpan
from game.shadows.map_grid import GridBuilder, MapGrid
from game.shadows.plan import ShadowPlan, ShadowSettings, shadow_reach


def build_grids(builders: list[GridBuilder], plan: ShadowPlan, spans: list[LightSpan],
                lights: list[Light], settings: ShadowSettings) -> list[MapGrid]:
    """Each light's grid over its own maps; a light's cached maps keep their cells."""
    reach = shadow_reach(settings)
    grids = []
    for light, span, builder in zip(lights, spans, builders, strict=True):
        maps = plan.maps[span.first_map:span.first_map + span.map_count]
        dynamic = [i - span.first_map for i in plan.render_dynamic
                   if span.first_map <= i < span.first_map + span.map_count]
        grids.append(builder.build([m.fit for m in maps], kind_of(light).eye(light),
                                   settings.grid, [m.cover for m in maps], reach,
                                   tiles=[m.tile for m in maps],
                                   spheres=[m.spheres for m in maps],
                                   steady=min(dynamic, default=len(maps))))
    return grids


def stack_lights(first: np.ndarray, count: int, others) -> np.ndarray:
    """(H, W, ``count``) visibility: light 0's ``first``, then ``others(k)`` for each other
    light k."""
    out = np.empty((*first.shape, count), np.float32)
    out[..., 0] = first
    for k in range(1, count):
        out[..., k] = others(k)
    return out
