"""The renderer's caching, floor exclusion, map grid and resource ownership, on llvmpipe."""

import dataclasses

import numpy as np
import pytest

from game.render.renderer import Renderer, View
from game.scene import Light, load_scene, parse_scene
from game.shadows.plan import ShadowSettings
from tests.helpers import SCENES
from tests.helpers import SMALL_SIZE as SIZE


def render(ctx, scene, settings=None, t=0.0, frames=1, gbuffer=True, debug="none"):
    r = Renderer(ctx, scene, SIZE, settings, gbuffer=gbuffer)
    r.debug_view = debug
    view = View.from_camera(scene.camera, SIZE)
    try:
        return [r.render(t + k / 30, view) for k in range(frames)]
    finally:
        r.release()


def test_only_character_maps_are_re_rendered_after_the_first_frame(ctx, tiny):
    frames = render(ctx, tiny, frames=4)
    n_chars = len(tiny.characters)
    first, *rest = frames
    assert first.maps_rendered == first.maps_total
    assert first.maps_total > n_chars
    for f in rest:
        assert f.maps_rendered == n_chars
        assert f.maps_cached == f.maps_total - n_chars
        assert f.triangles_to_maps == sum(len(c.mesh.faces) for c in tiny.characters)


def test_a_light_change_re_renders_every_clump(ctx, tiny):
    r = Renderer(ctx, tiny, SIZE)
    view = View.from_camera(tiny.camera, SIZE)
    try:
        r.render(0.0, view)
        assert r.render(0.1, view).maps_rendered == len(tiny.characters)
        before = r.render(0.2, view).image
        d = np.array([0.5, -1.0, 0.2])
        r.set_light(Light("directional", d / np.linalg.norm(d), None, None))
        f = r.render(0.2, view)
        assert f.maps_rendered == f.maps_total
        assert not np.array_equal(f.image, before)  # the shadows moved
    finally:
        r.release()


RAISED_FLOOR = """
[camera]
position = [0.0, 2.0, 9.0]
target = [0.0, 0.5, 0.0]
fov = 50.0
[light]
kind = "directional"
direction = [0.6, -1.0, 0.2]
[[floor]]
shape = "box"
size = [20.0, 0.2, 20.0]
position = [0.0, -0.1, 0.0]
[[floor]]
shape = "box"
size = [4.0, 0.1, 4.0]
position = [0.0, 3.0, -6.0]
[[static]]
shape = "box"
size = [1.0, 1.0, 1.0]
position = [2.0, 0.5, 0.0]
"""


def test_floors_are_never_drawn_into_a_map(ctx):
    # A second floor hangs over the ground: were it a caster, the ground beneath it would be
    # dark. Floors receive only, so that ground stays lit while the box still casts.
    scene = parse_scene(RAISED_FLOOR)
    r = Renderer(ctx, scene, SIZE, gbuffer=True)
    try:
        frame = r.render(0.0, View.from_camera(scene.camera, SIZE))
        plan = r.method.plan(np.zeros((0, 4, 4)))
    finally:
        r.release()
    floor_ids = set(range(len(scene.floors)))
    assert plan.maps and all(not floor_ids & set(m.objects) for m in plan.maps)
    g = frame.gbuffer
    ground = g["object"] == 0
    # Where the ray from a ground point towards the light crosses y = 3 (the raised floor).
    to_light = -scene.light.direction
    p = g["position"]
    hit = p + to_light * ((3.0 - p[..., 1:2]) / to_light[1])
    under = ground & (np.abs(hit[..., 0]) < 1.9) & (np.abs(hit[..., 2] + 6.0) < 1.9)
    assert under.sum() > 30
    assert np.all(g["lit"][under] == 1.0)
    shadowed_ground = ground & (g["lit"] == 0.0)
    assert shadowed_ground.sum() > 20  # the box's shadow: the maps work in this scene
    assert np.all(np.abs(p[shadowed_ground][:, 0] - 2.0) < 2.0)


