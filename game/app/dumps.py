"""The dumps (docs/reference.md, section 3): a frame's G-buffer as npz and its geometry as glb.

Written by capture, trace and the bench alike; read back by game/reference/hard.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from game.app import outputs
from game.render.renderer import Frame, View
from game.scene import Scene


def frame_geometry(scene: Scene, t: float) -> trimesh.Scene:
    """All geometry at time ``t`` in world space, one node per object named as in the dumps."""
    out = trimesh.Scene()
    for body in scene.floors + scene.statics:
        out.add_geometry(body.mesh, node_name=body.name, geom_name=body.name)
    for character in scene.characters:
        mesh = character.mesh.copy()
        mesh.apply_transform(character.model_matrix(t))
        out.add_geometry(mesh, node_name=character.name, geom_name=character.name)
    return out


def lit_lights(gbuffer: dict[str, np.ndarray]) -> np.ndarray:
    """The (H, W, L) float32 visibility of every light in file order: the G-buffer's own for a
    scene of several lights, else ``lit`` as the one layer (``lit == lit_lights[..., 0]``)."""
    if "lit_lights" in gbuffer:
        return np.asarray(gbuffer["lit_lights"], dtype=np.float32)
    return np.asarray(gbuffer["lit"], dtype=np.float32)[..., None]


def write_dump(stem: Path, scene: Scene, view: View, size: tuple[int, int], t: float,
               frame: Frame) -> None:
    g = frame.gbuffer
    arrays = {
        "position": g["position"], "normal": g["normal"], "object": g["object"],
        "names": np.array(scene.object_names()), "lit": g["lit"],
        "lit_lights": lit_lights(g),
        "view": view.view.astype(np.float64), "proj": view.proj.astype(np.float64),
        "size": np.array(size, dtype=np.int64), "time": np.float64(t),
        # Which scene made the frame, so that verify scores it against that scene's light.
        "scene": np.array(scene.given),
        "scene_sha256": np.array(scene.sha256),
        # The same file from any folder: verify may run elsewhere than the capture did.
        "scene_path": np.array(str(scene.source.resolve()) if scene.source else ""),
    }
    if "soft" in g:  # the linear light's traced visibility (trace, capture --soft)
        arrays["soft"] = g["soft"]
    outputs.write_npz(stem.with_suffix(".npz"), arrays)
    glb = frame_geometry(scene, t).export(file_type="glb")
    outputs.write_bytes(stem.with_suffix(".glb"), glb)
