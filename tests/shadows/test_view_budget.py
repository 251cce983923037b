"""Clump maps sized by the view: the atlas's squares, the budget, the hysteresis, the render cap."""

from __future__ import annotations

import dataclasses

import numpy as np

from game.render.renderer import Renderer, View
from game.scene import load_scene
from game.shadows.atlas import Atlas
from game.shadows.plan import ShadowSettings
from game.shadows.view_budget import ClumpRequest, ViewBudget
from tests.conftest import COURTYARD
from tests.shadow_check import frame_error


def _overlap(a, b) -> bool:
    return (a.layer == b.layer and a.x < b.x + b.side and b.x < a.x + a.side
            and a.y < b.y + b.side and b.y < a.y + a.side)


def test_the_atlas_hands_out_squares_that_never_overlap_and_takes_them_back_whole():
    atlas = Atlas(2, 1024)
    rng = np.random.default_rng(3)
    held = []
    for _ in range(400):
        if held and rng.random() < 0.45:
            atlas.give(held.pop(int(rng.integers(len(held)))))
        else:
            square = atlas.take(int(2 ** rng.integers(6, 10)))
            if square is not None:
                assert square.x % square.side == 0 and square.y % square.side == 0
                assert all(not _overlap(square, other) for other in held)
                held.append(square)
    for square in held:
        atlas.give(square)
    assert atlas.free_texels == 2 * 1024 ** 2
    assert atlas.take(1024) is not None and atlas.take(1024) is not None
    assert atlas.take(64) is None


def test_a_repack_fits_whatever_fits_by_texels():
    atlas = Atlas(1, 1024)
    sides = [512, 256, 256, 256, 128, 128, 128, 128, 256, 64, 64, 64, 64]
    assert sum(s * s for s in sides) <= 1024 ** 2
    squares = atlas.repack(sides)
    assert [s.side for s in squares] == sides
    assert not any(_overlap(a, b) for i, a in enumerate(squares) for b in squares[:i])
    assert atlas.repack([1024, 64]) is None


def _requests(needs, maps=1):
    return [ClumpRequest(key=f"clump_{k}", maps=maps, need=need, refit=lambda side: [side] * maps)
            for k, need in enumerate(needs)]


def test_sides_follow_the_need_within_the_budget():
    budget = ViewBudget(layers=1, resolution=2048, min_side=128, reserved=[], max_renders=64)
    assert budget.sides(_requests([100.0, 300.0, 900.0])) == [128, 512, 1024]
    # Four maps asking 2048 each cannot all have it in one 2048 layer: the largest halve.
    sides = budget.sides(_requests([5000.0] * 4))
    assert sum(s * s for s in sides) <= 2048 ** 2 and max(sides) == 1024


def test_a_small_change_of_need_draws_nothing_again_and_a_large_one_draws_only_its_map():
    budget = ViewBudget(layers=2, resolution=2048, min_side=128, reserved=[1024],
                        max_renders=64)
    needs = [300.0, 600.0, 90.0, 1500.0]
    placed, drawn = budget.place(_requests(needs), set())
    assert drawn == {0, 1, 2, 3}
    assert [p.side for p in placed] == [512, 1024, 128, 2048]
    # A little nearer or farther: the hysteresis keeps every side.
    placed, drawn = budget.place(_requests([n * 0.8 for n in needs]), set())
    assert drawn == set() and [p.side for p in placed] == [512, 1024, 128, 2048]
    # Map 2 comes much nearer: it alone is drawn again, at its new side.
    placed, drawn = budget.place(_requests([300.0, 600.0, 700.0, 1500.0]), set())
    assert drawn == {2} and placed[2].side == 1024
    squares = [s for p in placed for s in p.squares] + budget.reserved
    assert not any(_overlap(a, b) for i, a in enumerate(squares) for b in squares[:i])


def test_at_most_the_cap_of_maps_change_side_in_a_frame_and_the_rest_follow():
    budget = ViewBudget(layers=4, resolution=2048, min_side=128, reserved=[], max_renders=3)
    budget.place(_requests([100.0] * 10), set())
    drawn_per_frame = []
    for _ in range(5):
        placed, drawn = budget.place(_requests([1000.0] * 10), set())
        drawn_per_frame.append(len(drawn))
    assert drawn_per_frame[:3] == [3, 3, 3] and drawn_per_frame[3] == 1
    assert budget.backlog == 0 and all(p.side == 1024 for p in placed)


def test_view_sized_clump_maps_hold_the_accuracy_bar_in_no_more_memory(ctx):
    scene = load_scene(COURTYARD)
    size = (320, 180)
    view = View.from_camera(scene.camera, size)
    memory = {}
    for on in (False, True):
        renderer = Renderer(ctx, scene, size, ShadowSettings(view_resolution=on),
                            gbuffer=True)
        try:
            frame = renderer.render(0.0, view)
            assert frame_error(renderer, frame, 0.0)["error"] <= 0.05
            memory[on] = renderer.shadow_memory_bytes
            again = renderer.render(1 / 30, view)
            statics = [i for i in renderer.last_plan.render_static]
            assert not statics, "a still camera re-renders no clump map"
            assert again.maps_rendered == len(renderer.last_plan.render_dynamic)
        finally:
            renderer.release()
    assert memory[True] <= 1.25 * memory[False]


def test_walking_up_to_a_clump_re_renders_its_map_finer(ctx):
    scene = load_scene(COURTYARD)
    size = (320, 180)
    renderer = Renderer(ctx, scene, size, ShadowSettings(view_resolution=True))
    try:
        far = dataclasses.replace(scene.camera, position=scene.camera.position * 4.0)
        renderer.render(0.0, View.from_camera(far, size))
        before = {rec.name: rec.viewport for rec in renderer.last_plan.maps if rec.kind == 0}
        renderer.render(0.0, View.from_camera(scene.camera, size))
        after = {rec.name: rec.viewport for rec in renderer.last_plan.maps if rec.kind == 0}
        grown = [name for name in after if after[name] > before.get(name, 0)]
        assert grown
        redrawn = {renderer.last_plan.maps[i].name for i in renderer.last_plan.render_static}
        assert set(grown) <= redrawn
    finally:
        renderer.release()
