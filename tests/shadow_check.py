"""Check a rendered frame's shadows against Embree (game/reference/) without writing dumps.

Shared by the tests that change the scene or the limits at run time (limits, scene edits,
robustness) and need the image checked, not only a counter.
"""

from __future__ import annotations

import numpy as np
import trimesh

from game.app import dumps
from game.reference.hard import geometry_from_glb
from game.reference.score import score_frame
from game.render.renderer import Frame, Renderer, View


def occluders(scene, t: float) -> trimesh.Trimesh:
    """The frame's geometry as the dumps would hold it, read back as the reference reads it."""
    return geometry_from_glb(dumps.frame_geometry(scene, t).export(file_type="glb"))


def frame_error(renderer: Renderer, frame: Frame, t: float) -> dict:
    """Embree shadow error of a frame rendered with ``gbuffer=True``."""
    g = frame.gbuffer
    return score_frame(g["lit"], g["position"], g["normal"], occluders(renderer.scene, t),
                       renderer.scene.light)


def render_and_check(renderer: Renderer, t: float = 0.0) -> tuple[Frame, dict]:
    view = View.from_camera(renderer.scene.camera, renderer.size)
    frame = renderer.render(t, view)
    for name, array in frame.gbuffer.items():
        covered = frame.covered if array.ndim == 2 else frame.covered[..., None]
        if array.dtype.kind == "f":
            assert np.all(np.isfinite(np.where(covered, array, 0.0))), f"NaN in {name}"
    return frame, frame_error(renderer, frame, t)
