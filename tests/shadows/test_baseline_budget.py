"""The baselines' depth array within a memory budget (game/shadows/budget.py).

Many point lights with no range gave ``single`` a cube of 4096² maps each: 64 lights asked the
driver for 4096²x384 layers (24 GiB), 16 lights for 6 GiB. The planners are GL-free, so the
array each would ask for is read from ``LightShadows.prepare()`` with no driver involved.
"""

from __future__ import annotations

import glob

import pytest

from game.errors import GameError
from game.gpu.limits import GLLimits
from game.scene import load_scene, parse_scene
from game.scene.geometry import pack
from game.shadows.budget import BASELINE_BUDGET_SHARE, fit_settings
from game.shadows.fit import CUBE_FACES
from game.shadows.lights import LightShadows
from game.shadows.plan import ShadowSettings, budget_of, layer_bytes
from tests.helpers import ROOT, TINY

LIMITS = GLLimits(max_texture_size=16384, max_array_layers=2048, max_maps=512)
BASELINES = ["single", "static-dynamic", "csm"]


def _lamps(count: int) -> str:
    """tiny.toml lit by ``count`` point lights with no range, on a ring above the casters."""
    text = TINY.read_text()
    start = text.index("[light]")
    end = text.index("[linear_light]")
    lamps = "".join(f'[[light]]\nkind = "point"\nposition = [{(k % 8) - 3.5}, 4.0, '
                    f'{(k // 8) - 3.5}]\nintensity = 0.05\n\n' for k in range(count))
    return text[:start] + lamps + text[end:]


def _array(text_or_path, method: str, **changes):
    scene = (load_scene(text_or_path) if not isinstance(text_or_path, str)
             else parse_scene(text_or_path, TINY, TINY.parent))
    geom = pack(scene)
    settings, notes = fit_settings(ShadowSettings(method=method, **changes), LIMITS,
                                   geom.n_characters)
    shadows = LightShadows(geom, scene.lights, settings, LIMITS.max_layers, LIMITS.max_maps)
    shape = shadows.prepare()
    return shape, layer_bytes(shape.resolution) * shape.layers, notes + shadows.notes


@pytest.mark.parametrize("count", [16, 64])
@pytest.mark.parametrize("method", BASELINES)
def test_many_point_lights_fit_the_baselines_budget(method, count):
    shape, size, notes = _array(_lamps(count), method)
    budget = BASELINE_BUDGET_SHARE * budget_of(ShadowSettings()) * 2**20
    assert size <= budget, (shape, size / 2**30)
    if method != "csm" or count == 64:  # 16 cubes of csm's 2048² fit as asked
        assert any("baselines may take" in n for n in notes), notes
        assert all("\n" not in n for n in notes)
    assert shape.resolution >= 64


def test_a_budget_nothing_fits_is_refused_in_one_line_before_the_driver():
    with pytest.raises(GameError) as caught:
        _array(_lamps(64), "single", budget_mib=0.001)
    message = str(caught.value)
    assert "\n" not in message and "MiB" in message and " need " in message, message


def test_by_default_no_light_gets_less_memory_than_the_baselines_maps_of_it():
    """Three point lights with no range: the baselines draw a cube of 4096^2 faces around
    each, 384 MiB. Clumped's 512 MiB, shared, would give each a third of that. By default the
    lights are given at least the baselines' cubes; a budget given is held to."""
    scene = parse_scene(_lamps(3), TINY, TINY.parent)
    geom = pack(scene)
    cube = CUBE_FACES * layer_bytes(ShadowSettings().single_resolution) / 2**20
    owed = LightShadows(geom, scene.lights, ShadowSettings(), LIMITS.max_layers,
                        LIMITS.max_maps)
    assert owed.budget_mib >= 3 * cube, owed.budget_mib
    held = LightShadows(geom, scene.lights, ShadowSettings(budget_mib=512.0), LIMITS.max_layers,
                        LIMITS.max_maps)
    assert held.budget_mib <= 512.0 + 1e-6 and held.array_mib <= 512.0, held.array_mib


SHIPPED = sorted(p for p in glob.glob(str(ROOT / "assets" / "*.toml"))
                 + glob.glob(str(ROOT / "tests" / "scenes" / "*.toml")) if "town_1m" not in p)


@pytest.mark.parametrize("method", BASELINES)
def test_shipped_scenes_plan_as_before_at_the_defaults(method):
    from pathlib import Path

    for path in SHIPPED:
        _, size, notes = _array(Path(path), method)
        assert not any("baselines may take" in n for n in notes), (path, notes)
        assert size <= 1024 * 2**20, path  # night_town's static-dynamic, the most: 896 MiB


def test_more_cascades_than_a_light_may_have_are_refused_in_one_line():
    scene = parse_scene(TINY.read_text(), TINY, TINY.parent)
    geom = pack(scene)
    settings = ShadowSettings(method="csm", cascades=8)
    with pytest.raises(GameError, match="csm: 8 cascades are more maps than a light may have"):
        LightShadows(geom, scene.lights, settings, 4, 4)
