"""Clump maps sized by the view: the atlas's squares, the budget, the hysteresis, the render cap."""

from __future__ import annotations

import dataclasses

import numpy as np

from game import transforms
from game.render.renderer import COUNT_EVERY, Renderer, View
from game.scene import load_scene
from game.shadows.atlas import Atlas, Square
from game.shadows.crowd import pow2_at_least, pow2_sides
from game.shadows.fit import cube_face_reach, fit_cube_faces
from game.shadows.plan import KIND_CHARACTER, SHADOW_BUDGET_MIB, ShadowSettings
from game.shadows.view_budget import (
    ClumpRequest,
    ViewBudget,
    atlas_shape,
    free_a_square,
)
from tests.helpers import ASSETS, COURTYARD
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


def _fragmented(max_renders: int):
    """A budget whose map 0 gives up three quarters of its square while map 3 asks as many
    texels more, free but in three pieces; the squares before, and the second frame."""
    budget = ViewBudget(layers=1, resolution=1024, min_side=128, reserved=[],
                        max_renders=max_renders)
    frames = iter([[512, 512, 512, 256, 256, 256, 256], [256, 512, 512, 512, 256, 256, 256]])
    budget.sides = lambda requests: next(frames)
    placed, _ = budget.place(_requests([1.0] * 7), set())
    before = [p.squares[0] for p in placed]
    placed, drawn = budget.place(_requests([1.0] * 7), set())
    squares = [s for p in placed for s in p.squares]
    assert not any(_overlap(a, b) for i, a in enumerate(squares) for b in squares[:i])
    return budget, before, placed, drawn


def test_a_map_that_finds_no_free_square_moves_smaller_maps_aside_instead_of_a_repack():
    """Laying every square out anew would draw every map again: a map whose larger side finds
    no free square, the free texels broken up, takes the aligned square that costs fewest
    draws, its maps moved to free squares elsewhere and drawn again there."""
    budget, before, placed, drawn = _fragmented(max_renders=64)
    assert placed[3].side == 512 and budget.backlog == 0
    assert drawn == {0, 3}  # map 0 shrank into the square map 3 left, and is drawn anyway
    assert placed[0].squares[0] == before[3]
    assert [p.squares[0] for p in placed[1:3]] == before[1:3]
    assert [p.squares[0] for p in placed[4:]] == before[4:]


def test_a_map_that_finds_no_free_square_within_the_render_cap_waits():
    budget, before, placed, drawn = _fragmented(max_renders=1)
    assert drawn == {0} and budget.backlog == 1
    assert budget.atlas.free_texels == 512 ** 2 - 256 ** 2
    assert placed[3].side == 256 and placed[3].squares[0] == before[3]


def test_moving_maps_aside_never_moves_the_character_maps_squares():
    """Squares of 256 in a layer of 1024: the 512 square that holds a character square is
    never freed, though it holds the fewest maps; the next fewest is, its one map moved."""
    atlas = Atlas(1, 1024)
    squares = [Square(0, x, y, 256) for y in range(0, 1024, 256) for x in range(0, 1024, 256)]
    for square in squares:
        atlas.take_again(square)
    fixed = [squares[0]]  # the 512 square at (0, 0) holds it and the squares 1, 4 and 5
    placed = {k: [squares[k]] for k in range(1, 16)}
    for k in (1, 4, 2, 3, 7):  # leave one map in (0, 0) and one, map 6, in (512, 0)
        atlas.give(placed.pop(k)[0])
    found = free_a_square(atlas, placed, fixed, 512, 8, set())
    assert found is not None
    square, moved = found
    assert square == Square(0, 512, 0, 512) and moved == {6}
    assert not any(_overlap(placed[6][0], other) for other in (square, *fixed))
    # The other two 512 squares hold four maps each: more than the free texels can take.
    assert free_a_square(atlas, placed, fixed, 512, 8, set()) is None


def test_sides_follow_the_weights_the_counts_give():
    """At the same need, a map with longer shadow edges gets more texels, one whose pixels
    show no edge of it the least; a map with no weight goes as wide as its need."""
    budget = ViewBudget(layers=1, resolution=2048, min_side=128, reserved=[], max_renders=64)
    requests = [dataclasses.replace(r, weight=w) for r, w in
                zip(_requests([500.0] * 4), [8e6, 1e6, 0.0, None], strict=True)]
    sides = budget.sides(requests)
    assert sides[0] > sides[1] > sides[2] == 128
    assert sum(s * s for s in sides) <= 2048 ** 2


def test_sides_the_hysteresis_holds_give_way_to_a_map_whose_weight_grows():
    """Eight maps fill two layers at 1024; map 0's edges grow 27-fold. The hysteresis would
    keep the others at 1024, which leaves map 0 no more: the held sides are paid for by the
    scale, so they shrink and map 0 gets the 2048 its weight asks."""
    budget = ViewBudget(layers=2, resolution=2048, min_side=128, reserved=[], max_renders=64)
    for w0 in (1e6, 27e6):
        requests = [dataclasses.replace(r, weight=w0 if k == 0 else 1e6)
                    for k, r in enumerate(_requests([900.0] * 8))]
        placed, _ = budget.place(requests, set())
    assert [p.side for p in placed] == [2048] + [512] * 7


