"""The soft check and the reference's offset probe: a dump's ``soft`` against stratified Embree
samples of the linear light (game/reference/soft_score.py), and the points whose reference
changes with the ray offset, left out of the hard and the soft check alike
(game/reference/offsets.py), on geometry built by hand."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from game.reference.hard import RAY_OFFSET_SCENE, Light, hard_visibility, shadow_error
from game.reference.offsets import offset_sensitive_lights
from game.reference.soft_score import OFF_BY, score_soft, score_soft_dump
from tests.reference.hand_made_dumps import (
    LINEAR_LIGHT,
    floor_frame,
    scene_text,
    true_lit,
    write_dump,
)

pytest.importorskip("embreex", reason="the reference needs embreex (pip install embreex)")

CUBE = ((-1.0, 0.0, -1.0), (1.0, 2.0, 1.0))   # the hand-made scene's static, corner to corner


def box_visibility(position: np.ndarray, samples: int = 4096) -> np.ndarray:
    """The share of the linear light each floor point sees past the cube, by a slab test on
    ``samples`` evenly spaced points of the segment (no Embree)."""
    a, b = (np.asarray(end) for end in LINEAR_LIGHT)
    t = (np.arange(samples) + 0.5) / samples
    targets = a + t[:, None] * (b - a)                      # (S, 3)
    p = np.nan_to_num(position.reshape(-1, 3).astype(np.float64))[:, None, :]
    d = targets[None] - p                                   # (P, S, 3)
    lo, hi = (np.asarray(c) for c in CUBE)
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (lo - p) / d, (hi - p) / d
    near = np.nanmax(np.minimum(t0, t1), axis=-1)
    far = np.nanmin(np.maximum(t0, t1), axis=-1)
    blocked = (near < far) & (far > 0) & (near < 1)
    visibility = (1.0 - blocked.mean(axis=1)).reshape(position.shape[:-1])
    return np.where(np.isfinite(position).all(axis=-1), visibility, np.nan)


def test_the_reference_of_a_cube_is_what_a_slab_test_says(tmp_path):
    position, normal = floor_frame()
    truth = box_visibility(position)
    npz = write_dump(tmp_path, scene_text(linear_light=True), None,
                     lit=true_lit(position, 0), soft=truth)
    score = score_soft_dump(npz, *LINEAR_LIGHT)
    assert score["points"] == 399 and score["left_out_offset"] == 0
    assert score["rmse"] < 0.01 and score["off"] == 0, score["rmse"]
    assert ((truth > 0.0) & (truth < 1.0)).sum() > 20   # a penumbra, not just lit and dark


def test_points_off_by_more_than_a_tenth_are_counted(tmp_path):
    position, _ = floor_frame()
    truth = box_visibility(position)
    all_lit = np.where(np.isfinite(position[..., 0]), 1.0, np.nan)
    npz = write_dump(tmp_path, scene_text(linear_light=True), None,
                     lit=true_lit(position, 0), soft=all_lit)
    score = score_soft_dump(npz, *LINEAR_LIGHT)
    # A point within sampling noise of the threshold may fall either way.
    missing = 1.0 - truth[np.isfinite(truth)]
    surely, maybe = int((missing > OFF_BY + 0.01).sum()), int((missing > OFF_BY - 0.01).sum())
    assert 0 < surely <= score["off"] <= maybe
    assert score["off_share"] == score["off"] / 399
    rmse = np.sqrt(np.nanmean((1.0 - truth) ** 2))
    assert score["rmse"] == pytest.approx(rmse, abs=0.01)


def plate_and_points() -> tuple[trimesh.Trimesh, np.ndarray, np.ndarray, float]:
    """A 10 m plate floating over the point (0, 0, 0) at three quarters of the reference's ray
    offset there, and a point (7, 0, 0) in the open; both face up. Returns the mesh, the (1, 2)
    positions and normals, and the offset."""
    position = np.array([[[0.0, 0.0, 0.0], [7.0, 0.0, 0.0]]], np.float32)
    normal = np.array([[[0.0, 1.0, 0.0], [0.0, 1.0, 0.0]]], np.float32)
    # The scene's diagonal: the plate (x, z from -5 to 5) and the points (x up to 7).
    offset = RAY_OFFSET_SCENE * float(np.hypot(12.0, 10.0))
    height = 0.75 * offset
    corners = np.array([[-5, height, -5], [5, height, -5], [5, height, 5], [-5, height, 5]])
    plate = trimesh.Trimesh(corners, [[0, 2, 1], [0, 3, 2]], process=False)
    return plate, position, normal, offset


def test_a_point_whose_hard_reference_changes_with_the_offset_is_left_out():
    plate, position, normal, _ = plate_and_points()
    sun = Light("directional", direction=(0.0, -1.0, 0.0))
    exact = hard_visibility(plate, position, normal, sun)
    # At the usual offset the ray starts above the plate; at half of it, below.
    np.testing.assert_array_equal(exact, [[1.0, 1.0]])
    [shaky] = offset_sensitive_lights(plate, position, normal, [sun], [exact])
    np.testing.assert_array_equal(shaky, [[True, False]])
    dark = np.zeros((1, 2), np.float32)
    err = shadow_error(dark, exact, position, normal, sun, left_out=shaky)
    assert err["considered"] == 1 and err["left_out_offset"] == 1
    assert err["misclassified"] == 1 and err["left_out_reach"] == 0
    np.testing.assert_array_equal(err["offset_mask"], shaky)


def test_a_point_whose_soft_reference_changes_with_the_offset_is_left_out():
    plate, position, normal, _ = plate_and_points()
    soft = np.array([[0.5, 0.5]], np.float32)
    score = score_soft(soft, position, normal, plate, *LINEAR_LIGHT, samples=64)
    np.testing.assert_array_equal(score["offset_mask"], [[True, False]])
    assert score["points"] == 1 and score["left_out_offset"] == 1
    assert score["reference"][0, 1] == 1.0 and score["rmse"] == pytest.approx(0.5)
