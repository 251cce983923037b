"""Shadow accuracy against an independent reference: Embree shadow rays on the dumped frames.

Each scene is captured headless with dumps (docs/reference.md section 3); the reference reads only
the dump files (game/reference/hard.py), never the renderer. The bar: misclassified pixels /
pixels shadowed by the method or the reference, over pixels with N.L > 0.1, at most 5% at
320x180.
"""

import pytest

from game.scene import load_scene
from game.shadows.plan import ShadowSettings
from tests.helpers import ACCURACY_SCENES, MAX_ERROR
from tests.shadow_check import MIN_SHADOWED, capture_errors

pytest.importorskip("embreex", reason="the Embree reference needs embreex (pip install .[test])")


@pytest.mark.parametrize("name", list(ACCURACY_SCENES))
def test_clumped_matches_the_ray_traced_reference(ctx, name, tmp_path):
    scene = load_scene(ACCURACY_SCENES[name])
    errors = capture_errors(ctx, scene, ShadowSettings(), tmp_path)
    for k, err in enumerate(errors):
        assert err["shadowed"] >= MIN_SHADOWED, f"{name}: too few shadowed pixels to judge"
        assert err["error"] <= MAX_ERROR, (
            f"{name} frame {k}: error {err['error']:.3f} ({err['misclassified']} of "
            f"{err['shadowed']} shadowed pixels); diff image in {tmp_path}")


def test_the_reference_tells_a_coarse_map_from_a_tight_one(ctx, tmp_path, courtyard):
    # The check above could pass vacuously if the reference agreed with anything; a 256-texel
    # single map over the whole default scene must score clearly worse than clumped.
    scene = courtyard
    coarse = ShadowSettings(method="single", single_resolution=256)
    coarse_err = capture_errors(ctx, scene, coarse, tmp_path / "single", frames=1)[0]
    tight_err = capture_errors(ctx, scene, ShadowSettings(), tmp_path / "clumped",
                               frames=1)[0]
    assert coarse_err["error"] > max(2 * tight_err["error"], MAX_ERROR)
