"""A lamp short of layers counts its clumps at the density target only as far as shows they
cannot fit (game/shadows/methods/clumped/statics.py): the clumps it makes are the same."""

from __future__ import annotations

import pytest

from game.scene import parse_scene
from game.scene.geometry import pack
from game.shadows.lights import LightShadows
from game.shadows.methods.clumped import statics
from game.shadows.plan import ShadowSettings


def _plaza(kind: str):
    """400 small boxes on a 40 m square, lit by a spot lamp low over one corner, aimed across
    it, or a point lamp low over its middle."""
    aim = 'direction = [1.0, -0.3, 1.0]\ncone = 120.0\n' if kind == "spot" else ""
    where = "[-3.0, 3.0, -3.0]" if kind == "spot" else "[20.0, 3.0, 20.0]"
    boxes = "".join(f'[[static]]\nshape = "box"\nsize = [0.5, 1.0, 0.5]\n'
                    f"position = [{2.0 * (i % 20):.1f}, 0.5, {2.0 * (i // 20):.1f}]\n\n"
                    for i in range(400))
    return parse_scene(
        f'name = "plaza"\n[camera]\nposition = [20.0, 30.0, -20.0]\ntarget = [20.0, 0.0, 20.0]\n'
        f'[[light]]\nkind = "{kind}"\nposition = {where}\n{aim}\n'
        '[[floor]]\nshape = "box"\nsize = [50.0, 0.2, 50.0]\nposition = [20.0, -0.1, 20.0]\n\n'
        + boxes)


def _plan(scene):
    shadows = LightShadows(pack(scene), scene.lights, ShadowSettings(), 6, 64)
    plan, _ = shadows.plan(None)
    return [(m.name, tuple(m.objects)) for m in plan.maps], shadows.notes


@pytest.mark.parametrize("kind", ["spot", "point"])
def test_a_lamp_short_of_layers_makes_the_same_clumps_counting_only_so_far(kind, monkeypatch):
    scene = _plaza(kind)
    counted, notes = _plan(scene)
    assert any("at least" in note and "would meet" in note for note in notes), notes
    monkeypatch.setattr(statics, "LAMP_SEARCH", 10**9)  # count every clump at the target
    every, every_notes = _plan(scene)
    assert counted == every
    assert not any("at least" in note for note in every_notes), every_notes
