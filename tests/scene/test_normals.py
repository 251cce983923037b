"""Shading normals: smooth where a surface is smooth, hard across creases, and the triangles'
positions untouched."""

import math

import numpy as np
import pytest

from game.scene import geometry, parse_scene
from game.scene.normals import CREASE_ANGLE_DEG, corner_normals, face_normals, split_by_normal
from game.scene.shapes import box_mesh, cone_mesh, cylinder_mesh, sphere_mesh


def shading(mesh):
    source, normals, faces = split_by_normal(mesh.vertices, mesh.faces)
    return source, normals, faces


@pytest.mark.parametrize("make", [lambda: box_mesh([1.0, 2.0, 3.0]), lambda: sphere_mesh(1.5),
                                  lambda: cylinder_mesh(0.5, 2.0), lambda: cone_mesh(1.0, 2.0)])
def test_split_vertices_keep_every_triangle_exactly(make):
    mesh = make()
    source, normals, faces = shading(mesh)
    assert np.array_equal(mesh.vertices[source][faces], mesh.vertices[mesh.faces])
    length = np.linalg.norm(normals, axis=1)
    assert np.all((np.abs(length - 1.0) < 1e-4) | (length == 0.0))  # unit, or flat (none)


def test_a_sphere_shades_with_its_radial_normals():
    mesh = sphere_mesh(2.0)
    source, normals, faces = shading(mesh)
    radial = mesh.vertices[source] / np.linalg.norm(mesh.vertices[source], axis=1)[:, None]
    # The facets' own normals are up to ~8 degrees off the radius; the shading normals far less.
    assert np.einsum("ij,ij->i", normals, radial).min() > math.cos(math.radians(3.0))
    facet, _ = face_normals(mesh.vertices, mesh.faces)
    assert np.einsum("fj,fj->f", facet, radial[faces].mean(axis=1)).min() < math.cos(
        math.radians(5.0))
    assert len(source) == len(mesh.vertices)  # nothing to split on a sphere


def test_a_box_keeps_hard_edges_and_its_eight_vertices():
    mesh = box_mesh([1.0, 1.0, 1.0])
    corners = corner_normals(mesh.vertices, mesh.faces)
    facet, _ = face_normals(mesh.vertices, mesh.faces)
    assert np.allclose(corners, facet[:, None, :], atol=1e-6)
    # Every corner is flat: it carries no normal (the triangle's own is used) and shares its
    # vertex with the other flat corners there.
    source, normals, _ = shading(mesh)
    assert len(source) == 8 and not normals.any()


def test_a_cylinder_is_smooth_around_and_hard_at_its_rims():
    mesh = cylinder_mesh(1.0, 2.0)
    source, normals, faces = shading(mesh)
    facet, _ = face_normals(mesh.vertices, mesh.faces)
    side = np.abs(facet[:, 1]) < 0.5
    n_side = normals[faces[side]].reshape(-1, 3)
    p_side = mesh.vertices[source][faces[side]].reshape(-1, 3)
    radial = p_side * [1.0, 0.0, 1.0]
    radial /= np.linalg.norm(radial, axis=1)[:, None]
    assert np.einsum("ij,ij->i", n_side, radial).min() > 0.9999
    assert not normals[faces[~side]].any()  # the caps are flat: their triangles' normals
    assert len(source) == 2 * 24 + 2 + 48  # rim vertices once for a cap, once for the side


@pytest.mark.parametrize("bend_deg", [CREASE_ANGLE_DEG - 10.0, CREASE_ANGLE_DEG + 10.0])
def test_the_crease_angle_decides_smooth_or_hard(bend_deg):
    # Two triangles sharing the edge x = 0, the second bent down by bend_deg.
    a = math.radians(bend_deg)
    vertices = np.array([[0, 0, 0], [0, 0, 1], [-1, 0, 0.5], [math.cos(a), -math.sin(a), 0.5]])
    faces = np.array([[0, 1, 2], [0, 3, 1]])
    corners = corner_normals(vertices, faces)
    shared_first, shared_second = corners[0, 0], corners[1, 0]  # both at vertex 0
    smooth = bend_deg < CREASE_ANGLE_DEG
    assert np.allclose(shared_first, shared_second) == smooth


