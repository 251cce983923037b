"""The one scoring function: a frame's hard-shadow visibility against Embree shadow rays.

``verify``, the benchmark and the tests all score frames here, so they cannot disagree on what
the shadow error is. A frame of several lights is scored light by light: each layer of the
dump's ``lit_lights`` against shadow rays toward its own light.
"""

from __future__ import annotations

import hashlib
import os
import stat
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import trimesh

from game.errors import GameError
from game.reference.dump_format import missing_to_score
from game.reference.hard import (
    check_declared_sizes,
    hard_visibility,
    hard_visibility_lights,
    load_frame,
    load_geometry,
    shadow_error,
)
from game.reference.offsets import offset_sensitive_lights


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


def light_layers(frame: dict[str, Any]) -> np.ndarray:
    """The (H, W, L) visibility of each light that a loaded dump holds, in file order: its
    ``lit_lights``, or its ``lit`` as the one layer of light 0 for a dump without them."""
    if "lit_lights" in frame:
        return frame["lit_lights"]
    return frame["lit"][..., None]


def score_dump_lights(npz_path: str | Path, lights: Sequence[Any]) -> dict[str, Any]:
    """The shadow error of every light of one ``--dump`` frame.

    Layer k of the dump's ``lit_lights`` is scored against Embree shadow rays toward
    ``lights[k]``, all through one Embree scene. A dump without ``lit_lights`` holds light 0
    alone, as ``lit``, and only that light is scored.

    Pixels whose reference changes with the ray offset (game/reference/offsets.py) are left
    out of every light's error and counted in ``left_out_offset``.

    Returns ``{"lit": ..., "lights": [...]}``: :func:`score_frame`'s dict for the frame's ``lit``
    against light 0, and one such dict per layer, each with ``method``, the layer scored.

    Raises
    ------
    ValueError
        When ``lit_lights`` holds another number of lights than ``lights``.
    """
    if not lights:
        raise ValueError("a frame needs at least one light to score")
    npz_path = Path(npz_path)
    frame = load_frame(npz_path)
    missing = missing_to_score(list(frame))
    if missing is not None:
        raise ValueError(f"{npz_path.name}: no {missing!r} array")
    layers = light_layers(frame)
    if "lit_lights" in frame and layers.shape[-1] != len(lights):
        raise ValueError(f"'lit_lights' holds {layers.shape[-1]} light(s) and the scene has "
                         f"{len(lights)}")
    lights = list(lights)[:layers.shape[-1]]
    occluders = load_geometry(npz_path.with_suffix(".glb"))
    check_same_frame(frame, occluders, str(npz_path))
    position, normal = frame["position"], frame["normal"]
    exact = hard_visibility_lights(occluders, position, normal, lights)
    # Pixels the reference cannot decide are left out of every light's error, and counted.
    shaky = offset_sensitive_lights(occluders, position, normal, lights, exact)
    scores = [{**shadow_error(layers[..., k], exact[k], position, normal, light,
                              left_out=shaky[k]),
               "exact": exact[k], "method": layers[..., k]} for k, light in enumerate(lights)]
    lit = {**shadow_error(frame["lit"], exact[0], position, normal, lights[0],
                          left_out=shaky[0]),
           "exact": exact[0], "method": frame["lit"]}
    return {"lit": lit, "lights": scores}


# The dumped surface points tested against the geometry file, and the share that must lie on
# it. A ray cast back along each point's normal from just above it meets the surface within two
# steps; one step is a centimetre plus what float32 (the frame's positions) loses at the point's
# distance from the origin. Nothing about the camera enters, so a camera inside a volume whose
# back faces are culled, or geometry clipped by the near plane, cannot refuse a frame.
SAME_FRAME_POINTS = 256
SAME_FRAME_SHARE = 0.98
SAME_FRAME_STEP = 0.01
FLOAT32_STEP = 2.0 ** -20   # a float32's spacing, with room, as a share of its magnitude


def check_same_frame(frame: dict[str, Any], geometry: trimesh.Trimesh, name: str) -> None:
    """Raise GameError unless the frame's dumped surface points lie on ``geometry``: the
    geometry file of another scene beside the npz scored the frame against the wrong
    occluders, and gave a confident wrong error. (Another frame of the same scene differs in
    its characters alone, which this tells apart only where they fill enough of the frame.)"""
    position = np.asarray(frame["position"], np.float64).reshape(-1, 3)
    normal = np.asarray(frame["normal"], np.float64).reshape(-1, 3)
    length = np.linalg.norm(normal, axis=1)
    usable = np.isfinite(position).all(axis=1) & np.isfinite(length) & (length > 0.5)
    points, normal = position[usable], normal[usable] / length[usable, None]
    if not len(points):
        return  # nothing to test it by
    pick = np.linspace(0, len(points) - 1, min(SAME_FRAME_POINTS, len(points))).astype(np.int64)
    points, normal = points[pick], normal[pick]
    step = SAME_FRAME_STEP + FLOAT32_STEP * np.abs(points).max(axis=1)
    above = points + normal * step[:, None]
    hit = np.full(len(points), np.inf)
    if len(geometry.faces):
        where, ray, _ = geometry.ray.intersects_location(above, -normal, multiple_hits=False)
        hit[ray] = np.linalg.norm(where - above[ray], axis=1)
    if (hit <= 2.0 * step).mean() < SAME_FRAME_SHARE:
        raise GameError(f"{name}: its surface points do not lie on the geometry of "
                        f"{Path(name).with_suffix('.glb').name}: the geometry of another scene?")


def recorded_scene(npz_path: str | Path) -> tuple[str, str, str] | None:
    """The ``(scene, scene_sha256, scene_path)`` a dump records (``scene_path``: the file's
    absolute path, or ""), or None for a dump that records none."""
    with np.load(npz_path, allow_pickle=False) as data:
        check_declared_sizes(data, Path(npz_path).name)
        if "scene" not in data.files or "scene_sha256" not in data.files:
            return None
        path = str(data["scene_path"]) if "scene_path" in data.files else ""
        return str(data["scene"]), str(data["scene_sha256"]), path


def file_with_hash(paths: Sequence[Path], sha256: str,
                   max_bytes: int) -> tuple[Path, bytes] | None:
    """The first of ``paths`` that is a regular file of at most ``max_bytes`` whose bytes hash
    to ``sha256``, with those bytes; None when none is.

    A dump names its scene, and a dump may come from anyone: only a file that is byte for byte
    the recorded one may go on to be parsed. Nothing else is read past its size, and a pipe or
    a device is never opened for reading (a read from either may never end).
    """
    for path in paths:
        try:
            if not stat.S_ISREG(os.stat(path).st_mode):
                continue
            fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
        except (OSError, ValueError):  # ValueError: a NUL byte in the recorded path
            continue
        with os.fdopen(fd, "rb") as f:
            info = os.fstat(f.fileno())  # the file opened, not the one looked at before
            if not stat.S_ISREG(info.st_mode) or info.st_size > max_bytes:
                continue
            data = f.read(max_bytes + 1)
        if len(data) <= max_bytes and hashlib.sha256(data).hexdigest() == sha256:
            return path, data
    return None
