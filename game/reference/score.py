"""The one scoring function: a frame's hard-shadow visibility against Embree shadow rays.

``verify``, the benchmark and the tests all score frames here, so they cannot disagree on what
the shadow error is.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from game.reference.hard import hard_visibility, load_frame, load_geometry, shadow_error


def score_frame(lit: np.ndarray, position: np.ndarray, normal: np.ndarray,
                occluders: trimesh.Trimesh, light) -> dict[str, Any]:
    """The shadow error (:func:`~game.reference.hard.shadow_error`) of a frame's ``lit`` image,
    with one Embree shadow ray per pixel through ``occluders`` as the truth.

    Returns the metric's dict plus ``exact``, the reference visibility image.
    """
    exact = hard_visibility(occluders, position, normal, light)
    return {**shadow_error(lit, exact, position, normal, light), "exact": exact}


def score_dump(npz_path: str | Path, light) -> dict[str, Any]:
    """:func:`score_frame` of one ``--dump`` frame: its npz arrays and its glb geometry."""
    npz_path = Path(npz_path)
    frame = load_frame(npz_path)
    occluders = load_geometry(npz_path.with_suffix(".glb"))
    return score_frame(frame["lit"], frame["position"], frame["normal"], occluders, light)


def recorded_scene(npz_path: str | Path) -> tuple[str, str, str] | None:
    """The ``(scene, scene_sha256, scene_path)`` a dump records (``scene_path``: the file's
    absolute path, or ""), or None for a dump that records none."""
    with np.load(npz_path, allow_pickle=False) as data:
        if "scene" not in data.files or "scene_sha256" not in data.files:
            return None
        path = str(data["scene_path"]) if "scene_path" in data.files else ""
        return str(data["scene"]), str(data["scene_sha256"]), path