@pytest.mark.parametrize("scene_name", ["tiny.toml", "spot.toml", "point.toml", "lamps.toml"])
def test_grid_and_loop_give_the_same_shadows(ctx, scene_name):
    scene = load_scene(SCENES / scene_name)
    base = ShadowSettings(clump_count=6)
    off = render(ctx, scene, dataclasses.replace(base, grid="off"))[0]
    on = render(ctx, scene, dataclasses.replace(base, grid="on"))[0]
    assert np.array_equal(off.gbuffer["lit"], on.gbuffer["lit"], equal_nan=True)
    assert on.maps_per_fragment <= off.maps_per_fragment + 1e-9


def test_debug_view_colours_pixels_by_map(ctx, tiny):
    plain = render(ctx, tiny, gbuffer=False)[0].image
    debug = render(ctx, tiny, gbuffer=False, debug="map")[0].image
    assert not np.array_equal(plain, debug)
    colours = {tuple(c) for c in debug.reshape(-1, 3)[::7]}
    assert len(colours) > 3


def test_single_renders_every_caster_every_frame(ctx, tiny):
    settings = ShadowSettings(method="single", single_resolution=1024)
    frames = render(ctx, tiny, settings, frames=2)
    tris = sum(len(b.mesh.faces) for b in tiny.statics) + sum(
        len(c.mesh.faces) for c in tiny.characters)
    for f in frames:
        assert f.maps_rendered == 1
        assert f.triangles_to_maps == tris


def test_gbuffer_matches_the_camera(ctx, tiny):
    frame = render(ctx, tiny)[0]
    g = frame.gbuffer
    view = View.from_camera(tiny.camera, SIZE)
    m = view.proj @ view.view
    rows, cols = np.nonzero(g["object"] >= 0)
    pick = slice(None, None, 37)
    p = g["position"][rows[pick], cols[pick]]
    clip = np.c_[p, np.ones(len(p))] @ m.T
    ndc = clip[:, :2] / clip[:, 3:]
    w, h = SIZE
    assert np.allclose(ndc[:, 0], (cols[pick] + 0.5) / w * 2 - 1, atol=2e-3)
    assert np.allclose(ndc[:, 1], 1 - (rows[pick] + 0.5) / h * 2, atol=2e-3)
    n = g["normal"][rows, cols]
    assert np.allclose(np.linalg.norm(n, axis=1), 1, atol=1e-4)
    eye = np.asarray(tiny.camera.position)
    facing = np.einsum("ij,ij->i", n, eye - g["position"][rows, cols])
    assert np.all(facing > 0)
    assert np.all(np.isnan(g["position"][g["object"] < 0]))


GL_KINDS = ("Buffer", "Texture", "Framebuffer", "Renderbuffer", "VertexArray")


def next_gl_names():
    """The name GL would hand out next for each kind of object (Mesa counts upwards)."""
    from OpenGL import GL

    names = {}
    for kind in GL_KINDS:
        name = int(getattr(GL, f"glGen{kind}s")(1))
        getattr(GL, f"glDelete{kind}s")(1, [name])
        names[kind] = name
    program = int(GL.glCreateProgram())
    GL.glDeleteProgram(program)
    names["Program"] = program
    return names


def live_names(start, end):
    """Objects of each kind still alive among the names handed out between two snapshots."""
    from OpenGL import GL

    # A deleted program stays alive while it is the current one (GL semantics, not a leak).
    GL.glUseProgram(0)
    live = {}
    for kind, first in start.items():
        exists = getattr(GL, f"glIs{kind}")
        live[kind] = [n for n in range(first, end[kind]) if exists(n)]
        if kind == "Program":
            live["Shader"] = [n for n in range(first, end[kind]) if GL.glIsShader(n)]
    return live


def test_release_returns_every_gl_object(ctx, tiny):
    from game.soft.tracer import TraceSettings

    before = next_gl_names()
    render(ctx, tiny, frames=2)
    render(ctx, tiny, ShadowSettings(method="single"), frames=1)
    # Compute dispatches (the camera pass's culling, the soft tracer), then the soft composite.
    r = Renderer(ctx, tiny, SIZE, gbuffer=True)
    try:
        r.render(0.0, View.from_camera(tiny.camera, SIZE))
        r.render(0.0, View.from_camera(tiny.camera, SIZE), soft=TraceSettings(samples=4))
    finally:
        r.release()
    after = next_gl_names()
    assert after["Texture"] > before["Texture"]  # the renderers did make objects
    assert all(not names for names in live_names(before, after).values())



