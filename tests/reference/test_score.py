"""Scoring every light of a dump: each layer of ``lit_lights`` against Embree rays toward its own
light, on dumps built by hand (tests/reference/hand_made_dumps.py: numpy and a small glb, no
renderer, no GL)."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest

from game.reference import hard
from game.reference.hard import MAX_DUMP_LIGHTS, MAX_LAYERS_PER_PIXEL, load_frame
from game.reference.score import score_dump, score_dump_lights
from game.scene import parse_scene
from tests.reference.hand_made_dumps import (
    POINT_LIGHT_HEIGHT,
    floor_frame,
    scene_text,
    true_lit,
    write_dump,
)

pytest.importorskip("embreex", reason="the shadow reference needs embreex (pip install embreex)")

def test_each_light_is_scored_against_its_own_rays(tmp_path):
    position, _ = floor_frame()
    right = [true_lit(position, 0), true_lit(position, 1)]
    npz = write_dump(tmp_path, scene_text(), right)
    lights = parse_scene(scene_text()).lights
    scores = score_dump_lights(npz, lights)
    assert len(scores["lights"]) == 2
    for k, err in enumerate(scores["lights"]):
        assert err["error"] == 0.0 and err["misclassified"] == 0
        np.testing.assert_array_equal(err["exact"], right[k])
    # 6 x 6 points under the point light's square, 4 x 4 under the sun's; 399 with geometry.
    assert [err["shadowed"] for err in scores["lights"]] == [16, 36]
    assert [err["considered"] for err in scores["lights"]] == [399, 399]


def test_a_wrong_layer_gives_its_own_light_a_large_error_and_no_other(tmp_path):
    position, _ = floor_frame()
    # Light 1's layer says "lit" everywhere: it misses its whole shadow.
    wrong = [true_lit(position, 0), np.where(np.isfinite(position[..., 0]), 1.0, np.nan)]
    npz = write_dump(tmp_path, scene_text(), wrong)
    scores = score_dump_lights(npz, parse_scene(scene_text()).lights)
    sun, bulb = scores["lights"]
    assert sun["error"] == 0.0
    assert bulb["error"] == 1.0 and bulb["misclassified"] == bulb["shadowed"] == 36
    # ``lit`` is light 0's, and scores as it always did.
    assert scores["lit"]["error"] == 0.0
    assert score_dump(npz, parse_scene(scene_text()).light)["error"] == 0.0


def test_light_0_of_lit_lights_and_lit_are_scored_each_as_it_is(tmp_path):
    position, _ = floor_frame()
    layers = [true_lit(position, 0), true_lit(position, 1)]
    npz = write_dump(tmp_path, scene_text(), layers, lit=true_lit(position, 1))
    scores = score_dump_lights(npz, parse_scene(scene_text()).lights)
    assert scores["lights"][0]["error"] == 0.0
    assert scores["lit"]["misclassified"] == 20   # the ring between the two squares


def test_pixels_beyond_a_lights_range_are_not_judged(tmp_path):
    # A 7 m range from 6 m up reaches the floor within sqrt(7^2 - 6^2) = 3.6 m of the centre.
    reach = np.sqrt(7.0**2 - POINT_LIGHT_HEIGHT**2)
    text = scene_text(light_range=7.0)
    position, _ = floor_frame()
    beyond = np.hypot(position[..., 0], position[..., 2]) > reach
    # Light 1's layer is right within reach and says "shadowed" beyond it.
    bulb = np.where(beyond, 0.0, true_lit(position, 1)).astype(np.float32)
    npz = write_dump(tmp_path, text, [true_lit(position, 0), bulb])
    scores = score_dump_lights(npz, parse_scene(text).lights)
    err = scores["lights"][1]
    assert beyond.sum() > 50
    assert err["considered"] == 399 - int(beyond.sum())
    assert err["error"] == 0.0 and err["misclassified"] == 0
    assert not err["mask"][beyond].any()
    # Without the range the same layer is wrong at every one of those pixels.
    unlimited = score_dump_lights(npz, parse_scene(scene_text()).lights)["lights"][1]
    assert unlimited["misclassified"] == int(beyond.sum())


def test_a_dump_without_lit_lights_scores_lit_against_light_0(tmp_path):
    position, _ = floor_frame()
    npz = write_dump(tmp_path, scene_text(), None, lit=true_lit(position, 0))
    scores = score_dump_lights(npz, parse_scene(scene_text()).lights)
    assert len(scores["lights"]) == 1
    assert scores["lights"][0]["error"] == scores["lit"]["error"] == 0.0
    assert scores["lights"][0]["shadowed"] == 16


def test_a_layer_count_that_is_not_the_scenes_is_refused(tmp_path):
    position, _ = floor_frame()
    npz = write_dump(tmp_path, scene_text(), [true_lit(position, 0)] * 3)
    with pytest.raises(ValueError, match="'lit_lights' holds 3 light"):
        score_dump_lights(npz, parse_scene(scene_text()).lights)


def npz_with_lit_lights(path: Path, size: tuple[int, int], shape: tuple[int, ...]) -> None:
    """An npz of a ``size`` (W, H) frame whose ``lit_lights`` declares ``shape`` in its header
    and holds no data: only the check of declared sizes can read it."""
    with zipfile.ZipFile(path, "w") as z:
        with z.open("size.npy", "w") as f:
            np.lib.format.write_array(f, np.array(size))
        with z.open("lit_lights.npy", "w") as f:
            np.lib.format.write_array_header_1_0(
                f, {"descr": "<f4", "fortran_order": False, "shape": shape})


@pytest.mark.parametrize("shape", [(9, 16, MAX_DUMP_LIGHTS + 1), (9, 16, 0), (9, 16),
                                   (16, 9, 2), (9, 16, 2, 1)])
def test_lit_lights_must_have_the_frames_shape_and_at_most_64_layers(tmp_path, shape):
    npz_with_lit_lights(tmp_path / "frame_0000.npz", (16, 9), shape)
    with pytest.raises(ValueError, match="'lit_lights' declares"):
        load_frame(tmp_path / "frame_0000.npz")


def test_64_lights_fit_in_a_dump_and_the_total_stays_bounded(tmp_path):
    # 64 float32 layers of a 1024x512 frame are 128 MiB, past the allowance of small arrays:
    # only the per-pixel allowance lets them in.
    path = tmp_path / "frame_0000.npz"
    npz_with_lit_lights(path, (1024, 512), (512, 1024, MAX_DUMP_LIGHTS))
    with np.load(path) as data:
        hard.check_declared_sizes(data)
    assert MAX_DUMP_LIGHTS == 64 and MAX_LAYERS_PER_PIXEL * 8 >= 64 * 4
    # 64 layers of a 8192x4096 frame are 8 GiB: more than a dump may hold.
    npz_with_lit_lights(path, (8192, 4096), (4096, 8192, MAX_DUMP_LIGHTS))
    with np.load(path) as data, pytest.raises(ValueError, match="a dump may hold"):
        hard.check_declared_sizes(data)


def test_a_small_dump_of_64_lights_loads(tmp_path):
    layers = np.random.default_rng(1).random((9, 16, MAX_DUMP_LIGHTS)).astype(np.float32)
    np.savez(tmp_path / "frame_0000.npz", size=np.array([16, 9]), lit_lights=layers)
    np.testing.assert_array_equal(load_frame(tmp_path / "frame_0000.npz")["lit_lights"], layers)
