"""The scene model and loader (game/scene/loader.py) against docs/reference.md section 1; no GL."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import trimesh

from game.scene import (
    Character,
    default_scene_path,
    load_scene,
    parse_scene,
    reference_scene_path,
)
from game.scene.shapes import transform_mesh
from game.transforms import euler_xyz
from tests.helpers import ASSETS
from tests.scene.scene_texts import CAPSULE, HEAD, LIGHTS, only_static, scene_with, with_lights

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