def test_a_renderer_that_cannot_start_leaves_no_gl_objects(ctx, tiny):
    before = next_gl_names()
    with pytest.raises(ValueError, match="unknown shadow method"):
        Renderer(ctx, tiny, SIZE, ShadowSettings(method="nope"))
    after = next_gl_names()
    assert after["Buffer"] > before["Buffer"]  # it had made objects before it failed
    assert all(not names for names in live_names(before, after).values())

TOWN = """
[camera]
position = [0.0, 60.0, 90.0]
target = [0.0, 0.0, 0.0]
fov = 55.0
[light]
kind = "directional"
direction = [-0.4, -1.0, -0.3]
[generate]
seed = 3
blocks = 3
detail = 0
characters = 4
"""


def test_first_frame_equals_later_frames_with_a_large_map_grid(ctx):
    # Regression: the grid buffer grew on the first frame after it was bound, and the first
    # frame then read a stale grid (shadows missing on frame 0 only).
    scene = parse_scene(TOWN)
    settings = ShadowSettings(clump_count=60, clump_resolution=1024, grid="on")
    r = Renderer(ctx, scene, SIZE, settings, gbuffer=True)
    view = View.from_camera(scene.camera, SIZE)
    try:
        first = r.render(0.0, view)
        assert r.blocks.grid.size > 4 * 1024
        second = r.render(0.0, view)
    finally:
        r.release()
    assert first.maps_total > 60
    assert np.array_equal(first.gbuffer["lit"], second.gbuffer["lit"], equal_nan=True)


@pytest.mark.parametrize("scene_name", ["tiny.toml", "spot.toml", "point.toml"])
def test_layered_character_pass_equals_one_framebuffer_per_map(ctx, scene_name):
    scene = load_scene(SCENES / scene_name)
    results = []
    for layered in (False, True):
        r = Renderer(ctx, scene, SIZE, gbuffer=True)
        if layered and not r.shadow_pass.layered:
            r.release()
            pytest.skip("GL_ARB_shader_viewport_layer_array is missing")
        r.shadow_pass.layered = layered
        view = View.from_camera(scene.camera, SIZE)
        try:
            results.append([r.render(t, view).gbuffer["lit"] for t in (0.0, 0.7)])
        finally:
            r.release()
    for per_map, layered in zip(*results, strict=True):
        assert np.array_equal(per_map, layered, equal_nan=True)


def test_pcf_softens_only_the_shadow_edges(ctx, tiny):
    coarse = ShadowSettings(clump_resolution=24)  # wide texels, wide penumbrae
    hard = render(ctx, tiny, coarse)[0].gbuffer["lit"]
    soft = render(ctx, tiny, dataclasses.replace(coarse, pcf=True))[0].gbuffer["lit"]
    seen = ~np.isnan(hard)
    assert set(np.unique(hard[seen])) <= {0.0, 1.0}
    partial = seen & (soft > 0.0) & (soft < 1.0)
    assert partial.sum() > 10
    assert np.mean(hard[seen] == soft[seen]) > 0.95


def test_one_renderer_switches_its_shading_program_with_the_settings(ctx, tiny):
    """The shading program is compiled per variant (PCF, grid, debug view, light kind): one
    renderer switched between them draws what a fresh renderer draws with each, and makes no
    new GL objects the second time round."""
    coarse = ShadowSettings(clump_resolution=24)
    variants = [(coarse, "none"), (dataclasses.replace(coarse, pcf=True), "none"),
                (coarse, "map"), (dataclasses.replace(coarse, grid="off"), "map-count"),
                (dataclasses.replace(coarse, pcf=True), "cache")]
    expected = [render(ctx, tiny, s, debug=d)[0].image for s, d in variants]
    assert len({e.tobytes() for e in expected}) == len(variants)  # each variant differs
    r = Renderer(ctx, tiny, SIZE, coarse, gbuffer=True)
    view = View.from_camera(tiny.camera, SIZE)
    try:
        counts = []
        for _ in range(2):
            for (settings, debug), want in zip(variants, expected, strict=True):
                r.set_settings(settings)
                r.debug_view = debug
                assert np.array_equal(r.render(0.0, view).image, want), (settings, debug)
            counts.append(r.gl_objects())
        assert counts[0] == counts[1]
    finally:
        r.release()
