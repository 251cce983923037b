"""Scene files the loader refuses, each in one line naming the file, the line and the key;
mesh paths that leave the folder; colours."""

from __future__ import annotations

import json
import os
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

from game.errors import SceneError
from game.scene import (
    load_scene,
    mesh_files,
    parse_scene,
)
from game.scene.loader import MAX_LIGHTS
from tests.scene.scene_texts import CAPSULE, HEAD, scene_with, with_lights

MARK = "# <-"


def expect_error(tmp_path: Path, text: str, where: str, *fragments: str,
                 name: str = "scene.toml") -> str:
    """Load ``text`` from a file; the error must name the marked line, ``where`` and fragments."""
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(SceneError) as info:
        load_scene(path)
    message = str(info.value)
    marked = [i + 1 for i, line in enumerate(text.splitlines()) if MARK in line]
    assert "\n" not in message
    assert message.startswith(f"{path}:{marked[0]}: {where}:"), message
    for fragment in fragments:
        assert fragment in message, message
    return message


STATIC_ERRORS = [
    ('shape = "box"\nsize = [1, 1, 1]\npositon = [0, 0, 0] ' + MARK,
     "static[0].positon", ["unknown key", "did you mean 'position'"]),
    ('shape = "box"\nsize = [1, 1, 1]\nradius = 2 ' + MARK,
     "static[0].radius", ["not a key of shape 'box'"]),
    ('shape = "sphere"\nradius = "big" ' + MARK, "static[0].radius", ["must be a number"]),
    ('shape = "sphere"\nradius = nan ' + MARK, "static[0].radius", ["finite"]),
    ('shape = "box"\nsize = [1, inf, 1] ' + MARK, "static[0].size", ["finite"]),
    ('shape = "box"\nsize = [1, -1, 1] ' + MARK, "static[0].size", ["must be positive"]),
    ('shape = "box"\nsize = [1, 1] ' + MARK, "static[0].size", ["3 numbers"]),
    ('shape = "box"\nsize = [1, 1, 1]\nscale = -1.0 ' + MARK, "static[0].scale",
     ["must be positive, got -1.0"]),
    ('shape = "box"\nsize = [1, 1, 1]\nscale = "big" ' + MARK, "static[0].scale",
     ["must be a number or a list of 3 numbers, got 'big'"]),
    ('shape = "box"\nsize = [1, 1, 1]\nposition = [0, true, 0] ' + MARK,
     "static[0].position", ["3 numbers"]),
    ('shape = "boxx" ' + MARK, "static[0].shape", ["did you mean 'box'"]),
    ('shape = "capsule"\nradius = 1\nheight = 1.5 ' + MARK, "static[0].height",
     ["2 * radius"]),
    ('shape = "cone"\nradius = 0 ' + MARK + '\nheight = 1', "static[0].radius", ["positive"]),
]


@pytest.mark.parametrize(("body", "where", "fragments"), STATIC_ERRORS)
def test_invalid_static(tmp_path, body, where, fragments):
    # A valid static comes first, so the message must count the failing one as index 1.
    text = HEAD + '[[static]]\nshape = "sphere"\nradius = 1\n[[static]]\n' + body + "\n"
    expect_error(tmp_path, text, where.replace("[0]", "[1]"), *fragments)


@pytest.mark.parametrize(("body", "key"), [
    ('shape = "box"\nposition = [0, 1, 0]', "size"),
    ('shape = "cylinder"\nradius = 1', "height"),
    ("position = [0, 1, 0]", "shape"),
])
def test_missing_key_points_at_the_table_header(tmp_path, body, key):
    text = HEAD + "[[static]] " + MARK + f"\n{body}\n"
    expect_error(tmp_path, text, f"static[0].{key}", "missing required key")