def test_weights_that_fall_as_a_map_grows_do_not_flip_its_side_frame_after_frame():
    """Counted at a larger side, a map's edges may weigh less than at the smaller one: the
    sides the hysteresis holds are paid for by the scale, so the map keeps its new side and
    nothing is drawn again once it has grown."""
    budget = ViewBudget(layers=1, resolution=2048, min_side=128, reserved=[], max_renders=64)
    weights = {0: 2e7, 1: 4e6, 2: 4e6, 3: 4e6}
    redrawn = []
    for frame in range(8):
        placed, drawn = budget.place(
            [dataclasses.replace(r, weight=weights[k]) for k, r in
             enumerate(_requests([900.0] * 4))], set())
        redrawn.append(len(drawn) if frame else 0)
        # Map 0's count as it would be at its new side: its edges' pixels fall faster than
        # its side grows.
        weights[0] = 2e7 * (512 / placed[0].side) ** 1.2
    assert redrawn[3:] == [0] * 5, redrawn


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
    assert budget.held == {"clump_0"}
    assert atlas_shape(0, 128, 4096) == (1, 128)


def test_the_shading_pass_counts_each_maps_pixels_near_its_shadow_edges(ctx):
    """From the scene's camera, pixels near the edges of the clumps' shadows are counted for
    the maps that hold them, never more than the pixels covered; looking at the sky, none."""
    scene = load_scene(COURTYARD)
    size = (160, 90)
    renderer = Renderer(ctx, scene, size, ShadowSettings(view_resolution=True))
    try:
        frame = renderer.render(0.0, View.from_camera(scene.camera, size))
        plan = renderer.last_plan
        counts = renderer.blocks.counted_pixels(len(plan.maps))
        clumps = [i for i, rec in enumerate(plan.maps) if rec.kind == 0]
        assert counts[clumps].sum() > 0
        assert counts.max() <= frame.covered.sum()
        up = dataclasses.replace(scene.camera, target=scene.camera.position + [0.0, 10.0, 0.1])
        for _ in range(COUNT_EVERY):  # one frame in COUNT_EVERY counts
            renderer.render(0.0, View.from_camera(up, size))
        assert renderer.blocks.counted_pixels(len(renderer.last_plan.maps)).sum() == 0
    finally:
        renderer.release()


def test_the_first_frame_places_the_view_sized_maps_by_its_own_counts(ctx):
    """The first frame's maps are placed before any pixel is counted: the frame counts them,
    places them anew and draws them again. Counted at their new sides, a few maps may change
    side in the next frames; then a still camera draws no clump map again and keeps every
    side."""
    scene = load_scene(ASSETS / "night_town.toml")
    size = (160, 90)
    view = View.from_camera(scene.camera, size)
    # A budget given, held to: the test asks how the sides settle in an atlas, not how large
    # the default makes it (each lamp owed its baselines' cube).
    renderer = Renderer(ctx, scene, size, ShadowSettings(view_resolution=True,
                                                         budget_mib=float(SHADOW_BUDGET_MIB)))
    try:
        first = renderer.render(0.0, view)
        plan = renderer.last_plan
        clump_maps = sum(rec.kind != KIND_CHARACTER for rec in plan.maps)
        assert first.maps_rendered >= 2 * clump_maps
        again = 0
        for _ in range(2 * COUNT_EVERY):
            renderer.render(0.0, view)
            again += len(renderer.last_plan.render_static)
        assert again <= clump_maps // 10
        sides = [rec.viewport for rec in renderer.last_plan.maps]
        for _ in range(COUNT_EVERY + 1):
            renderer.render(0.0, view)
            assert renderer.last_plan.render_static == []
            assert [rec.viewport for rec in renderer.last_plan.maps] == sides
    finally:
        renderer.release()


def test_counted_weights_survive_scene_edits_and_a_still_camera_settles_again(ctx):
    """Statics moved and removed between counted frames, with view-sized maps: every frame's
    maps lie in the array, and a still camera draws no clump map again once the counts of the
    new clumps have caught up."""
    scene = load_scene(COURTYARD)
    size = (160, 90)
    view = View.from_camera(scene.camera, size)
    renderer = Renderer(ctx, scene, size, ShadowSettings(view_resolution=True))
    try:
        for _ in range(COUNT_EVERY + 1):
            renderer.render(0.0, view)
        statics = sorted(renderer.scene.statics, key=lambda b: b.mesh.area)
        renderer.move_static(statics[-1].name, transforms.translation([1.5, 0.0, 0.0]))
        renderer.render(0.0, view)
        renderer.remove_static(statics[0].name)
        for _ in range(3 * COUNT_EVERY):
            renderer.render(0.0, view)
            plan = renderer.last_plan
            assert all(rec.layer < renderer.shadows.prepare().layers for rec in plan.maps)
        assert renderer.last_plan.render_static == []
    finally:
        renderer.release()
