"""A static mesh split into parts (game/scene/parts.py): the file's structure, connected
components, and a bound on their number."""

from __future__ import annotations

import numpy as np
import trimesh

from game.scene import load_scene
from game.scene.mesh_files import FILE_PART
from game.scene.parts import connected_components, median_groups, mesh_parts


def boxes(n: int, spacing: float = 3.0) -> trimesh.Trimesh:
    return trimesh.util.concatenate([trimesh.creation.box().apply_translation([spacing * i, 0, 0])
                                     for i in range(n)])


def test_separate_boxes_are_separate_components():
    mesh = boxes(5)
    labels = connected_components(mesh.vertices, mesh.faces)
    assert sorted(np.bincount(labels)) == [12] * 5
    # Each box's faces share one label, and the labels follow the boxes' order.
    assert [len(set(labels[12 * i:12 * i + 12])) for i in range(5)] == [1] * 5


def test_corners_duplicated_per_face_are_welded():
    """An STL (or an OBJ with per-face normals) repeats every corner: one box is still one part."""
    box = trimesh.creation.box()
    soup = trimesh.Trimesh(box.vertices[box.faces].reshape(-1, 3),
                           np.arange(3 * len(box.faces)).reshape(-1, 3), process=False)
    assert connected_components(soup.vertices, soup.faces).max() == 0


def test_a_long_chain_is_one_component():
    """Label propagation with pointer jumping: a strip of 20,000 triangles is one component."""
    n = 10_000
    x = np.arange(n + 1, dtype=float)
    vertices = np.concatenate([np.stack([x, np.zeros_like(x), np.zeros_like(x)], 1),
                               np.stack([x, np.ones_like(x), np.zeros_like(x)], 1)])
    i = np.arange(n)
    faces = np.concatenate([np.stack([i, i + 1, n + 1 + i], 1),
                            np.stack([i + 1, n + 2 + i, n + 1 + i], 1)])
    assert connected_components(vertices, faces).max() == 0


def test_the_file_structure_splits_connected_faces():
    mesh = trimesh.creation.box()
    structure = np.repeat([0, 1], 6)
    assert mesh_parts(mesh.vertices, mesh.faces, structure).max() == 1
    assert mesh_parts(mesh.vertices, mesh.faces, None).max() == 0


def test_too_many_components_are_merged_into_neighbouring_groups():
    mesh = boxes(40)
    labels = mesh_parts(mesh.vertices, mesh.faces, limit=8)
    assert labels.max() + 1 == 8
    # Neighbours stay together: each group is a run of consecutive boxes.
    per_box = labels[::12]
    assert all(np.all(np.diff(np.flatnonzero(per_box == g)) == 1) for g in range(8))


def test_median_groups_gives_at_most_the_count_asked():
    rng = np.random.default_rng(3)
    for count in (1, 2, 7, 64):
        labels = median_groups(rng.random((500, 3)), count)
        assert labels.max() + 1 == count and set(labels) == set(range(count))


def test_obj_objects_are_kept_as_the_file_structure(tmp_path):
    """Two objects in one OBJ that touch (one shared corner position) are two parts."""
    text = ("o first\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
            "o second\nv 1 0 0\nv 2 0 0\nv 1 1 0\nf 4 5 6\n")
    (tmp_path / "two.obj").write_text(text)
    (tmp_path / "s.toml").write_text(
        '[camera]\nposition = [0, 5, 5]\ntarget = [0, 0, 0]\n'
        '[light]\nkind = "directional"\ndirection = [0, -1, 0]\n'
        '[[static]]\nshape = "mesh"\nfile = "two.obj"\n')
    mesh = load_scene(tmp_path / "s.toml").statics[0].mesh
    assert sorted(mesh.face_attributes[FILE_PART]) == [0, 1]
    assert mesh_parts(mesh.vertices, mesh.faces, mesh.face_attributes[FILE_PART]).max() == 1
