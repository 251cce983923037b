"""The camera pass's triangle culling (game/render/cull.py): the same pixels as drawing every
triangle, from every kind of view, and far fewer triangles where they are small."""


import numpy as np
import pytest
import trimesh

from game import transforms
from game.render.renderer import Renderer, View
from game.scene import Body, load_scene, parse_scene
from tests.helpers import SCENES
from tests.helpers import SMALL_SIZE as SIZE

# A small town with fine detail: at 160x90 most of its triangles fall between pixel centres.
TOWN = """
[camera]
position = [0.0, 60.0, 90.0]
target = [0.0, 0.0, 0.0]
fov = 55.0
near = 0.5
far = 400.0
[light]
kind = "directional"
direction = [-0.4, -1.0, -0.3]
[generate]
seed = 3
blocks = 2
detail = 2
characters = 4
"""


def views(scene):
    """The scene camera; turned half away (part of the scene off screen); close in, with
    triangles crossing the near plane and the eye plane; and looking straight down."""
    cam = scene.camera
    eye, target = np.asarray(cam.position, float), np.asarray(cam.target, float)
    proj = transforms.perspective(cam.fov, SIZE[0] / SIZE[1], cam.near, cam.far)
    side = np.cross(target - eye, [0.0, 1.0, 0.0])
    low = target + np.array([0.3, 0.4, 0.6])
    return [View.from_camera(cam, SIZE),
            View(transforms.look_at(eye, target + side), proj),
            View(transforms.look_at(low, low + np.array([1.0, -0.1, -2.0])), proj),
            View(transforms.look_at(target + [0.0, 30.0, 0.0], target), proj)]


def frames(ctx, scene, cull: bool):
    r = Renderer(ctx, scene, SIZE, gbuffer=True, cull=cull)
    try:
        return [r.render(0.4 * k, view) for k, view in enumerate(views(scene))]
    finally:
        r.release()


def assert_same_frames(culled, drawn_all):
    for a, b in zip(culled, drawn_all, strict=True):
        assert np.array_equal(a.image, b.image)
        for key in ("position", "normal", "object"):
            assert np.array_equal(a.gbuffer[key], b.gbuffer[key], equal_nan=True)


@pytest.mark.parametrize("scene_name", ["tiny.toml", "spot.toml", "point.toml", "town"])
def test_culled_frames_equal_frames_that_draw_every_triangle(ctx, scene_name):
    scene = (parse_scene(TOWN) if scene_name == "town" else load_scene(SCENES / scene_name))
    culled, drawn_all = frames(ctx, scene, True), frames(ctx, scene, False)
    assert_same_frames(culled, drawn_all)
    for a, b in zip(culled, drawn_all, strict=True):
        assert a.camera_triangles <= b.camera_triangles
    if scene_name == "town":
        # The scene camera sees the whole town from afar: most triangles are culled.
        assert culled[0].camera_triangles < 0.5 * drawn_all[0].camera_triangles


def test_culling_follows_scene_changes(ctx):
    scene_a, scene_b = parse_scene(TOWN), parse_scene(TOWN)
    renderers = [Renderer(ctx, s, SIZE, cull=c) for s, c in ((scene_a, True), (scene_b, False))]
    view = View.from_camera(scene_a.camera, SIZE)
    try:
        for r in renderers:
            r.render(0.0, view)
        objects = renderers[0].gl_objects()
        for r in renderers:
            mesh = trimesh.creation.box(extents=(6.0, 12.0, 6.0))
            mesh.apply_translation((0.0, 6.0, 0.0))
            r.add_static(Body(name="added", kind="static", mesh=mesh))
            r.remove_static(r.scene.statics[0].name)
            r.remove_character(r.scene.characters[0].name)
        culled, drawn_all = (r.render(0.5, view) for r in renderers)
        assert np.array_equal(culled.image, drawn_all.image)
        assert culled.camera_triangles < drawn_all.camera_triangles
        assert renderers[0].gl_objects() == objects  # the culler's buffers grew in place
    finally:
        for r in renderers:
            r.release()