@pytest.mark.parametrize(("text", "where", "fragments"), [
    (HEAD.replace('kind = "directional"', 'kind = "sun" ' + MARK), "light.kind",
     ["unknown value 'sun'"]),
    (HEAD.replace("direction = [0.0, -2.0, 0.0]", "direction = [0, 0, 0] " + MARK),
     "light.direction", ["zero"]),
    (HEAD + "cone = 40 " + MARK + "\n", "light.cone", ["not used by a 'directional' light"]),
    (HEAD.replace('kind = "directional"', 'kind = "spot"').replace("[light]", "[light] " + MARK),
     "light.position", ["missing required key"]),
    (HEAD.replace("[light]", "[light] " + MARK).replace(
        'kind = "directional"\n', ""), "light.kind", ["missing required key"]),
    (HEAD.replace("target = [0.0, 0.0, 0.0]\n", "").replace("[camera]", "[camera] " + MARK),
     "camera.target", ["missing required key"]),
    (HEAD.replace("target = [0.0, 0.0, 0.0]", "target = [0.0, 2.0, 10.0] " + MARK),
     "camera.target", ["must differ"]),
    (HEAD.replace("[camera]", "[camera]\nfov = 180 " + MARK), "camera.fov", ["less than 180"]),
    (HEAD.replace("[camera]", "[camera]\nnear = 0 " + MARK), "camera.near", ["positive"]),
    (HEAD.replace("[camera]", "[camera]\nnear = 5.0\nfar = 1.0 " + MARK), "camera.far",
     ["near (5) must be less than far (1)"]),
    (HEAD + "[linear_light]\na = [0, 5, 0]\nb = [0, 5, 0] " + MARK + "\n", "linear_light.b",
     ["0 m long", "a and b apart"]),
    (HEAD + "[linear_light]\na = [0, 5, 0]\nb = [0, 5, 1e-13] " + MARK + "\n", "linear_light.b",
     ["1e-13 m long"]),
    (HEAD + "[linear_light]\na = [0, 5, 0]\nc = [1, 5, 0] " + MARK + "\n", "linear_light.c",
     ["unknown key"]),
    (HEAD.replace('name = "test"', 'name = "test"\ncolour = "red" ' + MARK), "colour",
     ["unknown key"]),
    (HEAD + "[camra] " + MARK + "\nfov = 3\n", "camra", ["did you mean 'camera'"]),
    (HEAD + '[floor] ' + MARK + '\nshape = "box"\nsize = [1, 1, 1]\n', "floor",
     ["array of tables", "[[floor]]"]),
    (HEAD + "[generate]\nblocs = 2 " + MARK + "\n", "generate.blocs",
     ["did you mean 'blocks'"]),
    (HEAD + "[generate]\ndetail = 1.5 " + MARK + "\n", "generate.detail", ["integer"]),
])
def test_invalid_tables(tmp_path, text, where, fragments):
    expect_error(tmp_path, text, where, *fragments)


ONE_POINT = '[[light]]\nkind = "point"\nposition = [0, 3, 0]\n'


@pytest.mark.parametrize(("lights", "where", "fragments"), [
    ('[[light]]\nkind = "directional"\ndirection = [0, -1, 0]\nrange = 10 ' + MARK + "\n",
     "light[0].range", ["not used by a 'directional' light"]),
    ('[light]\nkind = "directional"\ndirection = [0, -1, 0]\nrange = 10 ' + MARK + "\n",
     "light.range", ["not used by a 'directional' light"]),
    (ONE_POINT + ONE_POINT + "color = [0.5, 1.5, 0.0] " + MARK + "\n", "light[1].color",
     ["[0, 1]"]),
    (ONE_POINT + "color = [-0.1, 0.5, 0.5] " + MARK + "\n", "light[0].color", ["[0, 1]"]),
    (ONE_POINT + "color = [1, 1] " + MARK + "\n", "light[0].color", ["3 numbers"]),
    (ONE_POINT + ONE_POINT + ONE_POINT + "intensity = -0.5 " + MARK + "\n",
     "light[2].intensity", ["must not be negative, got -0.5"]),
    (ONE_POINT + 'intensity = "bright" ' + MARK + "\n", "light[0].intensity",
     ["must be a number"]),
    (ONE_POINT + "intensity = inf " + MARK + "\n", "light[0].intensity", ["finite"]),
    (ONE_POINT + "range = 0 " + MARK + "\n", "light[0].range", ["must be positive, got 0.0"]),
    (ONE_POINT + ONE_POINT + "range = -3 " + MARK + "\n", "light[1].range",
     ["must be positive, got -3.0"]),
    (ONE_POINT + "range = nan " + MARK + "\n", "light[0].range", ["finite"]),
    (ONE_POINT + "colour = [1, 1, 1] " + MARK + "\n", "light[0].colour",
     ["unknown key", "did you mean 'color'"]),
    (ONE_POINT + '[[light]] ' + MARK + '\nkind = "spot"\nposition = [0, 3, 0]\n'
     "direction = [0, -1, 0]\n", "light[1].cone", ["missing required key"]),
])
def test_invalid_lights(tmp_path, lights, where, fragments):
    expect_error(tmp_path, with_lights(lights), where, *fragments)


