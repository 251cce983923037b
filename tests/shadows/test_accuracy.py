"""Shadow accuracy against an independent reference: Embree shadow rays on the dumped frames.

Each scene is captured headless with dumps (docs/reference.md section 3); the reference reads only
the dump files (game/reference/hard.py), never the renderer. The bar: misclassified pixels /
pixels shadowed by the method or the reference, over pixels with N.L > 0.1, at most 5% at
320x180.
"""

from pathlib import Path

import numpy as np
import pytest

from game.app import capture, outputs
from game.reference import hard as reference
from game.scene import load_scene
from game.shadows.plan import ShadowSettings
from tests.conftest import ACCURACY_SCENES, MAX_ERROR
from tests.conftest import ACCURACY_SIZE as SIZE

pytest.importorskip("embreex", reason="the Embree reference needs embreex (pip install .[test])")

MIN_SHADOWED = 200  # a scene must really have shadows in view for the ratio to mean anything


def capture_errors(ctx, scene, settings, out: Path, frames=2, fps=1.5) -> list[dict]:
    opts = capture.CaptureOptions(out=out, frames=frames, size=SIZE, fps=fps, dump=True,
                                  settings=settings)
    capture.run(ctx, scene, opts)
    errors = []
    for k in range(frames):
        frame = reference.load_frame(out / f"frame_{k:04d}.npz")
        mesh = reference.load_geometry(out / f"frame_{k:04d}.glb")
        exact = reference.hard_visibility(mesh, frame["position"], frame["normal"],
                                          scene.light)
        err = reference.shadow_error(frame["lit"], exact, frame["position"], frame["normal"],
                                     scene.light)
        # Saved for a person to look at: red = misclassified, green = lit by the method.
        diff = np.zeros((*err["mask"].shape, 3), np.uint8)
        diff[..., 0] = err["mask"] * 255
        diff[..., 1] = (np.nan_to_num(frame["lit"]) * 110).astype(np.uint8)
        outputs.write_png(out / f"diff_{k:04d}.png", diff)
        errors.append(err)
    return errors


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
