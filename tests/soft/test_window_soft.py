"""The linear light as one more light, and the window's soft accumulation
(game/soft/composite.py, game/soft/accumulate.py, game/soft/upsample.py) on the tiny scene."""

from __future__ import annotations

import numpy as np
import pytest

from game.render.renderer import Renderer, View
from game.scene.model import LinearLight
from game.soft.accumulate import walker_boxes
from game.soft.methods import TraceSettings
from game.soft.upsample import Upsampling

SIZE = (96, 54)
SOFT = TraceSettings(method="grid", samples=4)
NOISY = TraceSettings(method="grid", samples=1)
ANALYTIC = TraceSettings(method="analytic")


@pytest.fixture
def make_renderer(ctx):
    made = []

    def make(scene):
        made.append(Renderer(ctx, scene, SIZE, gbuffer=True))
        return made[-1]

    yield make
    for r in made:
        r.release()


def _view(renderer, camera_shift: float = 0.0) -> View:
    view = View.from_camera(renderer.scene.camera, SIZE)
    if camera_shift:
        moved = view.view.copy()
        moved[0, 3] += camera_shift
        view = View(moved, view.proj, view.size)
    return view


def test_the_linear_light_adds_to_the_scene_lights(make_renderer, tiny):
    # The linear light below the floor: every point of the floor sees none of it, so the soft
    # frame must be the hard one, the sun's light and shadows kept.
    tiny.linear_light = LinearLight(np.array([-2.0, -5.0, 1.0]), np.array([2.0, -5.0, 1.0]))
    renderer = make_renderer(tiny)
    hard = renderer.render(1.0, _view(renderer))
    soft = renderer.render(1.0, _view(renderer), soft=SOFT)
    covered = hard.covered
    lit = hard.gbuffer["lit"][covered]
    assert (lit > 0.99).mean() > 0.3            # most of the floor is in the sun
    floor = covered & (hard.gbuffer["object"] == 0)
    assert np.nanmax(soft.soft.visibility[floor]) == 0.0
    diff = np.abs(soft.image.astype(int) - hard.image.astype(int)).max(axis=2)
    assert diff[floor].max() <= 2, diff[floor].max()


def test_the_linear_light_brightens_what_it_reaches(make_renderer, tiny):
    renderer = make_renderer(tiny)
    hard = renderer.render(1.0, _view(renderer)).image.astype(int)
    soft = renderer.render(1.0, _view(renderer), soft=SOFT)
    gain = soft.image.astype(int).sum(axis=2) - hard.sum(axis=2)
    vis = soft.soft.visibility
    assert gain.min() >= -3                      # adding light never darkens
    seen = np.isfinite(vis)
    assert gain[seen & (vis > 0.9)].mean() > 10 + gain[seen & (vis < 0.1)].mean()


def _shown(renderer) -> np.ndarray:
    tex = renderer.traced.reduced.visibility
    w, h = tex.size
    return np.frombuffer(tex.read(), np.float16).reshape(h, w)[::-1].astype(np.float32)


def _rmse(a: np.ndarray, b: np.ndarray) -> float:
    seen = np.isfinite(b)
    return float(np.sqrt(np.mean((a[seen] - b[seen]) ** 2)))


def test_a_still_view_converges_to_the_analytic_picture_and_starts_again_when_moved(
        make_renderer, tiny):
    renderer = make_renderer(tiny)
    exact = renderer.render(1.0, _view(renderer), soft=ANALYTIC).soft.visibility
    renderer.traced.reduce_soft(Upsampling(divisor=2, rounds=8), b"still")
    rmse = []
    for _ in range(16):   # four rounds of every pixel, one sample per point each
        renderer.render(1.0, _view(renderer), soft=NOISY)
        rmse.append(_rmse(_shown(renderer), exact))
    assert rmse[15] < rmse[3] < rmse[0], rmse
    assert rmse[15] < 0.6 * rmse[0], rmse
    counts = renderer.traced.reduced.accumulation.read()[..., 1]
    assert counts.max() == 4
    # The camera moves: every pixel starts again.
    renderer.traced.reduce_soft(Upsampling(divisor=2, rounds=8), b"moved")
    renderer.render(1.0, _view(renderer, 0.3), soft=NOISY)
    assert renderer.traced.reduced.accumulation.read()[..., 1].max() == 1
    assert renderer.traced.reduced_state.round == 0


def test_a_walker_that_moves_starts_only_the_pixels_it_may_shadow(make_renderer, tiny):
    renderer = make_renderer(tiny)
    renderer.traced.reduce_soft(Upsampling(divisor=2, rounds=8), b"still")
    for _ in range(8):
        renderer.render(1.0, _view(renderer), soft=NOISY)
    frame = renderer.render(1.05, _view(renderer), soft=NOISY)   # the walker steps
    counts = renderer.traced.reduced.accumulation.read()[..., 1]
    covered = frame.covered
    walker = covered & (frame.gbuffer["object"] == renderer.geom.first_character)
    assert walker.any()
    assert counts[walker].max() <= 1             # its own pixels: this frame's trace at most
    assert np.median(counts[covered]) >= 2       # the rest keeps its samples


def test_walker_boxes_name_only_the_walkers_that_moved():
    bounds = np.array([[[-0.5, -1.0, -0.5], [0.5, 1.0, 0.5]]] * 2)
    still = np.stack([np.eye(4), np.eye(4)])
    moved = still.copy()
    moved[1, 0, 3] = 2.0
    assert len(walker_boxes(bounds, None, still)) == 0
    assert len(walker_boxes(bounds, still, still)) == 0
    boxes = walker_boxes(bounds, still, moved)
    assert boxes.shape == (1, 2, 3)
    centre, half = boxes[0]
    np.testing.assert_allclose(centre, [1.0, 0.0, 0.0])
    assert half[0] >= 1.5 and half[1] >= 1.0     # both poses inside
