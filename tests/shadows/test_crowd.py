"""The characters' maps of each frame (game/shadows/crowd.py): sized by need, skipped where no
shadow can be seen, grouped by cost, packed into shared layers; and the frames they make,
checked against Embree."""

from __future__ import annotations

import numpy as np
import pytest

from game import transforms
from game.render.renderer import Renderer, View
from game.scene import parse_scene
from game.scene.geometry import pack
from game.shadows import crowd
from game.shadows.fit import fit_directional, fit_squares
from game.shadows.lights import LightShadows
from game.shadows.plan import (
    CHARACTER_DENSITY_FLOOR,
    KIND_CHARACTER,
    KIND_CLUMP,
    ShadowSettings,
)
from tests.helpers import ACCURACY_SIZE as SIZE
from tests.helpers import MAX_ERROR, TINY
from tests.shadow_check import render_and_check

TINY_TEXT = TINY.read_text()
DOWN_SUN = np.array([-0.4, -1.0, -0.3]) / np.linalg.norm([-0.4, -1.0, -0.3])


def overlaps(a: crowd.CrowdMap, b: crowd.CrowdMap) -> bool:
    slot_a, slot_b = crowd.pow2_at_least(a.resolution), crowd.pow2_at_least(b.resolution)
    return (a.layer == b.layer
            and a.origin[0] < b.origin[0] + slot_b and b.origin[0] < a.origin[0] + slot_a
            and a.origin[1] < b.origin[1] + slot_b and b.origin[1] < a.origin[1] + slot_a)


