"""The matrix conventions, checked once against hand-computed values."""

import numpy as np
import pytest
from pyrr import matrix44

from game import transforms as tf


def test_look_at_maps_eye_to_origin_and_target_down_minus_z():
    view = tf.look_at([1.0, 2.0, 5.0], [1.0, 2.0, 0.0])
    assert np.allclose(view @ [1, 2, 5, 1], [0, 0, 0, 1])
    assert np.allclose(view @ [1, 2, 0, 1], [0, 0, -5, 1])
    assert np.allclose(view @ [1, 3, 5, 1], [0, 1, 0, 1])  # +Y stays up


def test_perspective_near_and_far_map_to_ndc_minus_one_and_one():
    proj = tf.perspective(90.0, 2.0, 1.0, 10.0)
    near = proj @ [0, 0, -1, 1]
    far = proj @ [0, 0, -10, 1]
    assert near[2] / near[3] == pytest.approx(-1)
    assert far[2] / far[3] == pytest.approx(1)
    edge = proj @ [2.0, 1.0, -1.0, 1.0]  # 45 degrees up, aspect 2 to the side
    assert np.allclose(edge[:2] / edge[3], [1, 1])


def test_frustum_equals_symmetric_perspective():
    assert np.allclose(tf.frustum(-1, 1, -1, 1, 1, 10), tf.perspective(90, 1, 1, 10))


def test_ortho_maps_box_corners_to_ndc_corners():
    proj = tf.ortho_many(*(np.array([v], float) for v in (-2, 4, -1, 3, -5, 5)))[0]
    assert np.allclose(proj @ [4, 3, 5, 1], [1, 1, -1, 1])   # z=+5 is distance -5: near
    assert np.allclose(proj @ [-2, -1, -5, 1], [-1, -1, 1, 1])


def test_ortho_many_equals_pyrr_one_by_one():
    rng = np.random.default_rng(5)
    lo = rng.uniform(-50, 50, (20, 3))
    hi = lo + rng.uniform(0.1, 30, (20, 3))
    many = tf.ortho_many(lo[:, 0], hi[:, 0], lo[:, 1], hi[:, 1], lo[:, 2], hi[:, 2])
    for k in range(20):
        one = matrix44.create_orthogonal_projection(lo[k, 0], hi[k, 0], lo[k, 1], hi[k, 1],
                                                    lo[k, 2], hi[k, 2], dtype=np.float64).T
        assert np.allclose(many[k], one, rtol=1e-12, atol=1e-12)


def test_look_at_many_and_frustum_many_equal_one_by_one():
    rng = np.random.default_rng(9)
    eyes = rng.uniform(-20, 20, (20, 3))
    targets = eyes + rng.normal(size=(20, 3))
    targets[0] = eyes[0] + [0.0, -2.0, 0.0]      # straight down and straight up: another up
    targets[1] = eyes[1] + [0.0, 3.0, 0.0]
    many = tf.look_at_many(eyes, targets)
    for k in range(20):
        assert np.allclose(many[k], tf.look_at(eyes[k], targets[k]), rtol=1e-12, atol=1e-12)
    lo = rng.uniform(-3, -0.1, (20, 2))
    hi = rng.uniform(0.1, 3, (20, 2))
    near = rng.uniform(0.01, 2, 20)
    far = near + rng.uniform(1, 100, 20)
    many = tf.frustum_many(lo[:, 0], hi[:, 0], lo[:, 1], hi[:, 1], near, far)
    for k in range(20):
        one = tf.frustum(lo[k, 0], hi[k, 0], lo[k, 1], hi[k, 1], near[k], far[k])
        assert np.allclose(many[k], one, rtol=1e-12, atol=1e-12)


def test_light_rotation_z_points_to_the_light_even_when_vertical():
    for direction in ([-0.4, -1.0, -0.3], [0.0, -1.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0, 0]):
        d = np.array(direction) / np.linalg.norm(direction)
        rot = tf.light_rotation(d)
        assert np.allclose(rot @ rot.T, np.eye(3))
        assert np.allclose(rot[2], -d)
        assert np.all(np.isfinite(rot))


def test_euler_order_is_x_then_y_then_z():
    r = tf.euler_xyz([90.0, 90.0, 0.0])
    # X first turns +Y into +Z, then Y turns +Z into +X.
    assert np.allclose(r @ [0, 1, 0], [1, 0, 0])


def test_gl_bytes_is_column_major():
    m = np.arange(16, dtype=float).reshape(4, 4)
    floats = np.frombuffer(tf.gl_bytes(m), np.float32)
    assert list(floats[:4]) == [0, 4, 8, 12]  # the first column


def test_project_points_matches_matrix_product():
    m = tf.perspective(60, 1.5, 0.1, 100) @ tf.look_at([3, 4, 5], [0, 0, 0])
    p = np.array([[1.0, 2.0, 3.0], [-1.0, 0.5, 2.0]])
    expected = np.array([m @ [*q, 1.0] for q in p])
    assert np.allclose(tf.project_points(m, p), expected)
