"""Many lights: every light's maps in one array and one budget, each light scored on its own."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from game.gpu import blocks
from game.reference.score import score_frame
from game.render.frame_blocks import join_grids
from game.render.renderer import Renderer, View
from game.scene import load_scene
from game.scene.generate import generate_town
from game.scene.loader import MAX_LIGHTS
from game.shadows.lights import LightSpan, budget_shares, min_layers, scene_radius
from game.shadows.map_grid import MapGrid
from game.shadows.plan import CLUMP_RESOLUTION, KIND_CHARACTER, ShadowSettings
from game.shadows.registry import MAP_METHODS
from tests.helpers import ASSETS, SCENES
from tests.shadow_check import occluders

LAMPS = SCENES / "lamps.toml"
SIZE = (160, 90)
MAX_ERROR = 0.05


def _render(ctx, method: str = "clumped", size=SIZE, on=None, **settings):
    scene = load_scene(LAMPS)
    renderer = Renderer(ctx, scene, size, ShadowSettings(method=method, **settings),
                        gbuffer=True)
    if on is not None:
        renderer.lights_on = list(on)
    frame = renderer.render(0.0, View.from_camera(scene.camera, size))
    return renderer, frame


@pytest.mark.parametrize("method", MAP_METHODS)
def test_every_method_shadows_every_light_within_the_bar(ctx, method):
    renderer, frame = _render(ctx, method)
    try:
        g = frame.gbuffer
        assert g["lit_lights"].shape == (*SIZE[::-1], 3)
        assert np.array_equal(g["lit_lights"][..., 0], g["lit"], equal_nan=True)
        mesh = occluders(renderer.scene, 0.0)
        for k, light in enumerate(renderer.scene.lights):
            err = score_frame(g["lit_lights"][..., k], g["position"], g["normal"], mesh, light)
            assert err["shadowed"] > 20, (k, err["shadowed"])  # the light casts shadows here
            assert err["error"] <= MAX_ERROR, (method, k, err["error"])
    finally:
        renderer.release()


def test_the_lights_of_the_picture_add_up_and_a_lamp_ends_at_its_range(ctx):
    """Each lamp brightens only what lies within its range; the picture with all lights is
    brighter than with any one of them off."""
    images = {}
    for on in ((False, False, False), (False, True, False), (True, True, True),
               (True, False, True)):
        renderer, frame = _render(ctx, on=on)
        images[on] = frame.image.astype(int)
        position = frame.gbuffer["position"]
        renderer.release()
    lamp = load_scene(LAMPS).lights[1]
    distance = np.linalg.norm(position - lamp.position, axis=-1)
    beyond = np.isfinite(distance) & (distance > lamp.range)
    within = np.isfinite(distance) & (distance < 0.5 * lamp.range)
    dark, lamp_only = images[(False, False, False)], images[(False, True, False)]
    assert beyond.sum() > 1000 and within.sum() > 100
    assert np.array_equal(lamp_only[beyond], dark[beyond])
    assert (lamp_only[within].sum(axis=-1) > dark[within].sum(axis=-1)).mean() > 0.5
    assert images[(True, True, True)].sum() > images[(True, False, True)].sum()


@pytest.mark.parametrize("method", MAP_METHODS)
def test_a_lamp_plans_no_map_for_casters_beyond_its_range(ctx, method):
    renderer, _ = _render(ctx, method)
    try:
        crate = renderer.geom.static_object(4)      # the far crate
        walker = renderer.geom.character_object(1)  # the far walker
        near = renderer.geom.character_object(0)    # walks round the point lamp
        for k, span in enumerate(renderer.last_spans):
            maps = renderer.last_plan.maps[span.first_map:span.first_map + span.map_count]
            held = {o for rec in maps for o in rec.objects}
            assert (crate in held) == (k == 0), k  # only the sun reaches them
            assert (walker in held) == (k == 0), k
            if k == 1:
                assert near in held
    finally:
        renderer.release()


def _moving_a_lamp_redraws_only_its_maps(renderer: Renderer, k: int) -> None:
    """Render twice (every clump map cached by then), move light k by half a metre, render:
    the clump maps drawn again are all light k's."""
    view = View.from_camera(renderer.scene.camera, renderer.size)
    renderer.render(0.0, view)
    renderer.render(0.0, view)
    assert not renderer.last_plan.render_static  # every clump map is cached
    lamp = renderer.scene.lights[k]
    renderer.set_light(dataclasses.replace(lamp, position=lamp.position + [0.5, 0.0, 0.0]), k)
    renderer.render(0.0, view)
    span = renderer.last_spans[k]
    redrawn = renderer.last_plan.render_static
    assert redrawn and all(span.first_map <= i < span.first_map + span.map_count
                           for i in redrawn)


