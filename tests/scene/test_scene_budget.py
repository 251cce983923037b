"""What a whole scene draws after instancing, held to one total: many entries naming one large
file, a glTF's nodes placing a mesh, crowds of walkers, a generated town. Each is refused in one
line naming the entry that passes the total, before the meshes that would pass it are built."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from game import gltf
from game.errors import SceneError
from game.scene import budget, load_scene, loader
from game.scene.budget import MAX_SCENE_TRIANGLES
from tests.scene.scene_texts import HEAD


def instancing_glb(triangles: int, nodes: int) -> bytes:
    """A small GLB whose ``nodes`` each place one mesh of ``triangles`` triangles, all indexing
    the same three corners: a few kilobytes that draw ``nodes * triangles`` triangles."""
    positions = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32).tobytes()
    indices = np.tile(np.array([0, 1, 2], np.uint32), triangles).tobytes()
    document = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": list(range(nodes))}],
        "nodes": [{"mesh": 0, "translation": [2 * i, 0, 0]} for i in range(nodes)],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
             "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5125, "count": 3 * triangles,
             "type": "SCALAR"}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                        {"buffer": 0, "byteOffset": 36, "byteLength": len(indices)}],
        "buffers": [{"byteLength": 36 + len(indices)}],
    }
    return gltf.join_glb(document, positions + indices)


def mesh_entries(kind: str, file: str, count: int) -> str:
    extra = 'path = [[0.0, 0.0, 0.0]]\n' if kind == "character" else ""
    return f'[[{kind}]]\nshape = "mesh"\nfile = "{file}"\n{extra}' * count


def refused(path, *fragments: str) -> str:
    with pytest.raises(SceneError) as info:
        load_scene(path)
    message = str(info.value)
    assert "\n" not in message
    for fragment in fragments:
        assert fragment in message, message
    return message


@pytest.fixture
def no_mesh_read(monkeypatch):
    """Fail the test if trimesh is handed any mesh file."""
    monkeypatch.setattr(trimesh, "load", lambda *a, **k: pytest.fail("trimesh got a file"))


def test_entries_that_each_name_a_large_gltf_are_refused_before_any_is_read(tmp_path,
                                                                             no_mesh_read):
    # 9 M triangles each: within what one mesh file may draw, twice more than a scene may.
    (tmp_path / "m.glb").write_bytes(instancing_glb(30_000, 300))
    scene = tmp_path / "s.toml"
    scene.write_text(HEAD + mesh_entries("static", "m.glb", 2))
    message = refused(scene, "static[1].file", "18,000,000 triangles",
                      f"at most {MAX_SCENE_TRIANGLES:,}")
    assert message.startswith(f"{scene}:15: "), message


def test_a_crowd_of_walkers_each_with_a_mesh_is_refused_at_once(tmp_path, no_mesh_read):
    # 4,096 walkers, as many as a file may list, of 5,000 triangles each: 20 M in all.
    (tmp_path / "walker.glb").write_bytes(instancing_glb(5_000, 1))
    scene = tmp_path / "s.toml"
    scene.write_text(HEAD + mesh_entries("character", "walker.glb", loader.MAX_CHARACTERS))
    first_over = MAX_SCENE_TRIANGLES // 5_000
    refused(scene, f"character[{first_over}].file",
            f"{(first_over + 1) * 5_000:,} triangles", "every walker")


def test_analytic_shapes_past_the_total_are_refused_before_any_is_built(tmp_path, monkeypatch):
    spheres, (triangles, _) = 10, budget.shape_draw("sphere")
    monkeypatch.setattr(budget, "MAX_SCENE_TRIANGLES", triangles * (spheres - 1))
    monkeypatch.setattr(loader, "sphere_mesh", lambda r: pytest.fail("a sphere was built"))
    scene = tmp_path / "s.toml"
    scene.write_text(HEAD + '[[static]]\nshape = "sphere"\nradius = 1\n' * spheres)
    refused(scene, f"static[{spheres - 1}].shape", f"{triangles * spheres:,} triangles")


def test_a_file_named_again_is_refused_before_it_is_read_again(tmp_path, monkeypatch):
    # An OBJ's count is known once it is read: the next entry naming it is checked first.
    trimesh.creation.box().export(tmp_path / "box.obj")
    monkeypatch.setattr(budget, "MAX_SCENE_VERTICES", 20)
    reads = []
    real_load = trimesh.load

    def counted(*args, **kwargs):
        reads.append(args)
        return real_load(*args, **kwargs)

    monkeypatch.setattr(trimesh, "load", counted)
    scene = tmp_path / "s.toml"
    scene.write_text(HEAD + mesh_entries("static", "box.obj", 5))
    refused(scene, "static[2].file", "24 vertices", "at most 20")
    assert len(reads) == 2


def test_a_generated_town_counts_towards_the_total(tmp_path, monkeypatch):
    monkeypatch.setattr(budget, "MAX_SCENE_TRIANGLES", 1_000)
    scene = tmp_path / "s.toml"
    scene.write_text(HEAD + "[generate]\nblocks = 1\ncharacters = 1\n")
    refused(scene, "generate: its town brings the scene to", "at most 1,000")


def test_a_scene_within_the_totals_loads_and_files_count_once_per_entry(tmp_path):
    (tmp_path / "m.glb").write_bytes(instancing_glb(1_000, 3))
    scene = tmp_path / "s.toml"
    scene.write_text(HEAD + mesh_entries("static", "m.glb", 2)
                     + mesh_entries("character", "m.glb", 2))
    loaded = load_scene(scene)
    assert [len(b.mesh.faces) for b in loaded.statics + loaded.characters] == [3_000] * 4
