"""Saying when accuracy collapses (game/shadows/collapse.py): a shadow texel's width on screen
where its map's shadows are seen nearest the camera, checked by hand, and one note per light
whose plan falls far short of its target, none where it holds it."""

from __future__ import annotations

import dataclasses
import re
from types import SimpleNamespace

import numpy as np
import pytest

from game import transforms
from game.render.renderer import Renderer, View
from game.scene import load_scene
from game.scene.geometry import pack
from game.scene.model import Light
from game.shadows import collapse
from game.shadows.fit import fit_squares
from game.shadows.methods.cascaded import CascadedShadows
from game.shadows.methods.single import SingleShadows
from game.shadows.methods.static_dynamic import StaticDynamicShadows
from game.shadows.plan import KIND_ALL, MapRecord, ShadowSettings
from tests.helpers import SCENES

SIZE = (960, 540)
FLOOR = collapse.Receivers(np.array([[-50.0, -0.1, -50.0, 50.0, 0.0, 50.0]]), np.array([0]))
BASELINE = SimpleNamespace(settings=ShadowSettings(method="single"))  # aims at 1 px a texel


def down_map(texel: float, resolution: int = 1024) -> MapRecord:
    """A map of a straight-down sun, ``texel`` metres a texel, centred on the origin."""
    rot = transforms.light_rotation(np.array([0.0, -1.0, 0.0]))
    half = 0.5 * (resolution - 3) * texel
    fit = fit_squares(rot, np.zeros((1, 2)), np.array([half]), np.array([-1.0]),
                      np.array([1.0]), np.array([resolution]), np.array([texel]))[0]
    return MapRecord("m", KIND_ALL, fit, 0, resolution, [0])


def camera(eye, target, height: int = 1000, fov: float = 90.0) -> View:
    return View(transforms.look_at(np.array(eye, float), np.array(target, float)),
                transforms.perspective(fov, 1.0, 0.1, 500.0), (height, height))


def test_pixels_per_metre_by_hand():
    # 90 degrees over 1000 pixels: at 10 m the view is 20 m tall, 50 pixels a metre.
    assert collapse.pixels_per_metre(camera([0, 10, 0], [0, 0, 0]), 10.0) == pytest.approx(50.0)


@pytest.mark.parametrize(("height", "texel", "pixels"), [
    (10.0, 0.01, 0.5),    # 1 cm texels at 50 px/m
    (2.5, 0.01, 2.0),     # 200 px/m
    (10.0, 0.1, 5.0),     # 10 cm texels: past 4x the 1 px target
])
def test_texel_on_screen_by_hand(height, texel, pixels):
    """A camera looking straight down at the floor from ``height``: every floor point is at
    that view depth, so a texel spans texel * 500 / height pixels."""
    depths = collapse.ViewDepths(FLOOR, camera([0, height, 0], [0, 0, 0]))
    [seen] = collapse.map_texels(BASELINE, [down_map(texel)], 0, depths)
    assert seen.depth == pytest.approx(height)
    assert seen.pixels == pytest.approx(pixels, rel=1e-6)
    assert seen.target == 1.0
    assert seen.collapsed == (pixels > collapse.COLLAPSE_FACTOR)


def test_nearest_receiver_is_where_the_view_meets_the_floor():
    """Looking level from 2 m with a 90 degree view, the lowest ray meets the floor 2 m ahead:
    the nearest receiver is at view depth 2, not at the near plane under the camera's feet."""
    depths = collapse.ViewDepths(FLOOR, camera([0, 2, 0], [0, 2, -10]))
    depth, point = depths.nearest(down_map(0.01))
    assert depth == pytest.approx(2.0)
    assert point[1] == pytest.approx(0.0, abs=1e-9)