def test_an_empty_light_array_is_refused(tmp_path):
    # TOML cannot write an empty [[light]] array, but `light = []` is one.
    text = f'name = "test"\nlight = [] {MARK}\n\n' + HEAD.split("[light]")[0].split("\n", 1)[1]
    expect_error(tmp_path, text, "light", "at least one light")


def test_more_than_the_most_lights_is_refused(tmp_path):
    ok = parse_scene(with_lights(ONE_POINT * MAX_LIGHTS))
    assert len(ok.lights) == MAX_LIGHTS == 64
    text = with_lights(ONE_POINT * MAX_LIGHTS + "[[light]] " + MARK + "\n"
                       'kind = "point"\nposition = [0, 3, 0]\n')
    expect_error(tmp_path, text, f"light[{MAX_LIGHTS}]", f"at most {MAX_LIGHTS} lights, got 65")


@pytest.mark.parametrize(("value", "where"), [("3", "light"), ('["sun"]', "light[0]")])
def test_a_light_that_is_not_a_table_is_refused(tmp_path, value, where):
    text = f"light = {value} {MARK}\n" + HEAD.split("[light]")[0].split("\n", 1)[1]
    expect_error(tmp_path, text, where, "must be a table")


def test_a_light_table_and_a_light_array_together_are_refused(tmp_path):
    text = HEAD + ONE_POINT.replace("[[light]]", "[[light]] " + MARK)
    message = expect_error(tmp_path, text, "light")
    assert "either one [light] table or a [[light]] array, not both" in message
    assert "TOML" not in message


def test_missing_light_table(tmp_path):
    text = HEAD.split("[light]")[0]
    path = tmp_path / "s.toml"
    path.write_text(text)
    with pytest.raises(SceneError, match=r"s\.toml:1: light: missing required table \[light\]"):
        load_scene(path)


@pytest.mark.parametrize(("body", "where", "fragments"), [
    ("path = [] " + MARK, "character[0].path", ["non-empty list"]),
    ("path = [[1, 0.9, 1], [1, 0.9, 1]] " + MARK, "character[0].path", ["zero length"]),
    ("path = [[1, 0.9, 1], [1, 0.9]] " + MARK, "character[0].path", ["point 1", "3 numbers"]),
    ("path = [[1, nan, 1]] " + MARK, "character[0].path", ["point 0", "finite"]),
    ("path = [[0, 0.9, 0]]\nspeed = -1 " + MARK, "character[0].speed", ["negative"]),
    ("path = [[0, 0.9, 0]]\nposition = [0, 0, 0] " + MARK, "character[0].position",
     ["characters have no position"]),
])
def test_invalid_character(tmp_path, body, where, fragments):
    text = HEAD + f"[[character]]\n{CAPSULE}{body}\n"
    expect_error(tmp_path, text, where, *fragments)


def test_missing_path(tmp_path):
    text = HEAD + "[[character]] " + MARK + f"\n{CAPSULE}"
    expect_error(tmp_path, text, "character[0].path", "missing required key")


def test_toml_syntax_error_has_the_line(tmp_path):
    text = HEAD + "[[static]]\nshape = box " + MARK + "\n"
    message = expect_error(tmp_path, text, "TOML syntax error", "line 11")
    assert re.search(r"column \d+", message)


# ---- Mesh files


