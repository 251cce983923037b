"""Hostile mesh files: glTF and GLB documents, OBJ groups and STL files that would hang,
exhaust memory or read outside the scene's folder, each refused in one line.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest
import trimesh

from game import gltf
from game.scene.mesh_files import binary_stl_damage
from tests.cli.cli_helpers import expect_scene_error, run_main
from tests.cli.hostile_files import (
    big_png,
    chain_of_nodes,
    data_uri_declaring_more,
    float_indices,
    glb_with,
    gltf_scene,
    mesh_scene,
    one_triangle,
    scene_five,
)
from tests.helpers import ROOT
from tests.helpers import TINY as TINY_PATH

TINY = TINY_PATH.read_text()


@pytest.mark.parametrize("uri", ["/etc/passwd", "../secret.bin", "file:///etc/passwd",
                                 "sub/../../secret.bin"])
@pytest.mark.parametrize("section", ["buffers", "images"])
def test_a_glb_naming_an_outside_file_is_refused_before_trimesh_reads_it(
        capsys, tmp_path, monkeypatch, uri, section):
    folder = tmp_path / "scene"
    folder.mkdir()
    (tmp_path / "secret.bin").write_bytes(b"\0" * 64)
    extra = ({"buffers": lambda d: d["buffers"] + [{"uri": uri, "byteLength": 64}]}
             if section == "buffers" else {"images": [{"uri": uri}]})
    (folder / "level.glb").write_bytes(glb_with(extra))
    monkeypatch.setattr(trimesh, "load", lambda *a, **k: pytest.fail("trimesh got the file"))
    expect_scene_error(capsys, folder, mesh_scene(folder, "level.glb"), None, "static[2].file",
                       "URI")


def test_a_gltf_naming_an_outside_buffer_is_refused(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "level.gltf").write_text(json.dumps(
        {"asset": {"version": "2.0"}, "buffers": [{"uri": "../../x.bin", "byteLength": 4}]}))
    expect_scene_error(capsys, folder, mesh_scene(folder, "level.gltf"), None, "static[2].file",
                       "leaves the scene's folder")


def test_glb_textures_are_never_decoded(capsys, tmp_path, monkeypatch):
    folder = tmp_path / "scene"
    folder.mkdir()
    png = big_png(6000)  # 36 MB of pixels in a few tens of kilobytes
    view = {"buffer": 0, "byteOffset": 48, "byteLength": len(png)}
    extra = {"bufferViews": lambda d: d["bufferViews"] + [view],
             "buffers": [{"byteLength": 48 + len(png)}],
             "images": [{"bufferView": 2, "mimeType": "image/png"}] * 4,
             "textures": [{"source": 0}], "materials": [
                 {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
             "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1,
                                         "material": 0}]}]}
    (folder / "level.glb").write_bytes(glb_with(extra, png))
    import PIL.Image

    decoded = []  # recorded, not raised: trimesh swallows exceptions around image loading
    real_open = PIL.Image.open
    monkeypatch.setattr(PIL.Image, "open", lambda *a, **k: decoded.append(1) or real_open(*a, **k))
    scene = folder / "s.toml"
    scene.write_text(mesh_scene(folder, "level.glb"))
    code, lines = run_main(capsys, "capture", scene, "--size", "16x9", "--out", tmp_path / "o")
    assert code == 0, lines
    assert not decoded


def test_mesh_coordinates_past_float32_are_refused(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "far.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1e39 0 0\nv 0 1e30 0\n"
                                    "v 0 0 1\nf 1 2 3\nf 4 5 6\n")
    expect_scene_error(capsys, folder, mesh_scene(folder, "far.obj"), None, "static[2].file",
                       "at most 1e+09")


def test_a_small_triangle_beside_a_large_one_is_kept(tmp_path):
    from game.scene import load_scene

    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "mixed.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1e8 0 0\nv 0 1e8 0\n"
                                      "v 0 0 1e8\nf 1 2 3\nf 4 5 6\n")
    (folder / "s.toml").write_text(mesh_scene(folder, "mixed.obj").replace(
        'file = "mixed.obj"', 'file = "mixed.obj"\nscale = 1e-3'))
    assert len(load_scene(folder / "s.toml").statics[2].mesh.faces) == 2


# -- paths -----------------------------------------------------------------------------------

@pytest.mark.parametrize("name, fragment", [("a\\u0000b.obj", "NUL"), ("x" * 300 + ".obj",
                                                                        "255 bytes"),
                                            ("loop.obj", "cannot follow")])
def test_odd_mesh_paths(capsys, tmp_path, name, fragment):
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "loop.obj").symlink_to(folder / "loop.obj")
    expect_scene_error(capsys, folder, mesh_scene(folder, name), None, "static[2].file", fragment)


def test_a_truncated_binary_stl_names_the_damage(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    data = trimesh.creation.box().export(file_type="stl")
    (folder / "cut.stl").write_bytes(data[:200])
    message = expect_scene_error(capsys, folder, mesh_scene(folder, "cut.stl"), None,
                                 "static[2].file", "cannot read mesh",
                                 "truncated binary STL", "says 12 triangles, 684 bytes")
    assert "module" not in message


def test_stl_damage_is_judged_from_the_header_and_the_size():
    """The same answer whatever optional modules trimesh finds (it reads a binary STL of the
    wrong size as text, and reported it differently on two machines)."""
    whole = trimesh.creation.box().export(file_type="stl")
    text = trimesh.creation.box().export(file_type="stl_ascii").encode()
    assert binary_stl_damage(whole[:84], len(whole)) is None
    assert binary_stl_damage(text[:84], len(text)) is None
    assert "shorter than its header" in binary_stl_damage(whole[:40], 40)
    assert "the file has 700" in binary_stl_damage(whole[:84], 700)  # padded after the triangles


def test_a_glb_accessor_declaring_more_than_its_buffer_holds(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    huge = {"accessors": [
        {"bufferView": 0, "componentType": 5126, "count": 10**9, "type": "VEC3"},
        {"bufferView": 1, "componentType": 5125, "count": 3, "type": "SCALAR"}]}
    (folder / "level.glb").write_bytes(glb_with(huge))
    expect_scene_error(capsys, folder, mesh_scene(folder, "level.glb"), None, "static[2].file",
                       "1,000,000,000 elements")


def test_a_glb_whose_json_nests_too_deep(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    deep: dict = {}
    for _ in range(200):
        deep = {"x": deep}
    (folder / "level.glb").write_bytes(glb_with({"extras": deep}))
    expect_scene_error(capsys, folder, mesh_scene(folder, "level.glb"), None, "static[2].file",
                       "nests deeper")


def test_a_gltf_holding_a_number_too_long_to_read(capsys, tmp_path):
    """Python refuses to read an integer of more than 4,300 digits: that was an internal error."""
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "level.gltf").write_text('{"asset": {"version": "2.0"}, "accessors": '
                                       '[{"count": ' + "9" * 5000 + "}]}")
    expect_scene_error(capsys, folder, mesh_scene(folder, "level.gltf"), None, "static[2].file",
                       "too long to read")


def test_an_obj_whose_vertices_have_two_coordinates(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "flat.obj").write_text("v 0 0\nv 1 0\nv 0 1\nf 1 2 3\n")
    expect_scene_error(capsys, folder, mesh_scene(folder, "flat.obj"), None, "static[2].file",
                       "three coordinates")


def test_a_glb_accessor_without_data_declaring_millions_of_elements(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    zeros = {"accessors": [{"componentType": 5126, "count": 4 * 10**8, "type": "VEC3"},
                           {"bufferView": 1, "componentType": 5125, "count": 3,
                            "type": "SCALAR"}]}
    (folder / "level.glb").write_bytes(glb_with(zeros))
    expect_scene_error(capsys, folder, mesh_scene(folder, "level.glb"), None, "static[2].file",
                       "without data declares 400,000,000 elements")


@pytest.mark.parametrize("extra", [{"accessors": 5},
                                   {"bufferViews": [{"buffer": 0, "byteLength": 36,
                                                     "byteStride": "a"},
                                                    {"buffer": 0, "byteOffset": 36,
                                                     "byteLength": 12}]},
                                   {"meshes": [{"primitives": 7}]}])
def test_glb_fields_of_the_wrong_type_are_one_line(capsys, tmp_path, extra):
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "level.glb").write_bytes(glb_with(extra))
    message = expect_scene_error(capsys, folder, mesh_scene(folder, "level.glb"), None,
                                 "static[2].file", "cannot read mesh level.glb")
    assert "internal error" not in message


@pytest.mark.parametrize("special", ["fifo", "folder"])
def test_a_gltf_buffer_that_is_not_a_regular_file_is_refused_not_opened(tmp_path, special):
    folder = tmp_path / "scene"
    folder.mkdir()
    if special == "fifo":
        os.mkfifo(folder / "m.bin")  # opening it for reading would wait for a writer for good
    else:
        (folder / "m.bin").mkdir()
    document, _ = one_triangle()
    document["buffers"] = [{"uri": "m.bin", "byteLength": 48}]
    (folder / "s.toml").write_text(gltf_scene(folder, "m.gltf", document))
    result = subprocess.run([sys.executable, "-m", "game", "capture", str(folder / "s.toml"),
                             "--size", "16x9", "--out", str(tmp_path / "o")], cwd=ROOT,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 1, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "static[2].file" in lines[0], lines
    assert "m.bin: not a regular file" in lines[0], lines


def test_a_mesh_file_that_is_a_fifo_is_refused_not_opened(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    os.mkfifo(folder / "m.obj")
    expect_scene_error(capsys, folder, mesh_scene(folder, "m.obj"), None, "static[2].file",
                       "m.obj: not a regular file")


def test_a_deep_chain_of_glb_nodes_is_refused_at_once(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    _, binary = one_triangle()
    start = time.perf_counter()
    expect_scene_error(capsys, folder, gltf_scene(folder, "m.glb", chain_of_nodes(5000), binary),
                       None, "static[2].file", "nodes nest deeper than",
                       str(gltf.MAX_NODE_DEPTH))
    assert time.perf_counter() - start < 10


def test_glb_node_count_and_node_cycles_are_one_line(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    document, binary = one_triangle()
    count = gltf.MAX_NODES + 1
    document["nodes"] = [{} for _ in range(count)]
    expect_scene_error(capsys, folder, gltf_scene(folder, "many.glb", document, binary), None,
                       "static[2].file", f"{count:,} nodes", f"{gltf.MAX_NODES:,}")
    document["nodes"] = [{"mesh": 0, "children": [1]}, {"children": [0]}]
    expect_scene_error(capsys, folder, gltf_scene(folder, "loop.glb", document, binary), None,
                       "static[2].file", "node 0 has more than one parent")


def test_a_glb_within_the_node_limits_loads(tmp_path):
    from game.scene import load_scene

    folder = tmp_path / "scene"
    folder.mkdir()
    _, binary = one_triangle()
    text = gltf_scene(folder, "m.glb", chain_of_nodes(gltf.MAX_NODE_DEPTH), binary)
    (folder / "s.toml").write_text(text)
    assert len(load_scene(folder / "s.toml").statics[2].mesh.faces) == gltf.MAX_NODE_DEPTH


def test_a_gltf_instancing_bomb_is_refused_before_anything_is_allocated(capsys, tmp_path,
                                                                          monkeypatch):
    from game.scene.mesh_files import MAX_INSTANCED_TRIANGLES

    folder = tmp_path / "scene"
    folder.mkdir()
    document, binary = one_triangle()
    triangles = 30_000   # indices into the same three corners: 360 kB that draw 30,000 triangles
    indices = np.tile(np.array([0, 1, 2], np.uint32), triangles).tobytes()
    nodes = MAX_INSTANCED_TRIANGLES // triangles + 1
    document["accessors"][1]["count"] = 3 * triangles
    document["bufferViews"][1]["byteLength"] = len(indices)
    document["buffers"][0]["byteLength"] = 36 + len(indices)
    document["nodes"] = [{"mesh": 0, "translation": [i, 0, 0]} for i in range(nodes)]
    document["scenes"] = [{"nodes": list(range(nodes))}]
    monkeypatch.setattr(trimesh, "load", lambda *a, **k: pytest.fail("trimesh got the file"))
    expect_scene_error(capsys, folder, gltf_scene(folder, "m.glb", document,
                                                  binary[:36] + indices),
                       None, "static[2].file", f"{nodes * triangles:,} triangles",
                       f"{MAX_INSTANCED_TRIANGLES:,}")


@pytest.mark.parametrize("make, fragment", [
    (data_uri_declaring_more, "buffer 0 declares 1,000,000,000 bytes; its data holds 48"),
    (float_indices, "byteStride 1"),
    (scene_five, "'scene' is 5, but the file has 0 scenes"),
])
def test_gltf_problems_are_named_in_the_projects_words(capsys, tmp_path, make, fragment):
    folder = tmp_path / "scene"
    folder.mkdir()
    _, binary = one_triangle()
    document = make()
    message = expect_scene_error(capsys, folder, gltf_scene(folder, "m.glb", document, binary),
                                 None, "static[2].file", "cannot read mesh m.glb", fragment)
    assert "Error" not in message and "index out of range" not in message


def test_a_gltf_buffer_in_a_parent_folder_inside_the_scene_folder_loads(capsys, tmp_path):
    from game.scene import load_scene

    folder = tmp_path / "scene"
    folder.mkdir()
    document, binary = one_triangle()
    (folder / "m.bin").write_bytes(binary)
    document["buffers"] = [{"uri": "../m.bin", "byteLength": len(binary)}]
    (folder / "s.toml").write_text(gltf_scene(folder, "sub/m.gltf", document))
    assert len(load_scene(folder / "s.toml").statics[2].mesh.faces) == 1
    (tmp_path / "x.bin").write_bytes(binary)
    document["buffers"] = [{"uri": "../../x.bin", "byteLength": len(binary)}]
    expect_scene_error(capsys, folder, gltf_scene(folder, "sub/m.gltf", document), None,
                       "static[2].file", "leaves the scene's folder")


@pytest.mark.parametrize("keyword", ["g", "o", "usemtl"])
def test_an_obj_with_more_groups_than_parts_is_refused_while_read(capsys, tmp_path,
                                                                    monkeypatch, keyword):
    from game.scene.parts import MAX_PARTS

    folder = tmp_path / "scene"
    folder.mkdir()
    count = MAX_PARTS + 1
    with open(folder / "m.obj", "w") as obj:
        obj.write("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
        obj.writelines(f"{keyword} part{i}\nf 1 2 3\n" for i in range(count))
    monkeypatch.setattr(trimesh, "load", lambda *a, **k: pytest.fail("trimesh got the file"))
    expect_scene_error(capsys, folder, mesh_scene(folder, "m.obj"), None, "static[2].file",
                       f"more than {MAX_PARTS:,}")


def test_obj_groups_that_repeat_a_name_or_hold_no_faces_are_not_counted_twice(tmp_path):
    from game.scene import load_scene
    from game.scene.parts import MAX_PARTS

    folder = tmp_path / "scene"
    folder.mkdir()
    with open(folder / "m.obj", "w") as obj:
        obj.write("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
        obj.writelines(f"o empty{i}\ng same\nf 1 2 3\n" for i in range(3))
        obj.writelines("g same\r\nf 1 2 3\n" for _ in range(MAX_PARTS + 1))
    (folder / "s.toml").write_text(mesh_scene(folder, "m.obj"))
    assert len(load_scene(folder / "s.toml").statics[2].mesh.faces) == MAX_PARTS + 4


def test_glb_primitives_placed_past_the_limit_and_zero_accessors_in_all(capsys, tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    document, binary = one_triangle()
    primitive = document["meshes"][0]["primitives"][0]
    document["meshes"][0]["primitives"] = [primitive, primitive]
    nodes = gltf.MAX_NODES // 2 + 1
    document["nodes"] = [{"mesh": 0} for _ in range(nodes)]
    document["scenes"] = [{"nodes": list(range(nodes))}]
    expect_scene_error(capsys, folder, gltf_scene(folder, "prims.glb", document, binary), None,
                       "static[2].file", f"{2 * nodes:,} mesh primitives")
    document, binary = one_triangle()
    each = gltf.MAX_ZERO_ACCESSOR_BYTES // 12 * 2 // 3   # two thirds of the limit, twice
    document["accessors"] += [{"componentType": 5126, "count": each, "type": "VEC3"}] * 2
    expect_scene_error(capsys, folder, gltf_scene(folder, "zeros.glb", document, binary), None,
                       "static[2].file", "without data declare more than 64 MiB in all")