def test_the_nearest_receiver_in_a_map_is_what_every_plane_together_gives():
    """The nearest receiver drops the view's and the map's planes that hold a whole box; with
    every plane kept, each box in turn, the least depth is the same."""
    rng = np.random.default_rng(4)
    lo = rng.uniform(-12.0, 12.0, (40, 3)) * [1.0, 0.2, 1.0]
    boxes = np.concatenate([lo, lo + rng.uniform(0.2, 6.0, (40, 3))], axis=1)
    receivers = collapse.Receivers(boxes, np.arange(40))
    record = down_map(0.02, 512)
    for eye, target in (([0, 6, 14], [0, 0, 0]), ([9, 2, 3], [-4, 1, -6]),
                        ([-3, 20, -2], [1, 0, 1])):
        view = camera(eye, target)
        depths = collapse.ViewDepths(receivers, view)
        frustum = collapse.clip_planes(view.proj @ view.view)
        planes = np.concatenate([collapse.box_planes(boxes),
                                 np.broadcast_to(np.concatenate(
                                     [frustum, collapse.region_planes(record)]),
                                     (40, 5 + len(frustum), 4))], axis=1)
        every, _ = collapse.nearest_vertices(planes, -np.asarray(view.view[2], float))
        depth, _ = depths.nearest(record)
        assert np.isfinite(depth)
        assert depth == pytest.approx(every.min(), rel=1e-9)


def test_a_map_away_from_the_view_is_not_judged():
    """Receivers out of the map's rectangle do not count: a map 100 m behind the camera has
    no receiver in view."""
    record = down_map(0.01, 64)
    moved = camera([0, 2, 100], [0, 2, 200])
    assert collapse.map_texels(BASELINE, [record], 0, collapse.ViewDepths(FLOOR, moved)) == []


def collapse_lines(notes: list[str]) -> list[str]:
    return [n for n in notes if "accuracy collapses" in n]


def frame_notes(ctx, scene, settings: ShadowSettings) -> tuple[list[str], list[str]]:
    renderer = Renderer(ctx, scene, SIZE, settings)
    try:
        renderer.render(0.0, View.from_camera(scene.camera, SIZE), read=False)
        return renderer.collapse_notes(), renderer.notes
    finally:
        renderer.release()


def test_courtyard_at_the_defaults_holds_its_target(ctx, courtyard):
    for method in ("clumped", "single"):
        own, notes = frame_notes(ctx, courtyard, ShadowSettings(method=method))
        assert own == [] and collapse_lines(notes) == []


def test_a_tiny_budget_collapses_once(ctx, courtyard):
    own, notes = frame_notes(ctx, courtyard, ShadowSettings(budget_mib=0.25))
    assert len(own) == 1 and collapse_lines(notes) == own
    found = re.search(r"^light 0: clumped: .* shadow texels are ([\d.]+) screen pixels wide "
                      r"near the camera \(target ([\d.]+),", own[0])
    assert found, own[0]
    assert float(found[1]) > collapse.COLLAPSE_FACTOR * float(found[2])
    assert "statics (static_0" in own[0]


def test_one_note_per_light(ctx):
    """Three lights, each with a sliver of a tiny budget: the sun's and the point lamp's maps
    collapse, one note each."""
    scene = load_scene(SCENES / "lamps.toml")
    own, _ = frame_notes(ctx, scene, ShadowSettings(budget_mib=0.25))
    lights = [int(re.match(r"light (\d+): ", note)[1]) for note in own]
    assert lights[:2] == [0, 1] and len(set(lights)) == len(lights)


