"""A level that arrives as one mesh file is clumped by its parts (game/scene/parts.py), as well
as the same level given as separate files."""

from __future__ import annotations

import pytest

from game import transforms
from game.render.renderer import Renderer
from game.scene import load_scene
from game.shadows.plan import ShadowSettings
from tests.helpers import ACCURACY_SIZE, MAX_ERROR
from tests.shadow_check import render_and_check
from tests.shadows.level_scenes import write_level

pytest.importorskip("embreex", reason="the Embree reference needs embreex (pip install .[test])")

def test_a_level_in_one_file_gets_many_maps_and_the_accuracy_of_separate_files(ctx, tmp_path):
    from tests.shadow_check import capture_errors

    results = {}
    for as_parts in (False, True):
        path = write_level(tmp_path / ("parts" if as_parts else "one"), as_parts)
        scene = load_scene(path)
        renderer = Renderer(ctx, scene, ACCURACY_SIZE)
        try:
            maps = len(renderer.method.static_maps)
        finally:
            renderer.release()
        errors = capture_errors(ctx, scene, ShadowSettings(), tmp_path / f"frames_{as_parts}",
                                frames=1)
        results[as_parts] = maps, errors[0]["error"]
    (one_maps, one_error), (parts_maps, parts_error) = results[False], results[True]
    assert len(load_scene(tmp_path / "one" / "level.toml").statics) == 1
    # 17 buildings over 48 m at 16 m per map: many maps either way, not one for the file.
    assert one_maps >= 8 and parts_maps >= 8, results
    assert one_error <= MAX_ERROR and one_error <= parts_error + 0.01, results


def test_editing_a_level_file_re_renders_the_clumps_of_its_parts(ctx, tmp_path):
    path = write_level(tmp_path / "one", as_parts=False)
    text = path.read_text() + ('[[static]]\nshape = "box"\nsize = [2.0, 3.0, 2.0]\n'
                               'position = [35.0, 1.5, 35.0]\n')
    path.write_text(text)
    scene = load_scene(path)
    r = Renderer(ctx, scene, ACCURACY_SIZE, gbuffer=True)
    try:
        render_and_check(r)
        method = r.method
        level = r.geom.names.index("static_0")
        holding = [k for k, m in enumerate(method.static_maps) if level in m.objects]
        assert len(holding) >= 8
        # Moving the box touches only the map it leaves and the one it joins (tiles: it may
        # share a tile with parts of the level); moving the level, every map of its parts, and
        # no stale shadow is left where its houses were.
        assert 1 <= len(r.move_static("static_1", transforms.translation([1.0, 0.0, 0.0]))) <= 2
        touched = r.move_static("static_0", transforms.translation([0.0, 0.0, 3.0]))
        assert len(touched) >= len(holding)
        frame, err = render_and_check(r)
        assert frame.maps_rendered >= len(holding)
        assert err["error"] <= MAX_ERROR, err["error"]
    finally:
        r.release()


def test_a_long_thin_caster_over_compact_clumps_does_not_leak(ctx, tmp_path):
    """A 56 m beam 4 cm thick over a row of boxes. Clumped alone it took a map of its own, 5.5 cm
    a texel, and its shadow broke up on the boxes and the ground (7.9% error against Embree);
    its long faces are now drawn into the boxes' clump maps, at their texels."""
    from tests.shadow_check import capture_errors

    text = ('name = "beam"\n[camera]\nposition = [-1.0, 7.0, 6.0]\ntarget = [1.0, 3.0, 0.0]\n'
            'fov = 50.0\n[light]\nkind = "directional"\ndirection = [0.15, -1.0, 0.1]\n'
            '[[floor]]\nshape = "box"\nsize = [80.0, 0.2, 80.0]\nposition = [0.0, -0.1, 0.0]\n'
            '[[static]]\nshape = "box"\nsize = [56.0, 0.04, 0.04]\nposition = [0.0, 5.0, 0.0]\n')
    text += "".join(f'[[static]]\nshape = "box"\nsize = [3.0, 3.0, 3.0]\n'
                    f'position = [{x:.1f}, 1.5, 0.0]\n' for x in range(-24, 25, 6))
    (tmp_path / "beam.toml").write_text(text)
    scene = load_scene(tmp_path / "beam.toml")
    err = capture_errors(ctx, scene, ShadowSettings(), tmp_path / "frames", frames=1)[0]
    assert err["shadowed"] >= 200
    assert err["error"] <= MAX_ERROR, err["error"]