def test_moving_one_lamp_re_renders_only_its_maps(ctx):
    renderer, _ = _render(ctx)
    try:
        _moving_a_lamp_redraws_only_its_maps(renderer, 1)
    finally:
        renderer.release()


def test_moving_a_lamp_of_the_night_town_re_renders_only_its_maps(ctx):
    """A lamp moved half a metre clumps anew within the layers kept for it, so no other
    light's cached maps move."""
    renderer = Renderer(ctx, load_scene(ASSETS / "night_town.toml"), (64, 36))
    try:
        _moving_a_lamp_redraws_only_its_maps(renderer, 5)
    finally:
        renderer.release()


def test_view_sized_maps_of_every_light_share_one_atlas_sized_by_the_view(ctx):
    """With view-sized maps the lights' clump maps take squares of one atlas, in no more
    memory than their fixed maps keep, by what the view needs whichever light casts: the
    lamp nearest the camera gets finer faces than the farthest; a lamp moved re-renders only
    its own maps."""
    scene = load_scene(ASSETS / "night_town.toml")
    size = (160, 90)
    renderer = Renderer(ctx, scene, size, ShadowSettings(view_resolution=True))
    try:
        renderer.render(0.0, View.from_camera(scene.camera, size))
        methods, plan = renderer.shadows.methods, renderer.last_plan
        fixed = sum(m.fixed_texels for m in methods) * 4
        assert renderer.shadow_memory_bytes <= 1.25 * fixed
        taken: dict[int, np.ndarray] = {}
        for record in plan.maps:
            used = taken.setdefault(record.layer, np.zeros((plan.resolution,) * 2, bool))
            x, y = record.origin
            if record.kind == KIND_CHARACTER:  # the characters' maps share their squares
                continue
            square = used[y:y + record.viewport, x:x + record.viewport]
            assert not square.any(), record.name
            square[:] = True
        distance = [np.linalg.norm(m.light.position - scene.camera.position)
                    for m in methods[1:]]
        sides = [max(r.viewport for r in plan.maps[s.first_map:s.first_map + s.map_count]
                     if r.kind != KIND_CHARACTER) for s in renderer.last_spans[1:]]
        assert sides[int(np.argmin(distance))] > sides[int(np.argmax(distance))], sides
        _moving_a_lamp_redraws_only_its_maps(renderer, 5)
    finally:
        renderer.release()


def test_characters_that_come_to_a_scene_of_several_lights_get_squares_of_the_shared_atlas(
        ctx):
    """The lights' atlas is made anew for the characters' squares before the array is sized:
    every map of the next frame lies in the array, and the walkers cast their shadows."""
    scene = load_scene(LAMPS)
    walkers, scene.characters = scene.characters, []
    view = View.from_camera(scene.camera, SIZE)
    renderer = Renderer(ctx, scene, SIZE, ShadowSettings(budget_mib=256.0, view_resolution=True),
                        gbuffer=True)
    try:
        renderer.render(0.0, view)
        for walker in walkers:
            renderer.add_character(walker)
        frame = renderer.render(0.0, view)
        plan = renderer.last_plan
        assert plan.render_dynamic
        assert all(record.layer < renderer.shadows.prepare().layers for record in plan.maps)
        mesh = occluders(renderer.scene, 0.0)
        for k, light in enumerate(renderer.scene.lights):
            g = frame.gbuffer
            err = score_frame(g["lit_lights"][..., k], g["position"], g["normal"], mesh, light)
            assert err["error"] <= MAX_ERROR, (k, err["error"])
    finally:
        renderer.release()


def test_every_light_shares_one_budget(ctx):
    budget = 64.0
    renderer, _ = _render(ctx, budget_mib=budget)
    try:
        assert renderer.shadow_memory_bytes <= budget * 2**20
    finally:
        renderer.release()


def test_what_a_light_leaves_of_its_share_goes_to_the_lights_short_of_theirs(ctx):
    """In 64 MiB the sun and the spot lamp of lamps.toml take less than their shares, and the
    point lamp's clumps are short of layers: it gets what they leave, and all lights together
    still keep to the budget."""
    budget = 64.0
    renderer, _ = _render(ctx, budget_mib=budget)
    try:
        lights, methods = renderer.scene.lights, renderer.shadows.methods
        shares, _ = budget_shares(lights, budget, CLUMP_RESOLUTION, scene_radius(renderer.geom))
        used = [m.memory_mib for m in methods]
        assert sum(used) <= budget
        grown = [k for k in range(len(lights)) if used[k] > shares[k]]
        assert grown and all(methods[k].settings.budget_mib > shares[k] for k in grown)
        assert all(used[k] <= methods[k].settings.budget_mib for k in range(len(lights)))
        said = [note for note in renderer.notes if "short of" in note]
        assert len(said) == 1 and all(str(k) in said[0] for k in grown), said
    finally:
        renderer.release()