def test_vertices_split_in_the_file_still_shade_smoothly():
    # The same sphere with every triangle's corners its own vertices (as files split at seams).
    mesh = sphere_mesh(1.0)
    vertices = mesh.vertices[mesh.faces.reshape(-1)]
    faces = np.arange(len(vertices)).reshape(-1, 3)
    welded = corner_normals(mesh.vertices, mesh.faces)
    split = corner_normals(vertices, faces)
    assert np.allclose(welded, split, atol=1e-6)


def test_a_face_key_splits_vertices_that_share_a_normal():
    mesh = sphere_mesh(1.0)
    key = np.zeros((len(mesh.faces), 3), np.float32)
    key[: len(key) // 2] = 1.0
    plain, _, _ = split_by_normal(mesh.vertices, mesh.faces)
    keyed, _, faces = split_by_normal(mesh.vertices, mesh.faces, face_key=key)
    assert len(keyed) > len(plain)
    assert np.array_equal(mesh.vertices[keyed][faces], mesh.vertices[mesh.faces])


COLOURED = """
[camera]
position = [0.0, 2.0, 8.0]
target = [0.0, 0.0, 0.0]
[light]
kind = "directional"
direction = [0.0, -1.0, 0.0]
[[floor]]
shape = "box"
size = [10.0, 0.2, 10.0]
position = [0.0, -0.1, 0.0]
[[static]]
shape = "sphere"
radius = 1.0
position = [0.0, 1.0, 0.0]
color = [1.0, 0.5, 0.0]
"""


def test_colours_are_packed_linear_and_absent_ones_marked():
    geom = geometry.pack(parse_scene(COLOURED))
    floor = geom.colours[geom.objects == 0]
    sphere = geom.colours[geom.objects == 1]
    assert np.all(floor == geometry.NO_COLOUR)
    # sRGB 0.5 is 0.214 in linear RGB.
    assert np.allclose(sphere, [1.0, 0.2140, 0.0], atol=1e-4)


def test_a_files_own_normals_are_used_and_turned_with_its_nodes_and_the_scene(tmp_path):
    import trimesh

    from game.scene import load_scene
    from game.scene.mesh_files import FILE_NORMAL

    box = trimesh.creation.box()
    up = np.tile([0.0, 1.0, 0.0], (len(box.vertices), 1))   # not a box's normals: the file's
    scene = trimesh.Scene()
    scene.add_geometry(trimesh.Trimesh(box.vertices, box.faces, vertex_normals=up, process=False),
                       node_name="box", geom_name="box",
                       transform=trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    (tmp_path / "box.glb").write_bytes(scene.export(file_type="glb", include_normals=True))
    (tmp_path / "plain.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "s.toml").write_text(COLOURED.split("[[static]]")[0] + """
[[static]]
shape = "mesh"
file = "box.glb"
position = [0.0, 0.5, 0.0]
rotation = [0.0, 90.0, 0.0]
[[static]]
shape = "mesh"
file = "plain.obj"
position = [3.0, 0.0, 0.0]
""")
    s = load_scene(tmp_path / "s.toml")
    # The node turns +Y to +Z, the scene's rotation +Z to +X.
    given = s.statics[0].mesh.vertex_attributes[FILE_NORMAL]
    assert np.allclose(given, [1.0, 0.0, 0.0], atol=1e-6)
    assert FILE_NORMAL not in s.statics[1].mesh.vertex_attributes  # a file without normals
    geom = geometry.pack(s)
    normals = geom.normals[geom.objects == 1]
    shaded = normals[np.abs(normals).sum(axis=1) > 0]
    assert len(shaded) > 0 and np.allclose(shaded, [1.0, 0.0, 0.0], atol=1e-6)
    # Corners whose own face looks along +X are flat: they carry no normal.
    assert len(shaded) < len(normals)


def test_an_obj_files_vertex_normals_are_read(tmp_path):
    from game.scene import load_scene
    from game.scene.mesh_files import FILE_NORMAL

    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 0 -1\nvn 0 1 0\nvn 0 1 0\n"
                                      "vn 0.6 0.8 0\nf 1//1 2//2 3//3\n")
    (tmp_path / "s.toml").write_text(COLOURED.split("[[static]]")[0] + """
[[static]]
shape = "mesh"
file = "tri.obj"
position = [0.0, 0.5, 0.0]
""")
    mesh = load_scene(tmp_path / "s.toml").statics[0].mesh
    assert np.allclose(mesh.vertex_attributes[FILE_NORMAL], [[0, 1, 0], [0, 1, 0], [0.6, 0.8, 0]])
