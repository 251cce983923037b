"""The camera pass goes depth first where the scene's order shades hidden fragments, and the
picture is the same whichever way it draws (game/render/depth_first.py)."""

from __future__ import annotations

import numpy as np
import trimesh

from game.gpu.resources import live_gl_names
from game.render.depth_first import DepthFirst
from game.render.renderer import Renderer, View
from game.scene import load_scene, parse_scene
from tests.helpers import SMALL_SIZE

HEAD = """
[camera]
position = [0.0, 3.0, 12.0]
target = [0.0, 3.0, 0.0]
fov = 50.0
[light]
kind = "directional"
direction = [-0.3, -1.0, -0.6]
[[floor]]
shape = "box"
size = [40.0, 0.2, 40.0]
position = [0.0, -0.1, 0.0]
"""


def stacked_walls(tmp_path, walls: int):
    """A scene whose one static mesh holds ``walls`` walls facing the camera, listed from the
    farthest to the nearest: drawn in that order, every wall's fragments pass the depth test."""
    parts = []
    for k in range(walls):
        wall = trimesh.creation.box(extents=(30.0 - 2.0 * k, 16.0 - k, 0.1))
        wall.apply_translation((0.0, 3.0, -4.0 + 1.5 * k))
        parts.append(wall)
    mesh = trimesh.util.concatenate(parts)
    mesh.export(tmp_path / "walls.ply")
    (tmp_path / "scene.toml").write_text(
        HEAD + '[[static]]\nshape = "mesh"\nfile = "walls.ply"\nposition = [0.0, 0.0, 0.0]\n')
    return load_scene(tmp_path / "scene.toml")


def frames(ctx, scene, mode: DepthFirst, n: int = 3):
    r = Renderer(ctx, scene, SMALL_SIZE, depth_first=mode)
    try:
        view = View.from_camera(scene.camera, SMALL_SIZE)
        return [r.render(0.0, view) for _ in range(n)]
    finally:
        r.release()


def test_hidden_fragments_send_the_camera_pass_depth_first_with_the_same_picture(ctx, tmp_path):
    scene = stacked_walls(tmp_path, 4)
    auto = frames(ctx, scene, DepthFirst.AUTO)
    # The first frame has no count to go by; then the walls' hidden fragments decide.
    assert not auto[0].depth_first and auto[0].fragments_per_pixel is None
    assert all(f.depth_first and f.fragments_per_pixel > 1.2 for f in auto[1:])
    off = frames(ctx, scene, DepthFirst.OFF, 1)[0]
    assert not off.depth_first and off.fragments_per_pixel is None
    for frame in auto[1:]:
        assert np.array_equal(frame.covered, off.covered)
        assert np.array_equal(frame.image, off.image)


def test_a_scene_with_few_hidden_fragments_shades_in_its_own_order(ctx, tiny):
    auto = frames(ctx, tiny, DepthFirst.AUTO)
    assert all(not f.depth_first and 0.0 < f.fragments_per_pixel <= 1.0 for f in auto[1:])
    on = frames(ctx, tiny, DepthFirst.ON, 1)[0]
    assert on.depth_first
    assert np.array_equal(on.image, auto[-1].image)


TWINS = HEAD + """
[[static]]
shape = "box"
size = [6.0, 4.0, 1.0]
position = [0.0, 2.0, 0.0]
color = [0.9, 0.1, 0.1]
[[static]]
shape = "box"
size = [6.0, 4.0, 1.0]
position = [0.0, 2.0, 0.0]
color = [0.1, 0.1, 0.9]
"""


def test_surfaces_at_the_same_depth_show_the_first_drawn_either_way(ctx):
    # Two boxes in the same place: every face of one lies on a face of the other, at the same
    # depth to the bit. A single pass keeps the first drawn; so must the depth-first one.
    scene = parse_scene(TWINS)
    on = frames(ctx, scene, DepthFirst.ON, 1)[0]
    off = frames(ctx, scene, DepthFirst.OFF, 1)[0]
    assert on.depth_first and not off.depth_first
    assert np.array_equal(on.image, off.image)
    front = off.image[off.covered].astype(int)
    assert ((front[:, 0] > front[:, 2] + 20) | (front[:, 2] > front[:, 0] + 20)).sum() > 500


def test_the_count_is_one_query_released_with_the_renderer(ctx, tiny):
    before = live_gl_names()["Query"]
    r = Renderer(ctx, tiny, SMALL_SIZE)
    view = View.from_camera(tiny.camera, SMALL_SIZE)
    for _ in range(3):
        r.render(0.0, view, read=False)
    assert live_gl_names()["Query"] == before + 1
    r.release()
    assert live_gl_names()["Query"] == before
