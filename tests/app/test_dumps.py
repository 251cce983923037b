"""The dump writer (game/app/dumps.py) on G-buffers made by hand: ``lit_lights`` is written for
every scene, from the renderer's layers or as ``lit`` alone, and the reference reads it back."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from game.app import dumps
from game.reference.hard import load_frame
from game.scene import load_scene
from tests.helpers import TINY

H, W = 3, 4


def gbuffer(**extra: np.ndarray) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(2)
    position = rng.normal(size=(H, W, 3)).astype(np.float32)
    position[0, 0] = np.nan
    lit = rng.random((H, W)).astype(np.float32)
    lit[0, 0] = np.nan
    return {"position": position, "normal": position.copy(),
            "object": np.where(np.isnan(lit), -1, 0).astype(np.int32), "lit": lit, **extra}


def write(tmp_path, g: dict[str, np.ndarray]) -> dict:
    view = SimpleNamespace(view=np.eye(4, dtype=np.float32), proj=np.eye(4, dtype=np.float32))
    stem = tmp_path / "frame_0000"
    dumps.write_dump(stem, load_scene(TINY), view, (W, H), 0.5, SimpleNamespace(gbuffer=g))
    return load_frame(stem.with_suffix(".npz"))


def test_a_one_light_dump_holds_lit_as_its_one_layer(tmp_path):
    g = gbuffer()
    frame = write(tmp_path, g)
    assert frame["lit_lights"].shape == (H, W, 1) and frame["lit_lights"].dtype == np.float32
    np.testing.assert_array_equal(frame["lit_lights"][..., 0], g["lit"])   # NaN included


@pytest.mark.parametrize("lights", [2, 64])
def test_the_renderers_layers_are_written_as_they_are(tmp_path, lights):
    g = gbuffer()
    layers = np.random.default_rng(3).random((H, W, lights)).astype(np.float32)
    layers[..., 0] = g["lit"]
    frame = write(tmp_path, {**g, "lit_lights": layers})
    np.testing.assert_array_equal(frame["lit_lights"], layers)
    np.testing.assert_array_equal(frame["lit_lights"][..., 0], frame["lit"])
