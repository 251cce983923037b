"""``traced``: exact hard shadows, with no shadow maps.

The method plans no maps; the render layer traces one ray per shaded point toward the hard light
with the compute tracer (game/soft/) and lights the frame through that visibility: exact hard
shadows from the GPU, a reference the other methods can be compared with.
"""

from __future__ import annotations

import numpy as np

from game.scene.model import Light
from game.shadows.method import VISIBILITY_TRACED, ShadowMethod
from game.shadows.plan import ShadowPlan

# The depth array still exists (the shading pass binds it); keep it as small as GL allows.
PLACEHOLDER_RESOLUTION = 16


class TracedShadows(ShadowMethod):
    """A planner with no maps; the visibility comes from the tracer."""

    name = "traced"
    summary = "exact hard shadows from the compute tracer, one ray per pixel (the GPU reference)"
    visibility = VISIBILITY_TRACED

    @property
    def layers(self) -> int:
        return 1

    @property
    def resolution(self) -> int:
        return PLACEHOLDER_RESOLUTION

    def set_light(self, light: Light) -> None:
        self.light = light

    def plan(self, models: np.ndarray, view=None) -> ShadowPlan:
        return ShadowPlan(resolution=PLACEHOLDER_RESOLUTION, maps=[])
