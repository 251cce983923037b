"""Dumps built by hand for scoring every light of a dump (tests/reference/test_score.py and
tests/cli/test_verify_lights.py): numpy and a small glb, no renderer, no GL. Not a test module.

The scene is a 2 m cube on a floor. Straight under a light that travels down, its shadow is the
square |x|, |z| < 1; under a point light 6 m above the floor it is the cube's top face projected
from the light: |x|, |z| < 1.5. The floor points lie on a 0.5 m grid whose points sit 0.25 m from
those edges, so each point's answer is known without a ray tracer.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import trimesh

from game.scene import parse_scene

SCENE = """\
name = "two_lights"

[camera]
position = [0.0, 12.0, 0.1]
target = [0.0, 0.0, 0.0]

[[light]]
kind = "directional"
direction = [0.0, -1.0, 0.0]

{point_light}
[[floor]]
shape = "box"
size = [20.0, 0.2, 20.0]
position = [0.0, -0.1, 0.0]

[[static]]
shape = "box"
size = [2.0, 2.0, 2.0]
position = [0.0, 1.0, 0.0]
"""
HALF_SHADOW = (1.0, 1.5)   # the half-width of each light's shadow square, metres
GRID = np.arange(-4.75, 4.76, 0.5)   # 20 points a side, none on a shadow's edge
POINT_LIGHT_HEIGHT = 6.0


# A linear light straight above the cube, along x: LINEAR_LIGHT[0] to LINEAR_LIGHT[1].
LINEAR_LIGHT = ((-3.0, 9.0, 0.0), (3.0, 9.0, 0.0))


def scene_text(light_range: float | None = None, point_light: bool = True,
               linear_light: bool = False) -> str:
    """The scene of two lights (the point light's ``range`` optional), or of the first alone;
    with ``linear_light``, also the linear light :data:`LINEAR_LIGHT`."""
    point = '[[light]]\nkind = "point"\nposition = [0.0, 6.0, 0.0]\n'
    if light_range is not None:
        point += f"range = {light_range}\n"
    a, b = (", ".join(f"{x:.1f}" for x in end) for end in LINEAR_LIGHT)
    linear = f"[linear_light]\na = [{a}]\nb = [{b}]\n" if linear_light else ""
    return SCENE.format(point_light=point if point_light else "") + linear


def floor_frame() -> tuple[np.ndarray, np.ndarray]:
    """A (20, 20) "frame" of floor-top points, normals up, and one pixel of sky."""
    x, z = np.meshgrid(GRID, GRID)
    position = np.stack([x, np.zeros_like(x), z], axis=-1).astype(np.float32)
    normal = np.zeros_like(position)
    normal[..., 1] = 1.0
    position[0, 0] = normal[0, 0] = np.nan
    return position, normal


def true_lit(position: np.ndarray, light: int) -> np.ndarray:
    """Each light's visibility worked out by hand: 0 inside its shadow square."""
    inside = np.maximum(np.abs(position[..., 0]), np.abs(position[..., 2])) < HALF_SHADOW[light]
    lit = np.where(inside, 0.0, 1.0).astype(np.float32)
    lit[~np.isfinite(position).all(axis=-1)] = np.nan
    return lit


def write_dump(folder: Path, text: str, layers: list[np.ndarray] | None,
               lit: np.ndarray | None = None, stem: str = "frame_0000",
               soft: np.ndarray | None = None) -> Path:
    """A dump of the scene ``text`` (saved as folder/scene.toml, which the dump records) whose
    ``lit_lights`` are ``layers`` (none when None), ``lit`` is ``lit`` (default: layer 0) and
    ``soft``, where given, ``soft`` (a trace's dump)."""
    folder.mkdir(parents=True, exist_ok=True)
    scene_file = folder / "scene.toml"
    scene_file.write_text(text)
    scene = parse_scene(text, source=scene_file)
    position, normal = floor_frame()
    h, w = position.shape[:2]
    arrays = {
        "position": position, "normal": normal,
        "object": np.where(np.isfinite(position[..., 0]), 0, -1).astype(np.int32),
        "names": np.array(scene.object_names()),
        "lit": layers[0] if lit is None else lit,
        "view": np.eye(4), "proj": np.eye(4),
        "size": np.array([w, h], dtype=np.int64), "time": np.float64(0.0),
        "scene": np.array(str(scene_file)),
        "scene_sha256": np.array(hashlib.sha256(scene_file.read_bytes()).hexdigest()),
        "scene_path": np.array(str(scene_file.resolve())),
    }
    if layers is not None:
        arrays["lit_lights"] = np.stack(layers, axis=-1).astype(np.float32)
    if soft is not None:
        arrays["soft"] = soft.astype(np.float32)
    npz = folder / f"{stem}.npz"
    np.savez(npz, **arrays)
    geometry = trimesh.Scene()
    for body in scene.floors + scene.statics:
        geometry.add_geometry(body.mesh, node_name=body.name, geom_name=body.name)
    npz.with_suffix(".glb").write_bytes(geometry.export(file_type="glb"))
    return npz
