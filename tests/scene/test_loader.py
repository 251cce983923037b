"""The scene model and loader (game/scene/loader.py) against docs/reference.md section 1; no GL."""

from __future__ import annotations

import json
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
import trimesh

from game.errors import SceneError
from game.scene import (
    Character,
    Scene,
    default_scene_path,
    load_scene,
    parse_scene,
    reference_scene_path,
)
from game.scene.loader import MAX_LIGHTS
from game.scene.shapes import transform_mesh
from game.transforms import euler_xyz
from tests.helpers import ASSETS

HEAD = """\
name = "test"

[camera]
position = [0.0, 2.0, 10.0]
target = [0.0, 0.0, 0.0]

[light]
kind = "directional"
direction = [0.0, -2.0, 0.0]
"""

CAPSULE = 'shape = "capsule"\nradius = 0.3\nheight = 1.8\n'


def scene_with(body: str) -> Scene:
    """Parse HEAD plus ``body``."""
    return parse_scene(HEAD + body)


def only_static(body: str) -> trimesh.Trimesh:
    """The world mesh of the one [[static]] described by ``body``."""
    return scene_with("[[static]]\n" + body).statics[0].mesh


# --------------------------------------------------------------------------------------------
# The default scene




def test_the_built_in_scene_is_the_town_square():
    s = load_scene(default_scene_path())
    assert default_scene_path() == ASSETS / "default.toml" and s.name == "square"
    assert reference_scene_path() == ASSETS / "courtyard.toml"
    assert len(s.floors) == 1 and len(s.statics) >= 40 and len(s.characters) >= 6
    assert s.light.kind == "directional" and s.linear_light is not None
    # Its houses come from the model file, with the file's part colours; the rest is coloured
    # by the scene.
    assert sum(len(b.mesh.faces) == 180 for b in s.statics) == 3  # the arcade's arches
    assert all(b.colour is not None for b in s.floors + s.statics)
    assert all(c.colour is not None for c in s.characters)


def test_courtyard_counts_and_names(courtyard):
    s = courtyard
    assert s.source == reference_scene_path()
    assert len(s.floors) == 1
    assert 15 <= len(s.statics) <= 30
    assert 4 <= len(s.characters) <= 8
    assert s.object_names() == (
        ["floor_0"] + [f"static_{i}" for i in range(len(s.statics))]
        + [f"character_{i}" for i in range(len(s.characters))])
    assert all(b.kind == "static" for b in s.statics) and s.floors[0].kind == "floor"
    assert s.light.kind == "directional"
    assert np.isclose(np.linalg.norm(s.light.direction), 1.0)
    assert s.linear_light is not None and s.linear_light.a[1] > 5.0
    # Two of the statics come from the committed model files (an OBJ and a multi-node GLB).
    assert any(len(b.mesh.faces) == 180 for b in s.statics)  # arch.obj
    for body in s.floors + s.statics:
        assert body.mesh.vertices.dtype == np.float64
        assert np.issubdtype(body.mesh.faces.dtype, np.integer)


SHIPPED = pytest.mark.parametrize("path", [reference_scene_path(), default_scene_path()],
                                  ids=["courtyard", "square"])


@SHIPPED
def test_floor_top_is_zero_and_objects_rest_on_something(path):
    s = load_scene(path)
    floor = s.floors[0].mesh.bounds
    assert np.isclose(floor[1][1], 0.0) and floor[0][1] < 0.0
    assert np.all(floor[1][[0, 2]] >= 20.0) and np.all(floor[0][[0, 2]] <= -20.0)
    eps = 1e-6
    for body in s.statics:
        lo, hi = body.mesh.bounds
        assert lo[1] >= -eps, f"{body.name} sinks into the floor"
        if abs(lo[1]) < eps:
            continue
        # Not on the floor: its bottom must lie within another static that it overlaps in x, z.
        supported = any(
            other is not body
            and other.mesh.bounds[0][1] - eps <= lo[1] <= other.mesh.bounds[1][1] + eps
            and np.all(lo[[0, 2]] < other.mesh.bounds[1][[0, 2]])
            and np.all(hi[[0, 2]] > other.mesh.bounds[0][[0, 2]])
            for other in s.statics)
        assert supported, f"{body.name} floats at y = {lo[1]}"