def test_no_clump_map_of_a_point_lamp_is_wider_than_a_cube_face(ctx):
    """A wider frustum would spread its texels thinner than the faces of a cube around the lamp:
    such a clump gets the faces instead, however many layers the lamp has."""
    renderer = Renderer(ctx, load_scene(ASSETS / "night_town.toml"), (64, 36))
    try:
        lamps = renderer.shadows.methods[1:]
        assert all(lamp.light.kind == "point" for lamp in lamps)
        for lamp in lamps:
            for record in lamp.static_maps:
                texel = 2.0 / (record.viewport - 3)  # a face's texel in tan units, as fitted
                # The rectangle is square, about its points' centre: its width is what counts.
                assert record.fit.rect[2] - record.fit.rect[0] <= 2.0 + 5.0 * texel, (
                    record.fit.rect)
    finally:
        renderer.release()


def test_the_budget_goes_first_to_what_each_light_cannot_do_without():
    scene = load_scene(LAMPS)
    shares, sides = budget_shares(scene.lights, 512.0, 1024, 20.0)
    assert sides == [1024] * 3 and sum(shares) == pytest.approx(512.0)
    floors = [4.0 * min_layers(light) for light in scene.lights]
    assert all(s >= f for s, f in zip(shares, floors, strict=True))
    assert shares[0] > shares[1] and shares[0] > shares[2]  # the sun reaches the whole scene
    # Sixty lamps cannot each have a cube of 1024-texel faces in 512 MiB: their maps shrink,
    # the sun's stay.
    many = [scene.lights[0]] + [scene.lights[1]] * 60
    shares, sides = budget_shares(many, 512.0, 1024, 20.0)
    assert sides[0] == 1024 and all(side < 1024 for side in sides[1:])
    assert sum(shares) == pytest.approx(512.0)
    assert all(s >= 4.0 * min_layers(x) * (side / 1024) ** 2
               for s, x, side in zip(shares, many, sides, strict=True))


def test_the_light_records_hold_as_many_lights_as_a_scene_may_have():
    assert blocks.MAX_LIGHTS == MAX_LIGHTS


def test_street_lamps_are_drawn_after_the_town_and_leave_it_as_it_was():
    plain = generate_town({"seed": 5, "blocks": 2, "characters": 3})
    lit = generate_town({"seed": 5, "blocks": 2, "characters": 3, "lamps": 6,
                         "lamp_range": 12.0})
    assert len(lit.lamps) == 6 and len(lit.statics) == len(plain.statics) + 6
    for a, b in zip(plain.statics, lit.statics, strict=False):
        assert np.array_equal(a.vertices, b.vertices)
    assert all(np.array_equal(a.path, b.path) for a, b in zip(plain.walkers, lit.walkers,
                                                              strict=True))
    again = generate_town({"seed": 5, "blocks": 2, "characters": 3, "lamps": 6,
                           "lamp_range": 12.0})
    assert [tuple(x.position) for x in again.lamps] == [tuple(x.position) for x in lit.lamps]
    for lamp, post in zip(lit.lamps, lit.statics[-6:], strict=True):
        assert 3.0 < lamp.position[1] < post.bounds[1][1]  # under its post's arm


def test_joining_the_lights_grids_shifts_their_maps_and_keeps_no_map_as_none():
    """Every light's grid goes into one buffer, its offsets moved past the grids before it and
    its map indices past the lights before it; a negative entry (no map) stays negative, where
    shifting it would name the last map of the light before."""
    first = MapGrid(blocks.GRID_ORTHO, 1, np.array([0.0, 0.0, 1.0, 1.0]),
                    np.array([2, 4, 0, 1], np.int32))
    # 2 x 2 cells: the first lists no map (-1) and character map 1, the second tile 0.
    tiles = MapGrid(blocks.GRID_TILES, 2, np.array([0.0, 0.0, 1.0, 1.0]),
                    np.array([5, 7, 8, 8, 8, -1, 1, 0], np.int32))
    data, bases = join_grids([first, tiles], [LightSpan(0, 2, 0), LightSpan(2, 2, 2)])
    assert bases == [0, 4]
    assert data[4:9].tolist() == [9, 11, 12, 12, 12]      # offsets moved by the first grid
    assert data[9:].tolist() == [-1, 3, 2]                 # -1 kept, maps moved by 2
