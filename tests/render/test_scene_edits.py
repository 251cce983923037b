"""Cache invalidation through the Python API: each change is checked on the image.

Every test renders, changes the scene or the light through the Renderer, renders again, and compares
the new frame's shadows with Embree shadow rays on its G-buffer (tests/shadow_check.py, the same
reference and 5% bound as tests/shadows/test_accuracy.py). A stale cached map shows up there as
misclassified pixels; the counters only say that no more was re-rendered than needed.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import trimesh

from game import transforms
from game.render.renderer import Renderer, View
from game.scene import Body, Character, Light
from game.shadows.plan import KIND_CHARACTER, ShadowSettings
from tests.helpers import ACCURACY_SIZE as SIZE
from tests.helpers import MAX_ERROR
from tests.shadow_check import frame_error, render_and_check

pytest.importorskip("embreex", reason="the Embree reference needs embreex (pip install .[test])")

T = 3.0


@pytest.fixture
def renderer(ctx, courtyard):
    r = Renderer(ctx, courtyard, SIZE, gbuffer=True)
    yield r
    r.release()


def good(renderer, t: float = T, min_shadowed: int = 200):
    frame, err = render_and_check(renderer, t)
    assert err["shadowed"] >= min_shadowed  # enough shadow in view for the ratio to mean much
    assert err["error"] <= MAX_ERROR, (err["error"], err["misclassified"], err["shadowed"])
    return frame, err


def static_maps_drawn(frame, renderer) -> int:
    n_character_maps = frame.maps_total - len(renderer.method.static_maps)
    return frame.maps_rendered - n_character_maps


def shadowed(frame) -> np.ndarray:
    lit = frame.gbuffer["lit"]
    return np.isfinite(lit) & (lit < 0.5)


def test_moving_the_light_re_renders_every_clump_map(renderer):
    first, _ = good(renderer)
    n_clumps = len(renderer.method.static_maps)
    assert n_clumps >= 3
    cached, _ = good(renderer)
    assert static_maps_drawn(cached, renderer) == 0
    old = renderer.scene.light
    direction = np.array([0.5, -1.0, 0.4])
    renderer.set_light(Light("directional", direction / np.linalg.norm(direction), None, None))
    moved, _ = good(renderer)  # a stale map would leave the old shadows: Embree disagrees
    assert static_maps_drawn(moved, renderer) == len(renderer.method.static_maps)
    assert (shadowed(moved) != shadowed(first)).sum() > 500  # the shadows really moved
    renderer.set_light(old)
    back, _ = good(renderer)
    assert (shadowed(back) != shadowed(first)).sum() < 50


def box_body(name: str, centre, size=(1.2, 2.4, 1.2)) -> Body:
    mesh = trimesh.creation.box(extents=size)
    mesh.apply_translation(centre)
    return Body(name=name, kind="static", mesh=mesh)


def test_adding_a_static_re_renders_only_the_clump_it_joins(renderer):
    before, _ = good(renderer)
    n_clumps = len(renderer.method.static_maps)
    touched = renderer.add_static(box_body("static_new", (2.0, 1.5, 3.0), (2.5, 3.0, 2.5)))
    assert len(touched) == 1
    after, _ = good(renderer)
    assert static_maps_drawn(after, renderer) == 1
    assert len(renderer.method.static_maps) == n_clumps
    assert (shadowed(after) & ~shadowed(before)).sum() > 100  # its shadow is there


def test_removing_a_static_leaves_no_stale_shadow(renderer):
    before, _ = good(renderer)
    biggest = max(renderer.scene.statics, key=lambda b: b.mesh.area)
    touched = renderer.remove_static(biggest.name)
    assert len(touched) <= 1
    after, _ = good(renderer)
    assert static_maps_drawn(after, renderer) == len(touched)
    assert (shadowed(before) & ~shadowed(after)).sum() > 100  # its shadow is gone
    assert biggest.name not in renderer.geom.names


def test_moving_a_static_re_renders_its_old_and_new_clumps(renderer):
    before, _ = good(renderer)
    method = renderer.method
    # The largest static, moved onto the footprint of another clump.
    body = max(renderer.scene.statics, key=lambda b: b.mesh.area)
    name = body.name
    index = renderer.geom.names.index(name)
    target_clump = next(m for m in method.static_maps if index not in m.objects)
    target = next(b for b in renderer.scene.statics
                  if b.name == renderer.geom.names[target_clump.objects[0]])
    offset = target.mesh.bounds.mean(axis=0) - body.mesh.bounds.mean(axis=0)
    offset[1] = 0.0
    offset[0] += 1.5  # beside it, not inside
    was = {m.name for m in method.static_maps if index in m.objects}
    array = renderer.shadow_array
    touched = renderer.move_static(name, transforms.translation(offset))
    now = {m.name for m in method.static_maps if index in m.objects}
    # The maps it leaves and the maps it joins are drawn again (its tiles under the sun), and
    # no others.
    drawn = {method.static_maps[i].name for k in touched for i in method.maps.of_clump[k]}
    assert was | now == drawn
    after, _ = good(renderer)
    assert len(touched) < len(method.static_maps)
    # A new tile that needs a layer beyond the array's makes the array anew, and that loses
    # every cached map; otherwise only the touched maps are drawn.
    grown = renderer.shadow_array is not array
    assert static_maps_drawn(after, renderer) == (len(method.static_maps) if grown
                                                  else len(touched))
    assert (shadowed(before) != shadowed(after)).sum() > 100


def test_removing_a_character_drops_its_map_and_its_shadow(renderer):
    method = renderer.method
    good(renderer)
    array = renderer.shadow_array
    layers = list(method.characters.layers)
    name = "character_0"
    renderer.remove_character(name)
    after, _ = good(renderer)  # a stale character shadow would be misclassified
    drawn = {renderer.geom.names[o] for m in method.plan(renderer.models(T)).maps
             if m.kind == KIND_CHARACTER for o in m.objects}
    assert name not in drawn and len(drawn) == renderer.geom.n_characters
    # A new character's map goes into the layers the character maps share: the array is not
    # re-created.
    walker = renderer.scene.characters[0]
    newcomer = Character(name="character_new", mesh=walker.mesh.copy(),
                         path=np.array([[-4.0, 0.9, 4.0], [4.0, 0.9, 4.0]]), speed=1.0,
                         phase=0.0)
    renderer.add_character(newcomer)
    assert method.characters.layers == layers
    good(renderer)
    assert renderer.shadow_array is array
    objects = renderer.gl_objects()
    good(renderer)
    assert renderer.gl_objects() == objects


def test_layers_are_reused_by_new_clumps(ctx, courtyard):
    scene = courtyard
    # The fixed maps' layers: view-sized maps take squares of an atlas instead.
    settings = ShadowSettings(clump_count=3, view_resolution=False)
    r = Renderer(ctx, scene, SIZE, settings, gbuffer=True)
    try:
        good(r)
        method = r.method
        high = method.layers
        # Empty a clump by removing all its members: its layer goes back to the pool.
        clump = method.static_maps[0]
        freed = clump.layer
        for name in [r.geom.names[obj] for obj in clump.objects]:
            r.remove_static(name)
        assert freed in method.pool.free
        good(r)
        # Remove every other static too, then add one far away: it makes a clump again and takes
        # the lowest free layer instead of growing the array.
        for body in list(r.scene.statics):
            r.remove_static(body.name)
        lowest = min(method.pool.free)
        r.add_static(box_body("static_far", (6.0, 1.2, -6.0)))
        assert [m.layer for m in method.static_maps] == [lowest]
        assert method.layers == high
        good(r, min_shadowed=50)  # a box and the characters are all that is left
    finally:
        r.release()


def test_the_tracer_sees_run_time_edits(ctx, courtyard):
    # The traced method's grid holds the scene's triangles: after an edit it must be rebuilt,
    # or the new static casts no traced shadow while Embree (on the new geometry) sees one.
    r = Renderer(ctx, courtyard, SIZE, gbuffer=True)
    try:
        r.set_settings(dataclasses.replace(r.settings, method="traced"))
        view = View.from_camera(r.scene.camera, SIZE)

        def traced():
            frame = r.render(T, view)  # the traced method's shadows come with the frame
            return frame_error(r, frame, T)

        before = traced()
        target = np.asarray(r.scene.camera.target, float)
        r.add_static(box_body("static_new", target + [0.0, 3.0, 0.0], (6.0, 0.3, 6.0)))
        after = traced()
    finally:
        r.release()
    assert after["shadowed"] > before["shadowed"] + 100  # the slab's shadow is in view
    assert after["error"] <= MAX_ERROR, after
