"""Where the reference itself is unsure: pixels whose answer changes with the ray offset.

A shadow ray starts a small offset off the surface (``RAY_OFFSET_SCENE`` in
game/reference/hard.py): enough to step past float32 rounding, small enough not to skip a near
occluder. Where moving that start by a factor of ``OFFSET_PROBE`` either way changes the answer,
the point lies within rounding of an occluder (a crease, a contact, a grazing face) and the
reference has no single answer to hold a method to: the hard and the soft checks leave it out
and say how many they left out.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import trimesh

from game.reference.hard import hard_visibility_lights

# The probe offsets are the reference's own times and over this factor: a point whose answer
# holds over a fourfold range of offsets is not decided by rounding.
OFFSET_PROBE = 2.0


def offset_sensitive_lights(mesh: trimesh.Trimesh, position: np.ndarray, normal: np.ndarray,
                            lights: Sequence[Any], exact: Sequence[np.ndarray]
                            ) -> list[np.ndarray]:
    """Per light, the (H, W) bool pixels whose Embree visibility ``exact[k]`` (at the usual
    offset) differs from the visibility at the offset over or times :data:`OFFSET_PROBE`."""
    near = hard_visibility_lights(mesh, position, normal, lights, 1.0 / OFFSET_PROBE)
    far = hard_visibility_lights(mesh, position, normal, lights, OFFSET_PROBE)
    return [np.isfinite(e) & ((n != e) | (f != e))
            for e, n, f in zip(exact, near, far, strict=True)]
