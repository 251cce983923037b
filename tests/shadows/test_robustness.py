"""Numerical robustness of the clumped method.

Scenes scaled from 0.01 m to 1000 m, a far plane at 10 km, the camera inside a caster, the light
exactly along the up axis, and a point light inside a clump's bounds. Each frame must be free of
NaN (image, G-buffer, map fits) and, where the method is meant to hold, within the foundation's 5%
shadow-error bound against Embree (tests/shadows/test_accuracy.py, tests/shadow_check.py).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from game.render.renderer import Renderer
from game.scene import Body, Character, Light, load_scene, parse_scene, reference_scene_path
from game.shadows.plan import TEXELS_PER_METRE, ShadowSettings
from tests.helpers import ACCURACY_SIZE as SIZE
from tests.helpers import MAX_ERROR, POINT, TINY
from tests.shadow_check import render_and_check

pytest.importorskip("embreex", reason="the Embree reference needs embreex (pip install .[test])")



def scaled(scene, s: float):
    """The same scene ``s`` times larger about the origin (speeds too, so poses match)."""
    def body(b: Body) -> Body:
        mesh = b.mesh.copy()
        mesh.apply_scale(s)
        return Body(b.name, b.kind, mesh)

    def character(c: Character) -> Character:
        mesh = c.mesh.copy()
        mesh.apply_scale(s)
        return Character(c.name, mesh, np.asarray(c.path) * s, c.speed * s, c.phase)

    def light(light):
        if light.position is not None:
            light = dataclasses.replace(light, position=light.position * s)
        if light.range is not None:
            light = dataclasses.replace(light, range=light.range * s)
        return light

    camera = dataclasses.replace(scene.camera, position=scene.camera.position * s,
                                 target=scene.camera.target * s, near=scene.camera.near * s,
                                 far=scene.camera.far * s)
    return dataclasses.replace(scene, camera=camera, lights=[light(x) for x in scene.lights],
                               floors=[body(b) for b in scene.floors],
                               statics=[body(b) for b in scene.statics],
                               characters=[character(c) for c in scene.characters])


def check(ctx, scene, t: float = 1.0, min_shadowed: int = 200, bound: bool = True,
          settings=None):
    renderer = Renderer(ctx, scene, SIZE, settings, gbuffer=True)
    try:
        frame, err = render_and_check(renderer, t)  # asserts: no NaN in the G-buffer
        plan = renderer.method.plan(renderer.models(t))
        for m in plan.maps:
            assert np.all(np.isfinite(m.fit.view_proj)), m.name
        assert frame.image.any()
        if bound:
            assert err["shadowed"] >= min_shadowed
            assert err["error"] <= MAX_ERROR, (err["error"], err["misclassified"],
                                               err["shadowed"])
        return frame, err
    finally:
        renderer.release()


@pytest.mark.parametrize("s", [0.01, 0.1, 10.0, 1000.0])
@pytest.mark.parametrize("path", [TINY, POINT, reference_scene_path()],
                         ids=["tiny", "point", "courtyard"])
def test_scaled_scenes(ctx, path, s):
    # The clumps' density target is in texels per metre: scaled with the scene, so that the
    # scaled scene gets the same maps and only the numbers change. (At the default target, a
    # scene 0.01 times as large fits one clump map; docs/results.md gives its error.)
    settings = ShadowSettings(texels_per_metre=TEXELS_PER_METRE / s)
    check(ctx, scaled(load_scene(path), s), min_shadowed=100, settings=settings)


def test_far_plane_at_10_km(ctx, courtyard):
    scene = courtyard
    scene.camera = dataclasses.replace(scene.camera, far=10_000.0)
    check(ctx, scene)


def test_camera_inside_a_caster(ctx):
    scene = load_scene(TINY)
    box = scene.statics[0].mesh  # the 1.5 x 2 x 1 box at (-0.5, 1, -0.5)
    inside = box.bounds.mean(axis=0)
    scene.camera = dataclasses.replace(scene.camera, position=inside,
                                       target=inside + np.array([0.3, -0.4, 1.0]))
    # Closed volumes are seen from outside only (back faces are culled), so from inside the box
    # the camera sees out through it, onto the floor, the sphere and the character.
    check(ctx, scene, min_shadowed=20)


@pytest.mark.parametrize("direction", [[0.0, -1.0, 0.0], [0.0, -3.0, 0.0]])
def test_light_exactly_along_the_up_axis(ctx, direction, courtyard):
    scene = courtyard
    d = np.array(direction) / np.linalg.norm(direction)
    scene.light = Light("directional", d, None, None)
    check(ctx, scene)


def test_point_light_inside_a_clump(ctx):
    # The light between the box and the sphere of tiny.toml, below the sphere's top: with one
    # clump for both, the light sits inside the clump's bounds.
    scene = load_scene(TINY)
    scene.light = Light("point", None, np.array([0.6, 0.6, 0.2]), None)
    settings = ShadowSettings(clump_count=1)
    check(ctx, scene, settings=settings, min_shadowed=100)
    renderer = Renderer(ctx, scene, SIZE, settings)
    try:
        method = renderer.method
        assert len(method.clumps) == 1 and len(method.static_maps) > 1  # the cube of maps
        assert len({m.layer for m in method.static_maps}) == len(method.static_maps)
    finally:
        renderer.release()


def test_point_light_inside_a_clump_of_the_point_scene(ctx):
    scene = load_scene(POINT)
    scene.light = dataclasses.replace(scene.light, position=np.array([0.0, 1.0, 0.0]))
    check(ctx, scene, settings=ShadowSettings(clump_count=1))


def test_parse_then_scale_keeps_degenerate_inputs_out():
    # Tiny scales must not make a valid scene's triangles count as zero-area.
    text = TINY.read_text().replace("radius   = 0.7", "radius   = 0.7\nscale = 0.001")
    scene = parse_scene(text, TINY, TINY.parent)
    assert len(scene.statics[1].mesh.faces) == 320
