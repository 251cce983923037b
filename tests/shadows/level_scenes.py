"""A level of houses and a long wall, written as one mesh file or as one file per part: the
scene the level-part and tile tests share."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

HEAD = """name = "level"
[camera]
position = [0.0, 45.0, 55.0]
target   = [0.0, 0.0, 0.0]
fov      = 55.0
[light]
kind      = "directional"
direction = [0.5, -1.0, -0.35]
[[floor]]
shape    = "box"
size     = [120.0, 0.2, 120.0]
position = [0.0, -0.1, 0.0]
"""


def level_meshes() -> list[trimesh.Trimesh]:
    """Houses of several heights on a 4x4 grid over 48 m, and a 40 m wall: wider than one
    clump map holds at the density target, so it must be split too."""
    rng = np.random.default_rng(7)
    meshes = []
    for x in np.linspace(-21, 21, 4):
        for z in np.linspace(-21, 21, 4):
            h = float(rng.uniform(2.0, 6.0))
            meshes.append(trimesh.creation.box([4.0, h, 4.0]).apply_translation([x, h / 2, z]))
    meshes.append(trimesh.creation.box([40.0, 3.0, 0.6]).apply_translation([0.0, 1.5, -27.0]))
    return meshes


def write_level(folder: Path, as_parts: bool) -> Path:
    folder.mkdir()
    meshes = level_meshes()
    if as_parts:
        entries = []
        for i, mesh in enumerate(meshes):
            mesh.export(folder / f"part_{i}.obj")
            entries.append(f'[[static]]\nshape = "mesh"\nfile = "part_{i}.obj"\n')
    else:
        trimesh.util.concatenate(meshes).export(folder / "level.obj")
        entries = ['[[static]]\nshape = "mesh"\nfile = "level.obj"\n']
    (folder / "level.toml").write_text(HEAD + "\n".join(entries))
    return folder / "level.toml"