def _components(faces: np.ndarray, n_vertices: int) -> np.ndarray:
    """Connected-component label per vertex (union-find over the faces' edges).

    Written out so the test needs no graph library (trimesh's split wants networkx or scipy).
    """
    parent = np.arange(n_vertices)

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b, c in faces:
        ra, rb, rc = find(a), find(b), find(c)
        parent[rb] = ra
        parent[rc] = ra
    return np.array([find(i) for i in range(n_vertices)])


def _part_boxes(bodies) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Axis-aligned boxes of every connected part of every body: conservative obstacles."""
    boxes = []
    for body in bodies:
        vertices = np.asarray(body.mesh.vertices)
        labels = _components(np.asarray(body.mesh.faces), len(vertices))
        for label in np.unique(labels):
            part = vertices[labels == label]
            boxes.append((body.name, part.min(axis=0), part.max(axis=0)))
    return boxes


@SHIPPED
def test_characters_do_not_walk_through_statics(path):
    s = load_scene(path)
    obstacles = _part_boxes(s.statics)
    for character in s.characters:
        lo_c, hi_c = character.mesh.bounds
        radius = 0.5 * (hi_c[0] - lo_c[0])
        loop = np.linalg.norm(np.roll(character.path, -1, axis=0) - character.path, axis=1).sum()
        period = loop / character.speed if character.speed > 0 and loop > 0 else 1.0
        for t in np.linspace(0.0, period, 400):
            position, _ = character.pose(t)
            # The capsule's axis, sampled from the lower to the upper cap centre.
            axis = position + np.outer(np.linspace(lo_c[1] + radius, hi_c[1] - radius, 9),
                                       [0.0, 1.0, 0.0])
            for name, lo, hi in obstacles:
                gap = np.linalg.norm(np.maximum(0.0, np.maximum(lo - axis, axis - hi)), axis=1)
                assert gap.min() > radius, f"{character.name} hits {name} at t = {t:.2f}"
        assert np.all(np.asarray(character.path)[:, 1] - (lo_c[1]) >= -1e-9)  # not under floor


# --------------------------------------------------------------------------------------------
# Shapes and transforms


@pytest.mark.parametrize(("body", "lo", "hi"), [
    ('shape = "box"\nsize = [1.0, 2.0, 3.0]', [-0.5, -1.0, -1.5], [0.5, 1.0, 1.5]),
    ('shape = "sphere"\nradius = 2.0', [-2.0, -2.0, -2.0], [2.0, 2.0, 2.0]),
    ('shape = "cylinder"\nradius = 0.5\nheight = 4.0', [-0.5, -2.0, -0.5], [0.5, 2.0, 0.5]),
    ('shape = "capsule"\nradius = 0.3\nheight = 1.8', [-0.3, -0.9, -0.3], [0.3, 0.9, 0.3]),
    ('shape = "capsule"\nradius = 0.5\nheight = 1.0', [-0.5, -0.5, -0.5], [0.5, 0.5, 0.5]),
    ('shape = "cone"\nradius = 1.0\nheight = 3.0', [-1.0, -1.5, -1.0], [1.0, 1.5, 1.0]),
])
def test_shapes_are_centred_with_their_axis_along_y(body, lo, hi):
    mesh = only_static(body)
    assert np.allclose(mesh.bounds, [lo, hi], atol=1e-9)
    assert mesh.is_watertight and mesh.volume > 0  # closed and facing outwards


def test_cone_apex_is_up():
    mesh = only_static('shape = "cone"\nradius = 1.0\nheight = 3.0')
    top = mesh.vertices[mesh.vertices[:, 1] > 1.5 - 1e-9]
    assert np.allclose(top[:, [0, 2]], 0.0)  # the apex, on the axis
    base = mesh.vertices[mesh.vertices[:, 1] < -1.5 + 1e-9]
    assert np.isclose(np.linalg.norm(base[:, [0, 2]], axis=1).max(), 1.0)


def test_position_rotation_scale_make_world_space():
    mesh = only_static('shape = "box"\nsize = [1.0, 1.0, 1.0]\nposition = [1.0, 2.0, 3.0]\n'
                       'scale = [2.0, 3.0, 4.0]')
    assert np.allclose(mesh.bounds, [[0.0, 0.5, 1.0], [2.0, 3.5, 5.0]])
    uniform = only_static('shape = "sphere"\nradius = 1.0\nscale = 2.5')
    assert np.allclose(uniform.bounds, [[-2.5] * 3, [2.5] * 3])


def test_rotation_order_is_z_after_y_after_x():
    # X first: +Z -> -Y; then Z by 90 degrees: -Y -> +X. The other order would give -Y.
    r = euler_xyz([90.0, 0.0, 90.0])
    assert np.allclose(r @ [0.0, 0.0, 1.0], [1.0, 0.0, 0.0])
    # Y by 90 degrees turns +Z to +X (right-handed, Y up).
    assert np.allclose(euler_xyz([0.0, 90.0, 0.0]) @ [0.0, 0.0, 1.0], [1.0, 0.0, 0.0])
    # The same through a scene: box extents [1, 2, 4] end up along [y, z, x].
    mesh = only_static('shape = "box"\nsize = [1.0, 2.0, 4.0]\nrotation = [90.0, 0.0, 90.0]')
    assert np.allclose(mesh.extents, [4.0, 1.0, 2.0])


def test_mirroring_transform_keeps_faces_outward():
    box = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
    mirrored = transform_mesh(box, np.diag([-1.0, 1.0, 1.0]), np.array([5.0, 0.0, 0.0]))
    assert mirrored.volume > 0
    assert np.allclose(mirrored.bounds, [[4.5, -1.0, -1.5], [5.5, 1.0, 1.5]])


def test_character_rotation_and_scale_apply_in_local_space():
    s = scene_with('[[character]]\nshape = "box"\nsize = [1.0, 2.0, 4.0]\n'
                   'rotation = [0.0, 90.0, 0.0]\nscale = 0.5\npath = [[3.0, 1.0, 3.0]]\n')
    c = s.characters[0]
    assert np.allclose(c.mesh.bounds, [[-1.0, -0.5, -0.25], [1.0, 0.5, 0.25]])
    assert np.allclose(c.model_matrix(10.0)[:3, 3], [3.0, 1.0, 3.0])


# --------------------------------------------------------------------------------------------
# Character motion


def square_walker(speed: float = 2.0, phase: float = 0.0) -> Character:
    """A 4 m square walked +X, +Z, -X, -Z from the origin: a 16 m loop."""
    path = np.array([[0.0, 0.9, 0.0], [4.0, 0.9, 0.0], [4.0, 0.9, 4.0], [0.0, 0.9, 4.0]])
    mesh = trimesh.creation.box(extents=(0.6, 1.8, 0.6))
    return Character(name="character_0", mesh=mesh, path=path, speed=speed, phase=phase)


@pytest.mark.parametrize(("t", "position", "yaw"), [
    (0.0, [0.0, 0.9, 0.0], math.pi / 2),  # facing +X
    (1.0, [2.0, 0.9, 0.0], math.pi / 2),
    (3.0, [4.0, 0.9, 2.0], 0.0),  # arc 6: second side, facing +Z
    (5.0, [2.0, 0.9, 4.0], -math.pi / 2),  # arc 10: facing -X
    (7.5, [0.0, 0.9, 1.0], math.pi),  # arc 15: the closing side back to the start, facing -Z
    (9.0, [2.0, 0.9, 0.0], math.pi / 2),  # arc 18 = 2 modulo 16
    (-1.0, [0.0, 0.9, 2.0], math.pi),  # arc -2 = 14 modulo 16
])
def test_pose_follows_arc_length_around_the_closed_loop(t, position, yaw):
    p, y = square_walker().pose(t)
    assert np.allclose(p, position)
    assert math.isclose(math.cos(y), math.cos(yaw), abs_tol=1e-12)
    assert math.isclose(math.sin(y), math.sin(yaw), abs_tol=1e-12)


def test_phase_is_seconds_added_to_the_clock():
    a, b = square_walker(phase=1.5), square_walker()
    for t in (0.0, 2.0, 7.3):
        assert np.allclose(a.pose(t)[0], b.pose(t + 1.5)[0])


def test_model_matrix_turns_local_z_to_the_direction_of_travel():
    walker = square_walker()
    for t, direction in ((0.5, [1.0, 0.0, 0.0]), (2.5, [0.0, 0.0, 1.0]),
                         (4.5, [-1.0, 0.0, 0.0])):
        m = walker.model_matrix(t)
        position, _ = walker.pose(t)
        assert m.shape == (4, 4) and m.dtype == np.float64
        assert np.allclose(m @ [0.0, 0.0, 1.0, 1.0], [*(position + direction), 1.0])
        assert np.allclose(m @ [0.0, 1.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0])  # upright


def test_one_point_path_stands_still():
    s = scene_with(f"[[character]]\n{CAPSULE}path = [[1.0, 0.9, 2.0]]\nspeed = 3.0\n")
    c = s.characters[0]
    assert c.speed == 3.0 and c.phase == 0.0
    for t in (0.0, 1.0, 100.0):
        position, yaw = c.pose(t)
        assert np.allclose(position, [1.0, 0.9, 2.0]) and yaw == 0.0
    assert np.allclose(c.model_matrix(5.0), [[1, 0, 0, 1.0], [0, 1, 0, 0.9], [0, 0, 1, 2.0],
                                              [0, 0, 0, 1]])


def test_repeated_points_do_not_break_the_yaw():
    path = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 4.0]])
    c = Character("character_0", trimesh.creation.box(), path, speed=1.0, phase=0.0)
    assert np.isclose(c.pose(0.0)[1], 0.0)  # facing +Z, the first segment of non-zero length
    assert np.isclose(abs(c.pose(5.0)[1]), math.pi)  # coming back along -Z


def test_character_defaults_speed_one_phase_zero():
    c = scene_with(f"[[character]]\n{CAPSULE}path = [[0, 0.9, 0], [10, 0.9, 0]]\n").characters[0]
    assert c.speed == 1.0 and c.phase == 0.0
    assert np.allclose(c.pose(3.0)[0], [3.0, 0.9, 0.0])
    assert np.allclose(c.mesh.bounds, [[-0.3, -0.9, -0.3], [0.3, 0.9, 0.3]])


# --------------------------------------------------------------------------------------------
# Defaults and valid variants


def test_camera_and_light_defaults():
    s = parse_scene(HEAD)
    assert s.name == "test" and s.source is None and s.linear_light is None
    assert (s.camera.fov, s.camera.near, s.camera.far) == (60.0, 0.1, 200.0)
    assert np.allclose(s.light.direction, [0.0, -1.0, 0.0])  # normalised
    assert s.light.position is None and s.light.cone is None
    assert s.floors == [] and s.statics == [] and s.characters == []


def test_spot_and_point_lights():
    spot = parse_scene(HEAD.replace('kind = "directional"', 'kind = "spot"')
                       + 'position = [1.0, 5.0, 0.0]\ncone = 45\n').light
    assert spot.kind == "spot" and spot.cone == 45.0 and np.allclose(spot.position, [1, 5, 0])
    point = parse_scene(HEAD.replace('kind = "directional"\ndirection = [0.0, -2.0, 0.0]',
                                     'kind = "point"\nposition = [0, 3, 0]')).light
    assert point.kind == "point" and point.direction is None


LIGHTS = """\
[[light]]
kind = "directional"
direction = [0.0, -2.0, 0.0]

