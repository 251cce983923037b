"""The ``traced`` hard-shadow method: no shadow maps; the compute tracer gives exact visibility.

The planner plans no maps (the shading pass then reads none), and capture runs the tracer
(game/trace_run.py ``traced_frame``) with one ray per point toward the hard light through the
grid of game/trace_grid.py: exact hard shadows, the GPU reference the benchmark can use.
"""

from __future__ import annotations

import numpy as np

from .shadow_plan import ShadowPlan

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
