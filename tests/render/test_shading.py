"""What the shading pass shows: shading normals, base colours from the scene and its files, and
the G-buffer the dumps read left as the geometry makes it."""

import numpy as np

from game.render.renderer import Renderer, View
from game.scene import parse_scene
from game.scene.mesh_files import FILE_COLOUR
from game.transforms import euler_xyz
from tests.helpers import ACCURACY_SIZE, SMALL_SIZE

BALL_AND_BOX = """
[camera]
position = [0.0, 2.0, 7.0]
target = [0.0, 1.0, 0.0]
fov = 50.0
[light]
kind = "directional"
direction = [-0.3, -1.0, -0.5]
[[floor]]
shape = "box"
size = [10.0, 0.2, 10.0]
position = [0.0, -0.1, 0.0]
[[static]]
shape = "sphere"
radius = 1.0
position = [-1.3, 1.0, 0.0]
color = [0.9, 0.1, 0.1]
[[static]]
shape = "box"
size = [1.5, 1.5, 1.5]
position = [1.4, 0.75, 0.0]
"""


def rendered(ctx, scene, size):
    """A frame of ``scene`` at time 0 from its camera, with the G-buffer's shading normals and
    base colours (linear RGB), row 0 at the top."""
    r = Renderer(ctx, scene, size, gbuffer=True)
    try:
        frame = r.render(0.0, View.from_camera(scene.camera, size))
        w, h = size
        shading = np.frombuffer(r.target.shading.read(), np.float16).reshape(h, w, 4)
        albedo = np.frombuffer(r.target.albedo.read(), np.uint8).reshape(h, w, 4)
    finally:
        r.release()
    return (frame, shading[::-1, :, :3].astype(np.float64),
            (albedo[::-1, :, :3] / 255.0) ** 2)


def test_smooth_surfaces_shade_with_their_own_normals_and_the_dumps_keep_the_geometric_one(ctx):
    frame, shading, _ = rendered(ctx, parse_scene(BALL_AND_BOX), SMALL_SIZE)
    g = frame.gbuffer
    geometric = g["normal"]
    ball, box = g["object"] == 1, g["object"] == 2
    # On the ball the shading normal is the sphere's radial one, closer to it than the facet's.
    radial = g["position"][ball] - [-1.3, 1.0, 0.0]
    radial /= np.linalg.norm(radial, axis=1)[:, None]
    shade_cos = np.einsum("ij,ij->i", shading[ball], radial)
    facet_cos = np.einsum("ij,ij->i", geometric[ball], radial)
    assert np.median(shade_cos) > 0.999 > np.median(facet_cos)
    # On the box, and in the dumps everywhere, the normal is the face's own.
    assert np.allclose(shading[box], geometric[box], atol=2e-3)
    faces = geometric[box]
    assert np.allclose(np.abs(faces).max(axis=1), 1.0, atol=1e-4)


def test_a_color_key_is_the_colour_shown(ctx):
    frame, _, albedo = rendered(ctx, parse_scene(BALL_AND_BOX), SMALL_SIZE)
    ball = frame.gbuffer["object"] == 1
    srgb = np.array([0.9, 0.1, 0.1])
    linear = np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)
    assert np.allclose(albedo[ball], linear, atol=0.01)
    red = frame.image[ball].astype(int)
    assert np.all(red[:, 0] > red[:, 1] + 30)


def test_the_cottage_wall_shows_the_wall_and_its_door_the_door(ctx, courtyard):
    """The default view of the cottage: its front wall, its door standing 7 cm proud of it and
    the door's top face under the eave each show their own part's colour. Drawn in one colour,
    the door's one-pixel shadow and its top read as a dashed line and roof-coloured specks."""
    static = 20
    body = courtyard.statics[static]
    scene_file = courtyard.source.read_text()
    assert 'file     = "models/house.glb"' in scene_file
    frame, _, albedo = rendered(ctx, courtyard, ACCURACY_SIZE)
    g = frame.gbuffer
    cottage = g["object"] == len(courtyard.floors) + static
    # The cottage's own frame: the scene turns it 25 degrees about Y and moves it to (-9, 0, 4).
    turn = euler_xyz([0.0, 25.0, 0.0])
    local = (g["position"][cottage] - [-9.0, 0.0, 4.0]) @ turn
    normal = g["normal"][cottage] @ turn
    colour = albedo[cottage]

    def part_colour(face_normal, depth):
        """The file's colour of the faces facing ``face_normal`` at local z = ``depth``."""
        mesh = body.mesh
        centres = (mesh.triangles_center - [-9.0, 0.0, 4.0]) @ turn
        normals = mesh.face_normals @ turn
        pick = (np.abs(centres[:, 2] - depth) < 1e-3) & (normals @ face_normal > 0.99)
        found = np.unique(np.asarray(mesh.face_attributes[FILE_COLOUR])[pick], axis=0)
        assert len(found) == 1
        return found[0]

    front = np.array([0.0, 0.0, 1.0])
    wall, door = part_colour(front, 1.5), part_colour(front, 1.57)
    assert np.abs(wall - door).max() > 0.1
    facing = normal @ front > 0.99
    on_wall = facing & (np.abs(local[:, 2] - 1.5) < 0.01)
    on_door = facing & (np.abs(local[:, 2] - 1.57) < 0.01)
    assert on_wall.sum() > 100 and on_door.sum() > 10
    assert np.allclose(colour[on_wall], wall, atol=0.02)
    assert np.allclose(colour[on_door], door, atol=0.02)
    # Upward faces below the eave (2.55 m) are the door's top: the door's colour, not the roof's.
    top = (normal[:, 1] > 0.99) & (local[:, 1] < 2.5)
    assert np.allclose(colour[top], door, atol=0.02)
