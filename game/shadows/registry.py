"""The hard-shadow methods by name: the one list the command line, the window, the bench and the
docs read."""

from __future__ import annotations

from game.scene.geometry import PackedGeometry
from game.scene.model import Light
from game.shadows.method import VISIBILITY_MAPS, ShadowMethod
from game.shadows.methods.cascaded import CascadedShadows
from game.shadows.methods.clumped import ClumpedShadows
from game.shadows.methods.single import SingleShadows
from game.shadows.methods.static_dynamic import StaticDynamicShadows
from game.shadows.methods.traced import TracedShadows
from game.shadows.plan import ShadowSettings

METHODS: dict[str, type[ShadowMethod]] = {
    cls.name: cls for cls in (ClumpedShadows, SingleShadows, StaticDynamicShadows,
                              CascadedShadows, TracedShadows)}
DEFAULT_METHOD = ShadowSettings.method  # the settings' default
# The methods that draw shadow maps (the benchmark's subjects; ``traced`` is their reference).
MAP_METHODS = tuple(name for name, cls in METHODS.items() if cls.visibility == VISIBILITY_MAPS)


def method_class(name: str) -> type[ShadowMethod]:
    """The class of method ``name``; ValueError naming the valid ones otherwise."""
    try:
        return METHODS[name]
    except KeyError:
        raise ValueError(f"unknown shadow method {name!r}; valid: {', '.join(METHODS)}") from None


def create(geom: PackedGeometry, light: Light, settings: ShadowSettings,
           max_layers: int, max_maps: int | None = None) -> ShadowMethod:
    """The planner for ``settings.method``; ``max_layers`` and ``max_maps`` are what the GL
    allows (array layers, map records)."""
    return method_class(settings.method)(geom, light, settings, max_layers, max_maps)
