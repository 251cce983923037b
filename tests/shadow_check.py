"""Check rendered shadows against Embree (game/reference/): a frame in memory, or frames
captured with dumps.

Shared by the tests that change the scene or the limits at run time (limits, scene edits,
robustness) and need the image checked, not only a counter, and by the accuracy tests. Not a
test module.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from game.app import capture, dumps, outputs
from game.reference import hard as reference
from game.reference.hard import geometry_from_glb
from game.reference.score import score_frame
from game.render.renderer import Frame, Renderer, View
from tests.helpers import ACCURACY_SIZE

MIN_SHADOWED = 200  # a scene must really have shadows in view for the ratio to mean anything


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


def capture_errors(ctx, scene, settings, out: Path, frames=2, fps=1.5) -> list[dict]:
    """Capture ``frames`` frames with dumps at ACCURACY_SIZE and score each against Embree;
    a picture of each frame's misclassified pixels is saved beside the dumps."""
    opts = capture.CaptureOptions(out=out, frames=frames, size=ACCURACY_SIZE, fps=fps, dump=True,
                                  settings=settings)
    capture.run(ctx, scene, opts)
    errors = []
    for k in range(frames):
        frame = reference.load_frame(out / f"frame_{k:04d}.npz")
        mesh = reference.load_geometry(out / f"frame_{k:04d}.glb")
        exact = reference.hard_visibility(mesh, frame["position"], frame["normal"],
                                          scene.light)
        err = reference.shadow_error(frame["lit"], exact, frame["position"], frame["normal"],
                                     scene.light)
        # Saved for a person to look at: red = misclassified, green = lit by the method.
        diff = np.zeros((*err["mask"].shape, 3), np.uint8)
        diff[..., 0] = err["mask"] * 255
        diff[..., 1] = (np.nan_to_num(frame["lit"]) * 110).astype(np.uint8)
        outputs.write_png(out / f"diff_{k:04d}.png", diff)
        errors.append(err)
    return errors