# -- packing -----------------------------------------------------------------------------------
@pytest.mark.parametrize("layer_resolution", [1024, 1000])
def test_pack_places_every_map_inside_its_layer_and_none_over_another(layer_resolution):
    rng = np.random.default_rng(5)
    sizes = [int(s) for s in rng.choice([32, 64, 128, 256, 512, 300], 60)]
    maps = [crowd.CrowdMap([k], s) for k, s in enumerate(sizes)]
    square = crowd.layer_square(layer_resolution)
    need = sum(crowd.pow2_at_least(s) ** 2 for s in sizes)
    layers = -(-need // square ** 2)
    assert crowd.pack(maps, layers, layer_resolution) == 0
    assert [m.resolution for m in maps] == sizes
    for m in maps:
        assert 0 <= m.layer < layers
        assert m.origin[0] + m.resolution <= square and m.origin[1] + m.resolution <= square
    assert not any(overlaps(a, b) for k, a in enumerate(maps) for b in maps[k + 1:])


def test_pack_halves_the_largest_maps_when_the_layers_are_short():
    maps = [crowd.CrowdMap([k], 512) for k in range(6)]  # one 1024^2 layer holds four
    shrunk = crowd.pack(maps, 1, 1024)
    assert shrunk == 3
    assert sorted(m.resolution for m in maps) == [256, 256, 256, 512, 512, 512]
    assert not any(overlaps(a, b) for k, a in enumerate(maps) for b in maps[k + 1:])


# -- sizes ---------------------------------------------------------------------------------------
def test_sizes_are_powers_of_two_in_range_and_do_not_flicker():
    planner = crowd.CrowdPlanner(32, 512)
    assert planner.sizes(["a", "b", "c"], np.array([10.0, 70.0, 1e9])) == [32, 128, 512]
    # A need that wobbles about a power of two moves the size once, not every frame.
    sizes = [planner.sizes(["a"], np.array([need]))[0]
             for need in (60.0, 66.0, 62.0, 65.0, 63.0, 64.5, 61.0)]
    assert sizes == [64, 128, 128, 128, 128, 128, 128]
    # Well under the smaller size, it shrinks.
    assert planner.sizes(["a"], np.array([40.0])) == [64]
    planner.forget({"b"})
    assert planner.sizes(["a"], np.array([40.0])) == [64]  # forgotten: sized afresh


# -- skipping --------------------------------------------------------------------------------------
def swept_samples(centre, radius, direction, ground, n=400, rng=None):
    """Points of the shadow volume: inside the sphere, swept along the light to the ground."""
    rng = rng or np.random.default_rng(0)
    d = rng.normal(size=(n, 3))
    p = centre + radius * d / np.linalg.norm(d, axis=1, keepdims=True) * rng.uniform(0, 1, (n, 1))
    t = (p[:, 1] - ground) / -direction[1]
    return p + direction * (t * rng.uniform(0, 1, n))[:, None]


def test_a_character_is_skipped_only_when_no_point_of_its_shadow_is_in_view():
    rng = np.random.default_rng(6)
    eye, target = np.array([0.0, 6.0, 10.0]), np.zeros(3)
    view = transforms.look_at(eye, target)
    proj = transforms.perspective(60.0, 16 / 9, 0.1, 100.0)
    vp = proj @ view
    centres = np.column_stack([rng.uniform(-60, 60, 300), np.full(300, 0.9),
                               rng.uniform(-60, 60, 300)])
    radii = np.full(300, 0.9)
    volumes, bounded = crowd.shadow_volumes(centres, radii, DOWN_SUN, None, 0.0)
    skipped = bounded & crowd.outside_view(volumes, vp)
    assert 50 < skipped.sum() < 290
    for c, r, skip in zip(centres, radii, skipped, strict=True):
        if skip:
            pts = swept_samples(c, r, DOWN_SUN, 0.0, rng=rng)
            clip = np.c_[pts, np.ones(len(pts))] @ vp.T
            inside = np.all(np.abs(clip[:, :3]) <= clip[:, 3:4], axis=1) & (clip[:, 3] > 0)
            assert not inside.any(), c
    # A light from below the horizon of the character: its shadow is unbounded, never skipped.
    _, bounded_up = crowd.shadow_volumes(centres[:3], radii[:3],
                                         np.array([0.0, 0.2, -1.0]), None, 0.0)
    assert not bounded_up.any()


def test_a_shadow_that_reaches_into_view_keeps_its_map():
    """Behind the camera, but under a low sun its shadow runs forward into the view."""
    eye = np.array([0.0, 2.0, 10.0])
    vp = transforms.perspective(60.0, 16 / 9, 0.1, 100.0) @ transforms.look_at(eye, np.zeros(3))
    low = np.array([0.0, -0.2, -1.0]) / np.linalg.norm([0.0, -0.2, -1.0])
    behind = np.array([[0.0, 0.9, 13.0]])
    for sun, seen in ((low, True), (np.array([0.0, -1.0, 0.0]), False)):
        volumes, bounded = crowd.shadow_volumes(behind, np.array([0.9]), sun,
                                                None, 0.0)
        assert bool(~(bounded & crowd.outside_view(volumes, vp))[0]) == seen


# -- grouping --------------------------------------------------------------------------------------
def test_overlapping_footprints_share_a_map_at_the_finer_texels_and_a_lone_one_keeps_its_own():
    rects = np.array([[0.0, 0.0, 1.8, 1.8], [0.5, 0.3, 2.3, 2.1], [30.0, 30.0, 31.8, 31.8],
                      [34.0, 30.0, 35.8, 31.8]])
    sizes = [64, 32, 64, 64]
    maps = crowd.group(sizes, rects, 512)
    # The first two overlap: one 128^2 map costs less than 64^2 + 32^2 and a map's fixed cost.
    # The last two lie 2 m apart: one map for both would need 256^2.
    assert sorted(sorted(m.members) for m in maps) == [[0, 1], [2], [3]]
    pair = next(m for m in maps if len(m.members) == 2)
    assert pair.texel == pytest.approx(1.8 / (64 - crowd.SPARE_TEXELS))  # the finer member's
    cx, cy, half = pair.square
    assert cx - half <= 0.0 and cx + half >= 2.3 and cy - half <= 0.0 and cy + half >= 2.1
    assert 2 * half / pair.texel + crowd.SPARE_TEXELS <= pair.resolution == 128
    assert all(m.texel is None and m.resolution == 64 for m in maps if len(m.members) == 1)


def test_the_sweep_finds_every_near_pair_that_comparing_all_pairs_finds():
    rng = np.random.default_rng(3)
    for n in (0, 1, 2, 40, 300):
        centre = rng.uniform(-30, 30, (n, 2))
        reach = rng.uniform(0.2, 3.0, n)
        i, j, gap = crowd.near_pairs(centre, reach)
        apart = np.linalg.norm(centre[:, None] - centre[None], axis=2)
        every = apart - reach[:, None] - reach[None]
        want = {(a, b) for a in range(n) for b in range(a + 1, n)
                if every[a, b] < 2.0 * max(reach[a], reach[b])}
        assert set(zip(i.tolist(), j.tolist(), strict=True)) == want
        assert np.allclose(gap, every[i, j])


def test_more_characters_than_map_records_are_merged_never_dropped():
    rng = np.random.default_rng(7)
    xy = rng.uniform(-50, 50, (20, 2))
    rects = np.concatenate([xy - 0.9, xy + 0.9], axis=1)
    maps = crowd.group([128] * 20, rects, 512, max_maps=5)
    assert len(maps) == 5
    assert sorted(k for m in maps for k in m.members) == list(range(20))


def test_a_frames_fits_at_once_equal_the_fits_one_by_one():
    """fit_squares (a frame's character maps in one go) gives each map the fit that
    fit_directional gives it alone: same snapped square, texel, depth range."""
    rng = np.random.default_rng(11)
    rot = transforms.light_rotation(np.array([-0.4, -1.0, -0.3]))
    n = 12
    points = [rng.uniform(-20, 20, 3) + rng.uniform(-0.5, 0.5, (8, 3)) for _ in range(n)]
    q = [p @ rot.T for p in points]
    centres = np.array([(x.min(axis=0) + x.max(axis=0))[:2] / 2 for x in q])
    halves = np.array([0.75 * (x.max(axis=0) - x.min(axis=0))[:2].max() for x in q])
    sizes = rng.choice([32, 64, 128, 512], n)
    texels = np.where(np.arange(n) % 2 == 0, np.nan, 2.5 * halves / (sizes - 3))
    together = fit_squares(rot, centres, halves, np.array([x[:, 2].min() for x in q]),
                           np.array([x[:, 2].max() for x in q]), sizes, texels)
    for k in range(n):
        alone = fit_directional(points[k], rot, int(sizes[k]), float(halves[k]),
                                texel=None if np.isnan(texels[k]) else float(texels[k]),
                                centre=centres[k])
        assert np.allclose(together[k].view_proj, alone.view_proj, rtol=1e-12, atol=1e-12)
        assert np.allclose(together[k].rect, alone.rect)
        assert together[k].texel == pytest.approx(alone.texel)
        assert (together[k].near, together[k].far) == pytest.approx((alone.near, alone.far))


# -- frames ----------------------------------------------------------------------------------------
def scene_with(characters: list[tuple[list, float, float]]):
    """tiny.toml with these extra characters: (path, speed, phase) each."""
    text = TINY_TEXT
    for path, speed, phase in characters:
        text += (f'\n[[character]]\nshape = "capsule"\nradius = 0.3\nheight = 1.8\n'
                 f"path = {path}\nspeed = {speed}\nphase = {phase}\n")
    return parse_scene(text, TINY, TINY.parent)


def test_walkers_that_meet_and_part_cast_their_shadows_in_and_out_of_a_group(ctx):
    """Two walkers pass each other: grouped while close, apart before and after. At every
    step each shadow is where Embree puts it: no stale map, no missing member."""
    scene = scene_with([("[[-3.5, 0.9, 1.5], [3.5, 0.9, 1.5]]", 1.0, 0.0),
                        ("[[3.5, 0.9, 1.9], [-3.5, 0.9, 1.9]]", 1.0, 0.0)])
    # At 1 texel per pixel, and a density floor under that (a low density target, which sets
    # the floor; the one clump's map is much finer than the target anyway), the walkers' maps
    # are small enough to share one when they meet.
    settings = ShadowSettings(character_texels_per_pixel=1.0, texels_per_metre=16.0)
    renderer = Renderer(ctx, scene, SIZE, settings, gbuffer=True)
    try:
        grouped = []
        for t in np.linspace(0.0, 7.0, 15):
            frame, err = render_and_check(renderer, float(t))
            assert err["error"] <= MAX_ERROR, (t, err["error"], err["misclassified"])
            grouped.append(frame.characters.grouped)
            drawn = sorted(o for m in renderer.last_plan.maps for o in m.objects
                           if m.kind == KIND_CHARACTER)
            assert drawn == [renderer.geom.character_object(i) for i in range(3)], t
        assert max(grouped) >= 2 and min(grouped) == 0, grouped
    finally:
        renderer.release()


def test_a_character_whose_shadow_cannot_be_seen_gets_no_map_and_changes_no_pixel(ctx):
    far = ("[[0.0, 0.9, 40.0]]", 1.0, 0.0)  # behind the camera (at z = 10), sun from above
    frames = []
    for scene in (scene_with([far]), scene_with([])):
        renderer = Renderer(ctx, scene, SIZE, gbuffer=True)
        try:
            frame = renderer.render(1.0, View.from_camera(scene.camera, SIZE))
            frames.append(frame)
        finally:
            renderer.release()
    with_far, without = frames
    assert with_far.characters.skipped == 1
    assert with_far.characters.maps == without.characters.maps == 1
    assert np.array_equal(with_far.gbuffer["lit"], without.gbuffer["lit"], equal_nan=True)
    assert np.array_equal(with_far.image, without.image)


def test_character_maps_follow_the_view(ctx):
    """The same walker needs a finer map seen from near than from far; capped by the most.
    (A low density target keeps the density floor out of the way.)"""
    scene = scene_with([])
    settings = ShadowSettings(character_texels_per_pixel=4.0, texels_per_metre=16.0)
    renderer = Renderer(ctx, scene, SIZE, settings, gbuffer=True)
    try:
        sizes = []
        for distance in (40.0, 10.0, 2.5):
            eye = np.array([0.0, 0.6, 1.0]) * distance
            view = View(transforms.look_at(eye, np.zeros(3)), View.from_camera(
                scene.camera, SIZE).proj)
            renderer.render(0.0, view)
            sizes += [m.viewport for m in renderer.last_plan.maps if m.kind == KIND_CHARACTER]
        assert sizes[0] < sizes[1] <= sizes[2] <= 512, sizes
    finally:
        renderer.release()


def _far_view(scene) -> View:
    """The scene camera's lens 60 m from the origin, looking at it from above and the side."""
    eye = np.array([0.0, 0.6, 1.0]) * 60.0
    return View(transforms.look_at(eye, np.zeros(3)), View.from_camera(scene.camera, SIZE).proj)


def test_a_distant_character_map_keeps_half_the_clump_maps_density(ctx):
    """Far from the camera a walker needs few texels per pixel, but its map is never coarser
    than CHARACTER_DENSITY_FLOOR times the clump maps' texels per metre."""
    scene = scene_with([])
    view = _far_view(scene)
    sizes = {}
    for floor_density in (8.0, 96.0):
        settings = ShadowSettings(character_texels_per_pixel=1.0,
                                  texels_per_metre=floor_density / CHARACTER_DENSITY_FLOOR)
        renderer = Renderer(ctx, scene, SIZE, settings, gbuffer=True)
        try:
            renderer.render(0.0, view)
            maps = [m for m in renderer.last_plan.maps if m.kind == KIND_CHARACTER]
            radius = renderer.geom.character_radius[0]
        finally:
            renderer.release()
        assert len(maps) == 1
        sizes[floor_density] = maps[0].viewport
        assert maps[0].viewport >= 2.0 * radius * floor_density, (floor_density, sizes)
    assert sizes[8.0] < sizes[96.0], sizes


def test_the_density_floor_follows_the_clump_maps_where_the_budget_holds_them_coarser(ctx):
    """Clump maps that cannot meet the density target set the floor at their own density: a
    distant walker's map is not made finer than the statics' shadows around it."""
    scene = scene_with([])
    view = _far_view(scene)
    settings = ShadowSettings(character_texels_per_pixel=1.0, texels_per_metre=400.0,
                              clump_resolution=256, budget_mib=0.75)
    renderer = Renderer(ctx, scene, SIZE, settings)
    try:
        renderer.render(0.0, view)
        plan = renderer.last_plan
        reached = 1.0 / np.median([m.fit.texel for m in plan.maps if m.kind == KIND_CLUMP])
        maps = [m for m in plan.maps if m.kind == KIND_CHARACTER]
        radius = renderer.geom.character_radius[0]
    finally:
        renderer.release()
    assert reached < settings.texels_per_metre / 2
    assert len(maps) == 1
    # The target's floor would ask 2 r 200 texels: the largest map, 256^2.
    assert 2.0 * radius * reached * CHARACTER_DENSITY_FLOOR <= maps[0].viewport < 256


def _ring(kind: str, height: float, camera: str = "[0.0, 0.0, 0.0]"):
    """Forty walkers standing in a ring 4 m around a lamp of ``kind`` at ``height``."""
    aim = 'direction = [0.0, -1.0, 0.0]\ncone = 170.0\n' if kind == "spot" else ""
    walkers = "".join(
        f'[[character]]\nshape = "capsule"\nradius = 0.3\nheight = 1.8\n'
        f"path = [[{4 * np.cos(a):.3f}, 0.9, {4 * np.sin(a):.3f}]]\nspeed = 0.0\n\n"
        for a in np.linspace(0.0, 2 * np.pi, 40, endpoint=False))
    return parse_scene(
        f'name = "ring"\n[camera]\nposition = [0.0, 12.0, 12.0]\ntarget = {camera}\n'
        f'[[light]]\nkind = "{kind}"\nposition = [0.0, {height}, 0.0]\n{aim}\n'
        '[[floor]]\nshape = "box"\nsize = [30.0, 0.2, 30.0]\nposition = [0.0, -0.1, 0.0]\n\n'
        '[[static]]\nshape = "box"\nsize = [1.0, 1.0, 1.0]\nposition = [10.0, 0.5, 10.0]\n\n'
        + walkers)


@pytest.mark.parametrize("kind", ["point", "spot"])
def test_walkers_that_share_a_lamps_map_for_want_of_records_all_lie_in_it(kind):
    """Walkers in a ring around a lamp, with too few map records for one map each: walkers
    must share maps. A shared map is one frustum from the lamp, so its walkers must be
    neighbours seen from it; walkers on either side of the lamp in one map fall outside its
    frustum, and their shadows are lost (random scene 88, whose near walkers left wedges
    lit). The point lamp is at the walkers' chests, so that no frustum holds two opposite."""
    scene = _ring(kind, 2.5 if kind == "spot" else 1.2)
    geom = pack(scene)
    shadows = LightShadows(geom, scene.lights, ShadowSettings(), 64, 24)
    models = np.stack([c.model_matrix(0.0) for c in scene.characters])
    plan, _ = shadows.plan(models)
    maps = [m for m in plan.maps if m.kind == KIND_CHARACTER]
    assert 4 < len(maps) < len(scene.characters), len(maps)  # shared, for want of records
    first = geom.character_object(0)
    held = []
    for m in maps:
        for o in m.objects:
            pts = geom.character_points[o - first]
            world = pts @ models[o - first][:3, :3].T + models[o - first][:3, 3]
            clip = np.c_[world, np.ones(len(world))] @ m.fit.view_proj.T
            held.append(bool((clip[:, 3] > 0).all()
                             and (np.abs(clip[:, :2]) <= clip[:, 3:4] * (1 + 1e-6)).all()))
    assert len(held) == len(scene.characters) and all(held), held


def test_a_lamps_walkers_whose_shadows_the_view_cannot_see_get_no_map():
    """The camera looks at the sky: a spot lamp over the ring shadows nothing it sees, so no
    walker is shown and none gets a map (an empty crowd is planned without a failure)."""
    scene = _ring("spot", 2.5, camera="[0.0, 40.0, -30.0]")
    shadows = LightShadows(pack(scene), scene.lights, ShadowSettings(), 64, 24)
    models = np.stack([c.model_matrix(0.0) for c in scene.characters])
    plan, _ = shadows.plan(models, View.from_camera(scene.camera, (320, 180)))
    assert not [m for m in plan.maps if m.kind == KIND_CHARACTER]
