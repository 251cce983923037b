"""Depth bounds of the cached maps: per block of texels, their nearest and farthest depth or a
plane and its spread, made only for maps kept across frames, and a shading pass that reads them
gives the very frame it gives without."""

import numpy as np
import pytest

from game.gpu.depth_bounds import BLOCK
from game.render import shadow_pass
from game.render.renderer import Renderer, View
from game.scene import default_scene_path, load_scene, parse_scene
from game.shadows.plan import ShadowSettings
from tests.helpers import SMALL_SIZE

ASSETS = default_scene_path().parent


def _depth_layers(array) -> np.ndarray:
    from OpenGL import GL  # after the context: PyOpenGL picks its platform on import

    GL.glBindTexture(GL.GL_TEXTURE_2D_ARRAY, array.texture)
    data = GL.glGetTexImage(GL.GL_TEXTURE_2D_ARRAY, 0, GL.GL_DEPTH_COMPONENT, GL.GL_FLOAT)
    GL.glBindTexture(GL.GL_TEXTURE_2D_ARRAY, 0)
    r = array.resolution
    return np.frombuffer(data, np.float32).reshape(array.layers, r, r)


LEVEL = 0x80000000
CENTRE = 0.5 * (BLOCK - 1)


def _bounds(q: np.ndarray) -> tuple:
    """Decode blocks' bounds (shaders/depth_bounds.glsl): (level, nearest, farthest, mid,
    slope x, slope y, spread), each an array over the blocks."""
    x, y = q[..., 0], q[..., 1]
    level = x >= LEVEL
    nearest = (x & (LEVEL - 1)).astype(np.uint32).view(np.float32).astype(np.float64)
    farthest = y.astype(np.uint32).view(np.float32).astype(np.float64)
    mid = (x >> 8).astype(np.float64) / (2**23 - 1)
    halves = y.astype(np.uint32).view(np.uint16).reshape(*y.shape, 2).view(np.float16)
    halves = np.where(level[..., None], 0.0, halves.astype(np.float64))  # level: y is a depth
    spread = (((x & 255) + 800).astype(np.uint32) << 20).view(np.float32).astype(np.float64)
    return level, nearest, farthest, mid, halves[..., 0], halves[..., 1], spread