@pytest.mark.parametrize("method", [SingleShadows, StaticDynamicShadows])
def test_a_baselines_map_of_the_statics_says_when_it_holds_too_few_texels_per_metre(method):
    """tiny.toml's sun map at 1024^2: a note in the texels per metre it holds where clumped's
    target asks four times as many or more, none at the default target, none for a lamp."""
    scene = load_scene(SCENES / "tiny.toml")
    geom = pack(scene)
    plain = method(geom, scene.light, ShadowSettings(single_resolution=1024), 64)
    models = np.repeat(np.eye(4)[None], geom.n_characters, 0)
    texel = plain.plan(models).maps[0].fit.texel
    assert not plain.notes
    density = 1.0 / texel
    asked = ShadowSettings(single_resolution=1024, texels_per_metre=4.0 * density * 1.01)
    noted = method(geom, scene.light, asked, 64)
    assert noted.notes == [
        f"its 1024^2 map holds {density:.3g} texels/m over the statics, where clumped aims for "
        f"{asked.texels_per_metre:g}: texels {100.0 / density:.0f} cm wide move every "
        f"shadow's edge and lose the shadows of details under them"], noted.notes
    just = ShadowSettings(single_resolution=1024, texels_per_metre=4.0 * density * 0.99)
    assert not method(geom, scene.light, just, 64).notes
    lamp = Light(kind="point", direction=None, position=np.array([0.0, 6.0, 0.0]), cone=None,
                 range=None)
    assert not method(geom, lamp, asked, 64).notes
    # A light turned refits the map: its note is said again for the new fit, not beside the
    # old one, and goes when the light is a lamp.
    far_short = method(geom, scene.light, dataclasses.replace(
        asked, texels_per_metre=40.0 * density), 64)
    turned = dataclasses.replace(scene.light, direction=np.array([0.3, -1.0, 0.2]))
    far_short.set_light(turned)
    assert len(far_short.notes) == 1 and far_short.notes[0].startswith("its 1024^2 map holds")
    far_short.set_light(lamp)
    assert far_short.notes == []


def csm_notes(scene, eye, target) -> tuple[list[str], np.ndarray]:
    """The view's notes of ``csm`` on ``scene`` seen from ``eye``, and its cascades' splits."""
    geom = pack(scene)
    cam = dataclasses.replace(scene.camera, position=np.array(eye, float),
                              target=np.array(target, float), fov=60.0)
    view = View.from_camera(cam, SIZE)
    method = CascadedShadows(geom, scene.light, ShadowSettings(method="csm"), 64)
    models = np.repeat(np.eye(4)[None], geom.n_characters, 0)
    plan = method.plan(models, view)
    return (collapse.collapse_notes([method], plan.maps, [0], view, geom, models),
            method.splits(view))


def test_csm_says_when_its_cascades_end_before_anything_in_view():
    """tiny.toml seen from 20 m up at 45 degrees: the floor's nearest point in view is on the
    frame's bottom edge, at view depth h / (sin(pitch) + tan(fov / 2) cos(pitch)), past half
    the cascades; from eye height the nearest floor is in the second cascade, and says
    nothing."""
    scene = load_scene(SCENES / "tiny.toml")
    notes, splits = csm_notes(scene, [0.0, 20.0, 20.0], [0.0, 0.0, 0.0])
    pitch = np.radians(45.0)
    nearest = 20.0 / (np.sin(pitch) + np.tan(np.radians(30.0)) * np.cos(pitch))
    first = int(np.sum(splits[1:-1] <= nearest))
    assert 2 * first >= len(splits) - 1, (nearest, splits)
    [note] = notes
    found = re.match(r"light 0: csm: nothing in view is nearer than ([\d.]+) m, so cascades "
                     r"0-(\d+), which end at ([\d.]+) m, hold no receiver, and its shadows "
                     r"take texels [\d.-]+ cm wide", note)
    assert found, note
    assert float(found[1]) == pytest.approx(nearest, rel=5e-3)   # three figures
    assert int(found[2]) == first - 1
    assert found[3] == f"{splits[first]:.3g}"
    street, splits = csm_notes(scene, [0.0, 1.7, 12.0], [0.0, 1.0, 0.0])
    assert street == [] and splits[1] < 2.68 < splits[2], splits
    lamp = dataclasses.replace(scene, lights=[Light(
        kind="point", direction=None, position=np.array([0.0, 6.0, 0.0]), cone=None,
        range=None)])
    assert csm_notes(lamp, [0.0, 20.0, 20.0], [0.0, 0.0, 0.0])[0] == []