def mesh_scene(tmp_path: Path, file: str) -> str:
    folder = tmp_path / "scene"
    folder.mkdir(exist_ok=True)
    return HEAD + f'[[static]]\nshape = "mesh"\nfile = "{file}" {MARK}\n'


def expect_mesh_error(tmp_path: Path, file: str, *fragments: str) -> str:
    return expect_error(tmp_path / "scene", mesh_scene(tmp_path, file), "static[0].file",
                        *fragments)


def test_mesh_path_leaving_the_folder_is_refused_before_opening(tmp_path):
    trimesh.creation.box().export(tmp_path / "outside.obj")  # exists, still refused
    expect_mesh_error(tmp_path, "../outside.obj", "leaves the scene's folder")
    expect_mesh_error(tmp_path, "models/../../outside.obj", "leaves the scene's folder")


def test_absolute_mesh_path_is_refused(tmp_path):
    trimesh.creation.box().export(tmp_path / "outside.obj")
    expect_mesh_error(tmp_path, (tmp_path / "outside.obj").as_posix(), "absolute")


def test_symlink_out_of_the_folder_is_refused(tmp_path):
    trimesh.creation.box().export(tmp_path / "outside.obj")
    (tmp_path / "scene").mkdir()
    (tmp_path / "scene" / "link.obj").symlink_to(tmp_path / "outside.obj")
    (tmp_path / "scene" / "dir").symlink_to(tmp_path, target_is_directory=True)
    expect_mesh_error(tmp_path, "link.obj", "outside the scene's folder")
    expect_mesh_error(tmp_path, "dir/outside.obj", "outside the scene's folder")


def test_missing_mesh_file(tmp_path):
    message = expect_mesh_error(tmp_path, "models/nothere.obj", "file not found")
    assert str(tmp_path / "scene" / "models" / "nothere.obj") in message  # where it looked


def test_non_mesh_files(tmp_path):
    (tmp_path / "scene").mkdir()
    (tmp_path / "scene" / "notes.txt").write_text("hello")
    (tmp_path / "scene" / "text.obj").write_text("this is not a mesh\n")
    (tmp_path / "scene" / "junk.glb").write_bytes(b"garbage!")
    (tmp_path / "scene" / "junk.ply").write_bytes(b"garbage!")
    (tmp_path / "scene" / "folder.obj").mkdir()
    expect_mesh_error(tmp_path, "notes.txt", "unsupported mesh format '.txt'")
    expect_mesh_error(tmp_path, "text.obj", "no triangles")
    expect_mesh_error(tmp_path, "junk.glb", "cannot read mesh")
    expect_mesh_error(tmp_path, "junk.ply", "cannot read mesh")
    expect_mesh_error(tmp_path, "folder.obj", "folder.obj: not a regular file (a folder)")