def test_each_block_holds_its_texels_within_its_bounds_the_tighter_form_kept(ctx):
    scene = load_scene(ASSETS / "courtyard.toml")
    r = Renderer(ctx, scene, SMALL_SIZE)
    try:
        r.render(0.0, View.from_camera(scene.camera, SMALL_SIZE))
        plan, maps = r.last_plan, r.shadow_pass
        depth = _depth_layers(maps.array).astype(np.float64)
        side = maps.bounds.side
        q = np.frombuffer(maps.bounds.texture.read(), np.uint32)
        q = q.reshape(maps.array.layers, side, side, 2)
        marked = shadow_pass.bounded_maps(plan)
        assert any(marked)
        offsets = np.arange(BLOCK) - CENTRE   # a texel's offset from its block's centre
        sloped_blocks = 0
        for i, rec in enumerate(plan.maps):
            if not marked[i]:
                continue
            x, y, n = *rec.origin, rec.viewport
            texels = depth[rec.layer, y:y + n, x:x + n]
            blocks = texels.reshape(n // BLOCK, BLOCK, n // BLOCK, BLOCK).transpose(0, 2, 1, 3)
            got = q[rec.layer, y // BLOCK:(y + n) // BLOCK, x // BLOCK:(x + n) // BLOCK]
            level, nearest, farthest, mid, du, dv, spread = _bounds(got)
            lo, hi = blocks.min(axis=(2, 3)), blocks.max(axis=(2, 3))
            np.testing.assert_array_equal(nearest[level], lo[level])
            np.testing.assert_array_equal(farthest[level], hi[level])
            # blocks[row, column, texel row, texel column]: a texel's plane at its offsets
            plane = (mid[..., None, None] + du[..., None, None] * offsets[None, None, None, :]
                     + dv[..., None, None] * offsets[None, None, :, None])
            off = np.abs(blocks - plane).max(axis=(2, 3))
            sloped = ~level
            assert (off[sloped] <= spread[sloped]).all()
            # Kept only where its band is the narrower.
            assert (2 * spread[sloped] < (hi - lo)[sloped]).all()
            sloped_blocks += sloped.sum()
        # The courtyard's walls and roofs face the sun at a slant: their blocks are planes.
        assert sloped_blocks > 100
    finally:
        r.release()


def test_only_maps_kept_across_frames_and_made_of_whole_blocks_have_bounds(ctx):
    scene = load_scene(ASSETS / "default.toml")
    for method in ("clumped", "single", "static-dynamic"):
        r = Renderer(ctx, scene, SMALL_SIZE, ShadowSettings(method=method))
        try:
            r.render(0.0, View.from_camera(scene.camera, SMALL_SIZE))
            plan = r.last_plan
            marked = shadow_pass.bounded_maps(plan)
            each_frame = set(plan.render_dynamic)
            for i, rec in enumerate(plan.maps):
                whole = rec.viewport % BLOCK == 0 and rec.origin[0] % BLOCK == 0 \
                    and rec.origin[1] % BLOCK == 0
                assert marked[i] == (i not in each_frame and whole)
            # single draws its one map every frame: nothing to bound, and no bounds are read.
            assert any(marked) == (method != "single")
            assert r.shading.last[0].depth_bounds == any(marked)
        finally:
            r.release()


def test_a_plan_of_several_lights_has_no_bounds(ctx):
    scene = load_scene(ASSETS / "night_town.toml")
    assert len(scene.lights) > 1
    r = Renderer(ctx, scene, SMALL_SIZE)
    try:
        r.render(0.0, View.from_camera(scene.camera, SMALL_SIZE))
        assert r.last_plan.render_static   # cached maps, which one light would bound
        assert not any(shadow_pass.bounded_maps(r.last_plan))
        assert not r.shading.last[0].depth_bounds
    finally:
        r.release()


POINT_AMONG_BOXES = """
[camera]
position = [6.0, 5.0, 9.0]
target = [0.0, 0.5, 0.0]
[light]
kind = "point"
position = [0.3, 2.5, 0.2]
[[floor]]
shape = "box"
size = [14.0, 0.2, 14.0]
position = [0.0, -0.1, 0.0]
[[static]]
shape = "box"
size = [1.0, 1.0, 1.0]
position = [2.0, 0.5, 0.0]
[[static]]
shape = "sphere"
radius = 0.6
position = [-1.5, 0.6, 1.2]
[[static]]
shape = "box"
size = [0.4, 2.0, 0.4]
position = [0.5, 1.0, -2.0]
"""


@pytest.mark.parametrize("source", ["courtyard.toml", "default.toml", POINT_AMONG_BOXES])
@pytest.mark.parametrize("pcf", [False, True])
def test_a_frame_read_through_the_bounds_is_the_frame_read_without(ctx, monkeypatch, source,
                                                                  pcf):
    scene = (parse_scene(source) if "\n" in source
             else load_scene(ASSETS / source))
    size = SMALL_SIZE

    def frame():
        r = Renderer(ctx, scene, size, ShadowSettings(pcf=pcf), gbuffer=True)
        try:
            out = r.render(0.0, View.from_camera(scene.camera, size))
            return out, r.shading.last[0].depth_bounds
        finally:
            r.release()

    with_bounds, used = frame()
    monkeypatch.setattr(shadow_pass, "holds", lambda origin, side: False)
    without, unused = frame()
    assert used and not unused
    np.testing.assert_array_equal(with_bounds.image, without.image)
    np.testing.assert_array_equal(with_bounds.gbuffer["lit"], without.gbuffer["lit"])


def test_the_shading_pass_reads_the_bounds(ctx):
    # Bounds that call every block's texels as far as can be (nearest and farthest depth 1)
    # light every fragment of the cached maps without reading a texel: the shadows of the
    # statics are gone.
    scene = load_scene(ASSETS / "courtyard.toml")
    r = Renderer(ctx, scene, SMALL_SIZE, gbuffer=True)
    try:
        view = View.from_camera(scene.camera, SMALL_SIZE)
        before = r.render(0.0, view).gbuffer["lit"]
        bounds = r.shadow_pass.bounds.texture
        far = np.full(bounds.width * bounds.height * bounds.layers * 2, 1.0, np.float32)
        far = far.view(np.uint32)
        far[0::2] |= LEVEL
        bounds.write(far)
        after = r.render(0.0, view).gbuffer["lit"]
    finally:
        r.release()
    assert not r.last_plan.render_static   # the maps came from the cache, the bounds kept
    shadowed = before < 0.5
    assert shadowed.sum() > 100
    assert (after[shadowed] > 0.5).mean() > 0.5
