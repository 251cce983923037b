"""Check a rendered frame's shadows against Embree (game/reference.py) without writing dumps.

Shared by the issue 6 tests (limits, cache invalidation, robustness): they change the scene or the
limits at run time and need the image checked, not only a counter.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import trimesh

from game.app import dumps
from game.reference import hard as reference
from game.render.renderer import Frame, Renderer, View
from game.scene.loader import default_scene_path

MAX_ERROR = 0.05  # the foundation's bound (tests/test_accuracy.py)
# The scenes the accuracy bound is asserted on, for every method (test_accuracy, test_baselines).
SCENES = Path(__file__).parent / "scenes"
ACCURACY_SCENES = {
    "default": default_scene_path(),
    "spot": SCENES / "spot.toml",
    "point": SCENES / "point.toml",
    "low_sun": SCENES / "low_sun.toml",
}


def occluders(scene, t: float) -> trimesh.Trimesh:
    """The frame's geometry as the dumps would hold it, read back like load_geometry."""
    glb = dumps.frame_geometry(scene, t).export(file_type="glb")
    loaded = trimesh.load(io.BytesIO(glb), file_type="glb", force="scene", process=False)
    parts = [loaded.geometry[name].copy().apply_transform(transform)
             for node in sorted(loaded.graph.nodes_geometry)
             for transform, name in [loaded.graph[node]]]
    return trimesh.util.concatenate(parts)


def frame_error(renderer: Renderer, frame: Frame, t: float) -> dict:
    """Embree shadow error of a frame rendered with ``gbuffer=True``."""
    g = frame.gbuffer
    exact = reference.hard_visibility(occluders(renderer.scene, t), g["position"], g["normal"],
                                      renderer.scene.light)
    return reference.shadow_error(g["lit"], exact, g["position"], g["normal"],
                                  renderer.scene.light)


def render_and_check(renderer: Renderer, t: float = 0.0) -> tuple[Frame, dict]:
    view = View.from_camera(renderer.scene.camera, renderer.size)
    frame = renderer.render(t, view)
    for name, array in frame.gbuffer.items():
        covered = frame.covered if array.ndim == 2 else frame.covered[..., None]
        if array.dtype.kind == "f":
            assert np.all(np.isfinite(np.where(covered, array, 0.0))), f"NaN in {name}"
    return frame, frame_error(renderer, frame, t)
