"""What every part of one light's clumped planner reads, held once and shared."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from game.scene.geometry import PackedGeometry
from game.scene.model import Light
from game.shadows.light_kinds import LightKind, kind_of
from game.shadows.plan import ShadowSettings


@dataclass
class LightContext:
    """The scene, the light and its kind, the settings, and the notes of one light's planner.

    The planner (:class:`~game.shadows.methods.clumped.planner.ClumpedShadows`) replaces its
    fields when the scene, the light or the budget change; its parts read them here.
    """

    geom: PackedGeometry
    light: Light
    settings: ShadowSettings
    notes: list[str]
    kind: LightKind
    rotation: np.ndarray | None  # the world-to-light rotation of orthographic maps
    ground: float                # the lowest height of floors and statics

    @classmethod
    def of(cls, geom: PackedGeometry, light: Light, settings: ShadowSettings) -> LightContext:
        kind = kind_of(light)
        return cls(geom, light, settings, [], kind, kind.rotation(light), ground_height(geom))

    def set_light(self, light: Light) -> None:
        self.light = light
        self.kind = kind_of(light)
        self.rotation = self.kind.rotation(light)
        self.ground = ground_height(self.geom)

    def note(self, text: str) -> None:
        """Say once how the planner degraded."""
        if text not in self.notes:
            self.notes.append(text)


def ground_height(geom: PackedGeometry) -> float:
    """The lowest height of the floors and statics: no shadow falls below it."""
    fixed = geom.objects < geom.first_character
    return float(geom.positions[fixed, 1].min()) if fixed.any() else math.inf
