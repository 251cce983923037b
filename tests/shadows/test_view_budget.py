"""Clump maps sized by the view: the atlas's squares, the budget, the hysteresis, the render cap."""

from __future__ import annotations

import dataclasses

import numpy as np

from game.render.renderer import Renderer, View
from game.scene import load_scene
from game.shadows.atlas import Atlas
from game.shadows.crowd import pow2_at_least
from game.shadows.fit import cube_face_reach, fit_cube_faces
from game.shadows.plan import ShadowSettings
from game.shadows.view_budget import ClumpRequest, ViewBudget, atlas_shape, pow2_sides
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


def test_sides_follow_the_need_and_fill_the_budget():
    budget = ViewBudget(layers=1, resolution=2048, min_side=128, reserved=[], max_renders=64)
    needs = [100.0, 300.0, 900.0]
    sides = budget.sides(_requests(needs))
    assert sides == sorted(sides) and sides[0] < sides[2]  # nearer maps get more texels
    assert sum(s * s for s in sides) <= 2048 ** 2
    # One scale for all: doubling the largest would not fit.
    assert sum(s * s for s in sides) + 3 * sides[2] ** 2 > 2048 ** 2
    # The same needs, all twice as large (the camera half as far): the same sides.
    assert budget.sides(_requests([2 * n for n in needs])) == sides
    # Four maps asking 2048 each cannot all have it in one 2048 layer.
    sides = budget.sides(_requests([5000.0] * 4))
    assert sides == [1024] * 4


def test_a_small_change_of_need_draws_nothing_again_and_a_large_one_draws_what_changed():
    budget = ViewBudget(layers=2, resolution=2048, min_side=128, reserved=[1024],
                        max_renders=64)
    needs = [300.0, 600.0, 90.0, 1500.0]
    placed, drawn = budget.place(_requests(needs), set())
    assert drawn == {0, 1, 2, 3}
    before = [p.side for p in placed]
    # A little nearer or farther: the hysteresis keeps every side.
    placed, drawn = budget.place(_requests([n * 0.9 for n in needs]), set())
    assert drawn == set() and [p.side for p in placed] == before
    # Map 2 comes much nearer: its side grows, and only maps whose side changed are drawn.
    placed, drawn = budget.place(_requests([300.0, 600.0, 1200.0, 1500.0]), set())
    after = [p.side for p in placed]
    assert after[2] > before[2] and 2 in drawn
    assert drawn == {i for i in range(4) if after[i] != before[i]}
    squares = [s for p in placed for s in p.squares] + budget.reserved
    assert not any(_overlap(a, b) for i, a in enumerate(squares) for b in squares[:i])


def test_at_most_the_cap_of_maps_change_side_in_a_frame_and_the_rest_follow():
    budget = ViewBudget(layers=2, resolution=2048, min_side=128, reserved=[], max_renders=3)
    placed, _ = budget.place(_requests([1000.0] * 8), set())
    assert all(p.side == 1024 for p in placed)
    drawn_per_frame, waiting = [], []
    for _ in range(4):  # the camera turns away: every map wants the least
        placed, drawn = budget.place(_requests([0.0] * 8), set())
        drawn_per_frame.append(len(drawn))
        waiting.append(budget.backlog)
    assert drawn_per_frame == [3, 3, 2, 0] and waiting == [5, 2, 0, 0]
    assert all(p.side == 128 for p in placed)


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


def test_turning_away_shrinks_the_clump_maps_the_view_cannot_see(ctx):
    scene = load_scene(COURTYARD)
    size = (320, 180)
    renderer = Renderer(ctx, scene, size, ShadowSettings(view_resolution=True))
    try:
        renderer.render(0.0, View.from_camera(scene.camera, size))
        before = {rec.name: rec.viewport for rec in renderer.last_plan.maps if rec.kind == 0}
        away = dataclasses.replace(scene.camera, target=2 * scene.camera.position
                                   - scene.camera.target)
        smallest, redrawn = {}, set()
        for _ in range(4):  # at most 16 maps change side a frame: let them all follow
            renderer.render(0.0, View.from_camera(away, size))
            plan = renderer.last_plan
            redrawn |= {plan.maps[i].name for i in plan.render_static}
            smallest = {rec.name: rec.viewport for rec in plan.maps if rec.kind == 0}
        shrunk = {name for name in smallest if smallest[name] < before[name]}
        assert shrunk and shrunk <= redrawn
        assert min(smallest.values()) == 128
    finally:
        renderer.release()


def test_the_budget_rounds_every_need_to_a_side_as_the_crowd_does():
    needs = np.concatenate([np.random.default_rng(1).uniform(0.0, 9000.0, 2000),
                            [0.0, 1.0, 127.0, 128.0, 129.0, np.inf, np.nan],
                            [2.0 ** k for k in range(14)]])
    assert pow2_sides(needs, 128, 4096).tolist() == [pow2_at_least(n, 128, 4096) for n in needs]


def test_a_map_that_finds_no_free_square_for_its_new_side_waits_instead_of_a_repack():
    """Laying every square out anew would draw every map again: a map whose larger side finds
    no free square, the free texels broken up, keeps its side and square and waits."""
    budget = ViewBudget(layers=1, resolution=1024, min_side=128, reserved=[], max_renders=64)
    # Map 0 gives up three quarters of its square; map 3 asks as many texels more, which are
    # free but lie in three pieces.
    frames = iter([[512, 512, 512, 256, 256, 256, 256], [256, 512, 512, 512, 256, 256, 256]])
    budget.sides = lambda requests: next(frames)
    placed, _ = budget.place(_requests([1.0] * 7), set())
    before = [p.squares[0] for p in placed]
    placed, drawn = budget.place(_requests([1.0] * 7), set())
    assert drawn == {0} and budget.backlog == 1
    assert budget.atlas.free_texels == 512 ** 2 - 256 ** 2
    assert placed[3].side == 256 and placed[3].squares[0] == before[3]
    squares = [s for p in placed for s in p.squares]
    assert not any(_overlap(a, b) for i, a in enumerate(squares) for b in squares[:i])


def test_a_cube_face_is_as_wide_as_the_deepest_point_in_front_of_it_within_the_range():
    """A lamp in a long room: the wall beside it has its corners outside the face that looks
    at it, and its middle inside; the floor's face holds the lamp's height; nothing lies
    beyond the range."""
    eye = np.zeros(3)
    wall = np.array([[5.0, y, z] for y in (-2.0, 2.0) for z in (-10.0, 10.0)])
    floor = np.array([[x, -2.0, z] for x in (-4.0, 4.0) for z in (-10.0, 10.0)])
    points = np.concatenate([wall, floor])
    faces = cube_face_reach(points, eye, reach=8.0)
    assert len(faces) == len(fit_cube_faces(points, eye, 256))
    widths = {tuple(np.sign(np.round(centre, 6)).astype(int)): width for centre, width in faces}
    assert widths[(1, 0, 0)] == 10.0    # the wall, 5 m away
    assert widths[(0, -1, 0)] == 4.0    # the floor, 2 m below
    assert widths[(0, 0, 1)] == 16.0    # along the room: held to the range


def test_a_clump_that_goes_takes_its_hysteresis_with_it_and_an_empty_atlas_is_small():
    budget = ViewBudget(layers=1, resolution=2048, min_side=128, reserved=[], max_renders=64)
    budget.place(_requests([500.0, 500.0]), set())
    budget.place(_requests([500.0]), set())
    assert set(budget._sizes._size) == {"clump_0"}
    assert atlas_shape(0, 128, 4096) == (1, 128)
