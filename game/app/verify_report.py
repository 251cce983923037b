"""What ``python -m game verify`` does with a folder of dumps once it knows the scene: score each
frame against Embree (game/reference/), print its lines, and with ``--images`` write beside each
frame a picture of where the method and the reference disagree.

A dump that holds ``soft`` (``trace --dump``, ``capture --soft --dump``) is scored on its soft
visibility against the linear light; any other on its hard ``lit`` and ``lit_lights``.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from game.app import outputs
from game.errors import GameError
from game.reference import error_picture
from game.reference.hard import MIN_NDOTL
from game.reference.score import score_dump_lights
from game.reference.soft_score import OFF_BY, dump_holds_soft, score_soft_dump
from game.scene.mesh_files import regular_file


def check_dump_files(folder: Path, frames: list[Path]) -> None:
    """Every dump and its geometry a regular file of ``folder`` itself, before any is read: a
    FIFO would block the read for good, and a link out of the folder would read a file that
    was never given."""
    root = folder.resolve()
    for npz in frames:
        for path in (npz, npz.with_suffix(".glb")):
            if not (path.exists() or path.is_symlink()):
                continue  # a missing geometry file is named when its frame is scored
            try:
                full = path.resolve()
            except (OSError, RuntimeError) as error:  # RuntimeError: a symlink loop
                raise GameError(f"{path}: cannot follow it ({error})") from None
            if not full.is_relative_to(root):
                raise GameError(f"{path}: links out of the dump folder; verify reads only the "
                                "folder's own files")
            regular_file(path, str(path), _refuse)


def _refuse(line: str):
    raise GameError(line)


def picture_paths(frames: list[Path], scene) -> list[Path]:
    """Every picture ``--images`` may write for ``frames``: one per frame, or one per light
    and frame for a scene of several lights (checked before any work)."""
    names = ["errors"] if len(scene.lights) == 1 else [
        f"light{k}_errors" for k in range(len(scene.lights))]
    return [npz.with_name(f"{npz.stem}_{name}.png") for npz in frames for name in names]


def verify_frames(frames: list[Path], scene, images: bool,
                  say: Callable[[str], None]) -> list[dict[str, Any]]:
    """Score every frame, print its lines, write its pictures; returns the ``--out`` entries."""
    results = []
    for npz in frames:
        if dump_holds_soft(npz):
            results.append(_soft_frame(npz, scene, images, say))
        else:
            results.append(_hard_frame(npz, scene, images, say))
    return results


def _hard_frame(npz: Path, scene, images: bool, say) -> dict[str, Any]:
    scores = score_dump_lights(npz, scene.lights)
    several = len(scene.lights) > 1
    lights = [{"light": k, **_numbers(err)} for k, err in enumerate(scores["lights"])]
    if not several:
        say(f"{npz.stem}: {hard_line(scores['lit'])}")
        _picture(npz.with_name(f"{npz.stem}_errors.png"), npz, scores["lit"], images, say)
    for k, err in enumerate(scores["lights"] if several else []):
        say(f"{npz.stem} light {k} ({scene.lights[k].kind}): {hard_line(err)}")
        _picture(npz.with_name(f"{npz.stem}_light{k}_errors.png"), npz, err, images, say)
    return {"frame": npz.stem, "kind": "hard", **_numbers(scores["lit"]), "lights": lights}


def _soft_frame(npz: Path, scene, images: bool, say) -> dict[str, Any]:
    if scene.linear_light is None:
        raise GameError(f"{npz.name} holds soft visibility, and the scene has no "
                        "[linear_light] to score it against")
    light = scene.linear_light
    score = score_soft_dump(npz, light.a, light.b)
    say(f"{npz.stem} soft: {soft_line(score)}")
    _picture(npz.with_name(f"{npz.stem}_errors.png"), npz, score, images, say, OFF_BY)
    return {"frame": npz.stem, "kind": "soft", **_numbers(score)}


def _picture(path: Path, npz: Path, score: dict, images: bool, say,
             tolerance: float | None = None) -> None:
    """Draw and write one frame's (or one light's) picture, and say what it holds."""
    if not images:
        return
    with np.load(npz, allow_pickle=False) as data:
        normal = data["normal"]
    reference = score["exact"] if tolerance is None else score["reference"]
    geometry = np.isfinite(normal).all(axis=-1) & np.isfinite(reference)
    masks = error_picture.kind_masks(score["method"], reference, score["considered_mask"],
                                     score["offset_mask"], geometry, tolerance)
    outputs.write_png(path, error_picture.picture(score["method"], normal, masks))
    legend = error_picture.legend(error_picture.counts(masks), soft=tolerance is not None)
    say(f"  wrote {path.name}: {legend}")


def _numbers(score: dict) -> dict:
    """A score's numbers, without its images (the JSON of ``verify --out``)."""
    return {k: v for k, v in score.items() if not isinstance(v, np.ndarray)}


def hard_line(err: dict) -> str:
    """One frame's (or one light's) shadow error as ``verify`` prints it, in percent."""
    return (f"error {100 * err['error']:.2f}% ({err['misclassified']} misclassified of "
            f"{err['shadowed_either']} pixels shadowed by the method or the reference; "
            f"{err['shadowed']} by the reference; {err['considered']} pixels considered, with "
            f"N.L > {MIN_NDOTL} and in the light's reach; left out: {err['left_out_reach']} "
            f"out of reach, {err['left_out_offset']} where the reference changes with the ray "
            "offset)")


def soft_line(score: dict) -> str:
    """One soft frame's error as ``verify`` prints it."""
    return (f"rmse {score['rmse']:.4f}, {100 * score['off_share']:.2f}% of points off by more "
            f"than {OFF_BY} ({score['off']} of {score['points']} points, against "
            f"{score['reference_samples']} stratified Embree samples of the linear light; left "
            f"out: {score['left_out_offset']} where the reference changes with the ray offset)")