[[light]]
kind = "spot"
position = [-8.0, 6.0, -8.0]
direction = [0.6, -1.0, 0.6]
cone = 90.0
range = 16.0
color = [1.0, 0.85, 0.6]
intensity = 1.5

[[light]]
kind = "point"
position = [0, 3, 0]
intensity = 0
"""


def with_lights(lights: str) -> str:
    """HEAD with its [light] table replaced by ``lights``."""
    return HEAD.split("[light]")[0] + lights


def test_a_single_entry_light_array_is_the_same_as_a_light_table():
    table = parse_scene(HEAD)
    array = parse_scene(HEAD.replace("[light]", "[[light]]"))
    assert len(table.lights) == len(array.lights) == 1
    assert array.light.kind == "directional"
    assert np.allclose(array.light.direction, table.light.direction)


def test_an_array_of_lights_loads_in_file_order():
    s = parse_scene(with_lights(LIGHTS))
    assert [light.kind for light in s.lights] == ["directional", "spot", "point"]
    assert s.light is s.lights[0]
    sun, spot, bulb = s.lights
    assert sun.color == (1.0, 1.0, 1.0) and sun.intensity == 1.0 and sun.range is None
    assert spot.color == pytest.approx((1.0, 0.85, 0.6)) and spot.intensity == 1.5
    assert spot.range == 16.0 and spot.cone == 90.0
    assert np.allclose(spot.direction, np.array([0.6, -1.0, 0.6]) / np.linalg.norm([0.6, -1, 0.6]))
    assert bulb.range is None and bulb.intensity == 0.0  # a light may be switched off
    assert np.allclose(bulb.position, [0.0, 3.0, 0.0])


def test_a_light_table_takes_color_intensity_and_range():
    light = parse_scene(HEAD.replace('kind = "directional"\ndirection = [0.0, -2.0, 0.0]',
                                     'kind = "point"\nposition = [0, 3, 0]\nrange = 4\n'
                                     'color = [0, 0.5, 1]\nintensity = 2')).light
    assert (light.range, light.color, light.intensity) == (4.0, (0.0, 0.5, 1.0), 2.0)


def test_the_lights_example_of_the_scene_guide_loads():
    guide = (ASSETS.parent / "docs" / "scenes.md").read_text()
    example = re.search(r"## Lights\n.*?```toml\n(.*?)```", guide, re.S).group(1)
    s = parse_scene(with_lights(example))
    assert [light.kind for light in s.lights] == ["directional", "spot", "point"]
    assert [light.range for light in s.lights] == [None, 16.0, 6.0]


def test_range_ends_a_lights_reach():
    bulb = parse_scene(with_lights('[[light]]\nkind = "point"\nposition = [0, 0, 0]\n'
                                   "range = 5\n")).light
    assert bulb.reaches(np.array([6.0, 0.0, 0.0]), 1.5)      # the sphere reaches into range
    assert not bulb.reaches(np.array([6.0, 0.0, 0.0]), 0.5)  # wholly beyond it
    unlimited = parse_scene(with_lights('[[light]]\nkind = "point"\nposition = [0, 0, 0]\n'))
    assert unlimited.light.reaches(np.array([1e5, 0.0, 0.0]), 0.5)


def test_mesh_files_load_relative_to_the_scene(tmp_path):
    (tmp_path / "models").mkdir()
    trimesh.creation.box(extents=(1, 2, 3)).export(tmp_path / "models" / "b.stl")
    trimesh.creation.icosphere(subdivisions=1).export(tmp_path / "models" / "s.ply")
    trimesh.creation.box(extents=(2, 2, 2)).export(tmp_path / "models" / "c.gltf")
    scene_file = tmp_path / "scene.toml"
    scene_file.write_text(HEAD + '[[static]]\nshape = "mesh"\nfile = "models/b.stl"\n'
                          'position = [0, 1, 0]\n'
                          '[[static]]\nshape = "mesh"\nfile = "models/../models/s.ply"\n'
                          '[[static]]\nshape = "mesh"\nfile = "models/c.gltf"\n')
    s = load_scene(scene_file)
    assert np.allclose(s.statics[0].mesh.bounds, [[-0.5, 0.0, -1.5], [0.5, 2.0, 1.5]])
    assert len(s.statics[1].mesh.faces) == 80
    assert np.allclose(s.statics[2].mesh.extents, [2.0, 2.0, 2.0])


def test_zero_area_triangles_are_dropped_with_a_warning(tmp_path):
    (tmp_path / "m.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n")
    scene_file = tmp_path / "s.toml"
    scene_file.write_text(HEAD + '[[static]]\nshape = "mesh"\nfile = "m.obj"\n')
    with pytest.warns(UserWarning, match="zero-area"):
        s = load_scene(scene_file)
    assert len(s.statics[0].mesh.faces) == 1


def test_generate_table_appends_after_listed_objects():
    s = scene_with('[[floor]]\nshape = "box"\nsize = [4, 0.2, 4]\n'
                   '[[static]]\nshape = "sphere"\nradius = 1\nposition = [0, 1, 0]\n'
                   f"[[character]]\n{CAPSULE}path = [[0, 0.9, 0]]\n"
                   "[generate]\nblocks = 1\nbuildings_per_block = 1\ntrees_per_block = 1\n"
                   "characters = 2\n")
    assert [b.name for b in s.floors] == ["floor_0", "floor_1"]
    assert [b.name for b in s.statics] == ["static_0", "static_1", "static_2"]
    assert [c.name for c in s.characters] == ["character_0", "character_1", "character_2"]
    assert len(s.statics[0].mesh.faces) == 320  # the listed sphere comes first


# --------------------------------------------------------------------------------------------
# Errors: one line, naming the file, the line, the table and the key

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
     ["zero length"]),
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
    message = expect_error(tmp_path, text, "TOML syntax error")
    assert "overwrite" in message


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
    expect_mesh_error(tmp_path, "models/nothere.obj", "file not found")


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
    with pytest.raises(SceneError, match="cannot read scene file"):
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