def test_bad_mesh_contents(tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "nan.obj").write_text("v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n")
    (folder / "flat.obj").write_text("v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
    expect_mesh_error(tmp_path, "nan.obj", "non-finite")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing is left to warn about: it is an error
        expect_mesh_error(tmp_path, "flat.obj", "zero area")


def test_gltf_buffer_outside_the_folder_is_refused(tmp_path):
    folder = tmp_path / "scene"
    folder.mkdir()
    (tmp_path / "secret.bin").write_bytes(b"\0" * 36)
    document = {"asset": {"version": "2.0"}, "buffers": [{"uri": "../secret.bin",
                                                          "byteLength": 36}]}
    (folder / "m.gltf").write_text(json.dumps(document))
    expect_mesh_error(tmp_path, "m.gltf", "leaves the scene's folder")


def test_in_memory_errors_name_the_scene():
    with pytest.raises(SceneError, match=r"^<scene>:9: light\.direction: must not be zero"):
        parse_scene(HEAD.replace("[0.0, -2.0, 0.0]", "[0, 0, 0]"))


def test_unreadable_scene_file(tmp_path):
    with pytest.raises(SceneError, match=r"^file not found: .*missing\.toml$"):
        load_scene(tmp_path / "missing.toml")
    (tmp_path / "binary.toml").write_bytes(b"name = 'x'\n\xff\xfe")
    with pytest.raises(SceneError, match=r"binary\.toml:2: not a UTF-8"):
        load_scene(tmp_path / "binary.toml")


# --------------------------------------------------------------------------------------------
# Colours: the scene's `color`, and the base colours of a glTF's materials


def test_color_is_an_optional_srgb_triple_per_object():
    s = scene_with('[[static]]\nshape = "sphere"\nradius = 1\ncolor = [0.2, 0.4, 1]\n'
                   '[[static]]\nshape = "sphere"\nradius = 1\n'
                   f'[[character]]\n{CAPSULE}path = [[0, 0.9, 0]]\ncolor = [1, 0, 0]\n')
    assert np.allclose(s.statics[0].colour, [0.2, 0.4, 1.0])
    assert s.statics[1].colour is None
    assert np.allclose(s.characters[0].colour, [1.0, 0.0, 0.0])


def test_a_color_outside_zero_to_one_is_refused(tmp_path):
    expect_error(tmp_path, HEAD + '[[static]]\nshape = "sphere"\nradius = 1\n'
                 f'color = [0.5, 1.5, 0.0]  {MARK}\n', "static[0].color", "[0, 1]")


def test_gltf_materials_give_their_parts_base_colours(courtyard):
    """The cottage's parts (walls, roof, chimney, door) carry their own colours, linear RGB."""
    from game.scene.mesh_files import FILE_COLOUR, FILE_PART

    cottage = courtyard.statics[20].mesh
    colours = np.asarray(cottage.face_attributes[FILE_COLOUR])
    parts = np.asarray(cottage.face_attributes[FILE_PART])
    per_part = {tuple(np.round(colours[parts == p], 3)[0]) for p in np.unique(parts)}
    assert len(per_part) == 4
    for p in np.unique(parts):  # one colour per part
        assert len(np.unique(colours[parts == p], axis=0)) == 1


def test_a_material_whose_colour_is_not_four_numbers_is_left_out(tmp_path):
    from game import gltf

    document = {"materials": [{"pbrMetallicRoughness": {"baseColorFactor": [2, 0, 0, 1]}},
                              {"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1]},
                               "normalTexture": {"index": 0}}],
                "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0},
                                           {"attributes": {"POSITION": 0}, "material": 1},
                                           {"attributes": {"POSITION": 0}, "material": "x"}]}]}
    kept = gltf.geometry_only(document)
    # Only the valid factor survives, alone, and only its primitive keeps a material.
    assert kept["materials"] == [{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5,
                                                                                1.0]}}]
    assert [p.get("material") for p in kept["meshes"][0]["primitives"]] == [None, 0, None]


# --------------------------------------------------------------------------------------------
# Every file a scene names is checked by one helper before it is read


@pytest.mark.parametrize("special, kind", [("fifo", "a FIFO"), ("folder", "a folder"),
                                           ("device", "a device or socket")])
def test_a_scene_file_that_is_not_a_regular_file_says_what_it_is(tmp_path, special, kind):
    path = tmp_path / "s.toml"
    if special == "fifo":
        os.mkfifo(path)   # opening it to read would wait for a writer for good
    elif special == "folder":
        path.mkdir()
    else:
        path = Path("/dev/null")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    assert str(info.value) == f"{path}: not a regular file ({kind})"   # as for a mesh file


def test_every_file_a_scene_names_passes_the_one_check(tmp_path, monkeypatch):
    checked = []
    real = mesh_files.regular_file

    def spy(path, shown, fail):
        checked.append(Path(path).name)
        return real(path, shown, fail)

    monkeypatch.setattr(mesh_files, "regular_file", spy)
    trimesh.creation.box().export(tmp_path / "box.obj")
    trimesh.creation.box().export(tmp_path / "box.gltf")   # with its buffer file beside it
    buffers = json.loads((tmp_path / "box.gltf").read_text())["buffers"]
    scene = tmp_path / "s.toml"
    scene.write_text(HEAD + '[[static]]\nshape = "mesh"\nfile = "box.obj"\n'
                     '[[static]]\nshape = "mesh"\nfile = "box.gltf"\n')
    load_scene(scene)
    assert {"s.toml", "box.obj", "box.gltf", *(b["uri"] for b in buffers)} <= set(checked)
