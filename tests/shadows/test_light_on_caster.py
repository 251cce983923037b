"""A lamp on a caster's surface: on a box's corner, edge or face (a lamp on a wall's corner).

The light's own position is then a vertex (or a point) of the caster, where no direction from
the light is defined. Every method must plan finite maps and shadow the other casters right,
against Embree, with both clumpings and with a range.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from game.render.renderer import Renderer, View
from game.scene import Light, load_scene
from game.shadows import clumping
from game.shadows.fit import MIN_NEAR_SHARE, fit_spot
from game.shadows.light_kinds import kind_of
from game.shadows.plan import ShadowSettings
from tests.helpers import ACCURACY_SIZE as SIZE
from tests.helpers import MAX_ERROR, TINY

pytest.importorskip("embreex", reason="the Embree reference needs embreex (pip install .[test])")

# tiny.toml's box: 1.5 x 2 x 1 at (-0.5, 1, -0.5), so x -1.25..0.25, y 0..2, z -1..0.
PLACES = {
    "top corner": [0.25, 2.0, 0.0],
    "far top corner": [-1.25, 2.0, -1.0],
    "bottom corner": [0.25, 0.0, 0.0],
    "top edge": [-0.5, 2.0, 0.0],
    "side edge": [0.25, 1.0, 0.0],
    "top face": [-0.5, 2.0, -0.5],
    "side face": [0.25, 1.0, -0.5],
}


def _light(kind: str, place: str, range_: float | None = None) -> Light:
    position = np.array(PLACES[place], float)
    if kind == "spot":  # aimed down and out, over the sphere and the floor
        direction = np.array([0.5, -1.0, 0.4]) / np.linalg.norm([0.5, -1.0, 0.4])
        return Light("spot", direction, position, 120.0, range=range_)
    return Light("point", None, position, None, range=range_)


def _off_the_box(light: Light) -> Light:
    """The light a millimetre out of the box. Embree's rays toward a light on the box end on
    the box, so at the light's own place every ray counts as blocked; a hair outside, they show
    what the lamp lights."""
    box_centre = np.array([-0.5, 1.0, -0.5])
    out = light.position - box_centre
    out[1] = abs(out[1])  # up off the floor the box stands on, not into it
    return dataclasses.replace(light, position=light.position + 1e-3 * out / np.linalg.norm(out))


def _check(ctx, light: Light, settings: ShadowSettings, t: float = 1.0) -> None:
    from game.reference.score import score_frame
    from tests.shadow_check import occluders, render_and_check

    scene = load_scene(TINY)
    scene.light = light
    renderer = Renderer(ctx, scene, SIZE, settings, gbuffer=True)
    try:
        frame, _ = render_and_check(renderer, t)  # asserts: no NaN in the G-buffer
        g = frame.gbuffer
        err = score_frame(g["lit"], g["position"], g["normal"], occluders(scene, t),
                          _off_the_box(light))
        plan = renderer.method.plan(renderer.models(t), View.from_camera(scene.camera, SIZE))
        assert plan.maps
        for m in plan.maps:
            assert np.all(np.isfinite(m.fit.view_proj)), m.name
        assert frame.image.any()
        # A lamp on the floor's level grazes the floor: little is lit, so little is shadowed.
        assert err["shadowed"] >= (0 if light.position[1] == 0.0 else 100)
        assert err["error"] <= MAX_ERROR, (err["error"], err["misclassified"], err["shadowed"])
    finally:
        renderer.release()


@pytest.mark.parametrize("place", list(PLACES))
@pytest.mark.parametrize("kind", ["point", "spot"])
def test_a_lamp_on_a_box_is_planned_and_shadows_right(ctx, kind, place):
    _check(ctx, _light(kind, place), ShadowSettings())


@pytest.mark.parametrize("clumps", ["light", "world"])
@pytest.mark.parametrize("range_", [None, 12.0])
def test_a_point_light_on_a_corner_with_both_clumpings_and_a_range(ctx, clumps, range_):
    light = _light("point", "top corner", range_)
    _check(ctx, light, ShadowSettings(clumping=clumps))
    _check(ctx, light, ShadowSettings(clumping=clumps, clump_count=1))


@pytest.mark.parametrize("method", ["single", "static-dynamic", "csm"])
@pytest.mark.parametrize("kind", ["point", "spot"])
def test_the_baselines_with_a_lamp_on_a_corner(ctx, method, kind):
    _check(ctx, _light(kind, "top corner"), ShadowSettings(method=method))


def test_the_point_footprint_skips_only_the_light_itself():
    """The box's footprint from its own corner is the octant the other seven corners span."""
    scene = load_scene(TINY)
    light = _light("point", "top corner")
    box = np.asarray(scene.statics[0].mesh.vertices, float)
    footprint, _ = kind_of(light).footprint(light, [box])
    rects, _ = clumping.object_summaries([box], footprint)
    others = box[np.any(box != light.position, axis=1)]
    expected, _ = clumping.object_summaries([others], footprint)
    assert np.all(np.isfinite(rects)) and np.array_equal(rects, expected)
    # With one object entirely away from the light, nothing changes.
    moved = box + np.array([5.0, 0.0, 0.0])
    plain, _ = clumping.object_summaries([moved], footprint)
    assert np.all(np.isfinite(plain))


def test_a_caster_reaching_behind_a_spot_keeps_its_part_nearest_the_lamp():
    """A slab whose corners lie behind the spot's plane and nearly three metres before it:
    its triangles cross every depth in front of the lamp, so the map's near plane lies at the
    nearest it may, not at the nearest corner in front (tests/scenes/spot_slab.toml, where
    that corner's near plane left 9% of the shadowed floor lit)."""
    eye = np.zeros(3)
    slab = np.array([[-3.0, 1.0, -1.0], [3.0, 1.0, -1.0], [-3.0, -2.0, 2.0], [3.0, -2.0, 2.0]])
    down_forward = np.array([0.0, -1.0, 1.0]) / np.sqrt(2.0)
    fit = fit_spot(slab, eye, down_forward, 120.0, 1024)
    depths = slab @ down_forward
    assert depths.min() < 0.0 < 0.5 < depths[depths > 0].min()
    assert fit.near <= MIN_NEAR_SHARE * fit.far * 1.01, (fit.near, fit.far)
    # A caster wholly in front keeps its near plane at its nearest corner, less a margin.
    ahead = slab + 3.0 * down_forward
    near = (ahead @ down_forward).min()
    assert 0.9 * near < fit_spot(ahead, eye, down_forward, 120.0, 1024).near < near


def test_a_caster_that_is_only_the_light_is_refused_in_words():
    light = _light("point", "top corner")
    footprint, _ = kind_of(light).footprint(light, [])
    with pytest.raises(ValueError, match="not finite"):
        clumping.object_summaries([np.array([light.position])], footprint)


def test_capture_of_a_lamp_on_a_corner_runs(capsys, tmp_path):
    from tests.cli.cli_helpers import run_main

    text = TINY.read_text().replace(
        'kind      = "directional"\ndirection = [-0.4, -1.0, -0.3]',
        'kind = "point"\nposition = [0.25, 2.0, 0.0]\nrange = 12.0')
    assert 'kind = "point"' in text
    path = tmp_path / "corner.toml"
    path.write_text(text)
    code, lines = run_main(capsys, "capture", path, "--size", "64x36", "--out", tmp_path / "o")
    assert code == 0, lines
    assert not any(line.startswith(("error", "internal", "warning")) for line in lines), lines
