"""The ``traced`` hard-shadow method: no shadow maps; the compute tracer gives exact visibility.

The planner plans no maps (the shading pass then reads none), and the Renderer runs the tracer
after the shading pass with one ray per point toward the hard light through the grid of
game/trace_grid.py: exact hard shadows, the GPU reference the benchmark can use.
"""

from __future__ import annotations

import numpy as np

from game.gpu import blocks as gpu_blocks
from game.shadows.plan import ShadowPlan
from game.soft.tracer import TraceSettings

# The hard-light capture method that the tracer provides (CONTRACT.md section 2).
TRACED_METHOD = "traced"
# Exact hard shadows: one ray per point through the grid (N = 1 toward a point is exact).
TRACED_SETTINGS = TraceSettings(method="grid", samples=1)

# The depth array still exists (the shading pass binds it); keep it as small as GL allows.
PLACEHOLDER_RESOLUTION = 16


class TracedShadows:
    """A planner with no maps; the visibility comes from the tracer."""

    def __init__(self) -> None:
        self.notes: list[str] = []

    @property
    def layers(self) -> int:
        return 1

    @property
    def resolution(self) -> int:
        return PLACEHOLDER_RESOLUTION

    def set_light(self, light) -> None:
        pass

    def invalidate_statics(self) -> None:
        pass

    def mark_rendered_lost(self) -> None:
        pass

    def plan(self, models: np.ndarray, view=None) -> ShadowPlan:
        return ShadowPlan(resolution=PLACEHOLDER_RESOLUTION, maps=[])


def hard_light(light) -> tuple[int, np.ndarray, np.ndarray]:
    """The tracer's light tuple for the scene's hard light (spot: its cone is shading, not
    visibility, as in the Embree reference)."""
    if light.kind == "directional":
        d = -np.asarray(light.direction, np.float64)
        d = d / np.linalg.norm(d)
        return gpu_blocks.TRACE_LIGHT_DIRECTIONAL, d, d
    p = np.asarray(light.position, np.float64)
    return gpu_blocks.TRACE_LIGHT_POINT, p, p
