"""Build the small models of the default scene: assets/models/arch.obj and house.glb.

Run ``python assets/make_models.py`` to rebuild them (``--out DIR`` writes them elsewhere); the
outputs are committed so that loading the default scene never depends on this script. Both models
stand on y = 0 in their own coordinates, so a scene places them with ``position = [x, 0, z]``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import trimesh

from game.scene.geometry import srgb_to_linear

MODELS = Path(__file__).parent / "models"

ARCH_PILLAR_HEIGHT = 3.0  # metres, springing line of the arch
ARCH_INNER_RADIUS = 1.2  # metres, half the opening
ARCH_RING_WIDTH = 0.8  # metres, also the pillars' side
ARCH_DEPTH = 0.8  # metres along z
ARCH_SEGMENTS = 16


def _checked(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The mesh, once it is closed and consistently wound; the faces are wound by hand because
    trimesh's ``fix_normals`` needs scipy and networkx, which are not dependencies."""
    if not (mesh.is_watertight and mesh.is_winding_consistent):
        raise ValueError("model is not closed and consistently wound")
    return mesh


def _outward(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """Flip a closed mesh whose faces point inwards (negative signed volume)."""
    if mesh.volume < 0:
        mesh.invert()
    return mesh


def half_ring(inner: float, outer: float, depth: float, segments: int) -> trimesh.Trimesh:
    """A half annulus in the xy-plane (angles 0 to 180 degrees) extruded along z, centred."""
    angles = np.linspace(0.0, np.pi, segments + 1)
    ring = []
    for radius in (inner, outer):
        for z in (-0.5 * depth, 0.5 * depth):
            ring.append(np.column_stack([radius * np.cos(angles), radius * np.sin(angles),
                                         np.full_like(angles, z)]))
    vertices = np.concatenate(ring)  # blocks: inner back, inner front, outer back, outer front
    m = segments + 1
    ib, i_f, ob, of = 0, m, 2 * m, 3 * m
    faces = []
    for k in range(segments):
        for a, b in ((ib, i_f), (of, ob), (i_f, of), (ob, ib)):  # inner, outer, front, back
            faces.append([a + k, b + k, b + k + 1])
            faces.append([a + k, b + k + 1, a + k + 1])
    # The two ends rest on the pillars and face down; at angle pi the inner-to-outer direction is
    # -x instead of +x, so that end's triangles are wound the other way round.
    faces.append([ib, ob, of])
    faces.append([ib, of, i_f])
    faces.append([of + segments, ob + segments, ib + segments])
    faces.append([i_f + segments, of + segments, ib + segments])
    mesh = trimesh.Trimesh(vertices=vertices, faces=np.array(faces), process=True)
    return _outward(_checked(mesh))


def arch() -> trimesh.Trimesh:
    """Two square pillars on plinths carrying a semicircular ring of stone."""
    side = ARCH_RING_WIDTH
    centre_x = ARCH_INNER_RADIUS + 0.5 * side
    parts = []
    for sign in (-1.0, 1.0):
        pillar = trimesh.creation.box(extents=(side, ARCH_PILLAR_HEIGHT, ARCH_DEPTH))
        pillar.apply_translation((sign * centre_x, 0.5 * ARCH_PILLAR_HEIGHT, 0.0))
        plinth = trimesh.creation.box(extents=(side + 0.2, 0.3, ARCH_DEPTH + 0.2))
        plinth.apply_translation((sign * centre_x, 0.15, 0.0))
        parts += [pillar, plinth]
    ring = half_ring(ARCH_INNER_RADIUS, ARCH_INNER_RADIUS + side, ARCH_DEPTH, ARCH_SEGMENTS)
    ring.apply_translation((0.0, ARCH_PILLAR_HEIGHT, 0.0))
    parts.append(ring)
    return trimesh.util.concatenate(parts)


def gable_roof(length: float, width: float, rise: float) -> trimesh.Trimesh:
    """A triangular prism along x: eaves at y = 0 (z = +-width/2), ridge at y = rise."""
    x0, x1, h = -0.5 * length, 0.5 * length, 0.5 * width
    vertices = np.array([[x, y, z] for x in (x0, x1) for (y, z) in ((0, -h), (0, h), (rise, 0))],
                        dtype=np.float64)
    faces = np.array([[0, 1, 2], [3, 5, 4],  # gable ends
                      [0, 2, 5], [0, 5, 3],  # back slope
                      [1, 4, 5], [1, 5, 2],  # front slope
                      [0, 3, 4], [0, 4, 1]])  # underside
    mesh = trimesh.Trimesh(vertices=vertices, faces=faces, process=True)
    return _outward(_checked(mesh))


# The cottage's parts' colours, sRGB: glTF stores a material's base colour as linear RGB.
HOUSE_COLOURS = {"walls": (0.90, 0.84, 0.70), "roof": (0.68, 0.30, 0.20),
                 "chimney": (0.56, 0.36, 0.28), "door": (0.42, 0.26, 0.14)}


def _material(srgb) -> trimesh.visual.TextureVisuals:
    material = trimesh.visual.material.PBRMaterial(
        baseColorFactor=[*srgb_to_linear(srgb), 1.0])
    return trimesh.visual.TextureVisuals(material=material)


def house() -> trimesh.Scene:
    """A cottage: walls, a gable roof resting on them, a chimney and a door, as separate nodes,
    each with its own base colour."""
    walls = trimesh.creation.box(extents=(4.0, 2.6, 3.0))
    walls.apply_translation((0.0, 1.3, 0.0))
    roof = gable_roof(length=4.6, width=3.6, rise=1.5)
    roof.apply_translation((0.0, 2.55, 0.0))  # sunk 5 cm into the walls so it rests on them
    chimney = trimesh.creation.box(extents=(0.5, 1.4, 0.5))
    chimney.apply_translation((1.2, 3.4, -0.6))
    door = trimesh.creation.box(extents=(0.9, 1.9, 0.1))
    door.apply_translation((-0.6, 0.95, 1.52))
    scene = trimesh.Scene()
    for name, mesh in (("walls", walls), ("roof", roof), ("chimney", chimney), ("door", door)):
        mesh.visual = _material(HOUSE_COLOURS[name])
        scene.add_geometry(mesh, node_name=name, geom_name=name)
    return scene


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=MODELS, metavar="DIR",
                        help="folder to write arch.obj and house.glb to (default: assets/models)")
    out = parser.parse_args(argv).out
    out.mkdir(parents=True, exist_ok=True)
    arch().export(out / "arch.obj")
    house().export(out / "house.glb")


if __name__ == "__main__":
    main()
