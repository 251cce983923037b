"""Traced lighting (game/render/traced_lighting.py): a trace that reports its progress goes in
bands of rows and gives the same visibility and counters as one pass; the window's reduced soft
trace leaves the headless frames as they were."""

from __future__ import annotations

import numpy as np
import pytest

from game.render import traced_lighting
from game.render.renderer import Renderer, View
from game.soft.methods import TraceSettings
from game.soft.upsample import Upsampling

SIZE = (96, 54)
SETTINGS = TraceSettings(method="grid", samples=4)


@pytest.fixture
def renderer(ctx, tiny):
    r = Renderer(ctx, tiny, SIZE, gbuffer=True)
    yield r
    r.release()


def _frame(renderer, soft=SETTINGS):
    return renderer.render(1.0, View.from_camera(renderer.scene.camera, SIZE), soft=soft)


ROWS_PER_BAND = -(-SIZE[1] // traced_lighting.PROGRESS_BANDS)


@pytest.mark.parametrize("after_s, calls", [(0.0, -(-SIZE[1] // ROWS_PER_BAND)), (1e9, 2)])
def test_a_trace_in_bands_equals_one_pass(renderer, monkeypatch, after_s, calls):
    whole = _frame(renderer).soft
    shares = []
    renderer.traced.progress = shares.append
    # 0 s: every band on its own; a long time: the first band, then the rest at once.
    monkeypatch.setattr(traced_lighting, "PROGRESS_AFTER_S", after_s)
    banded = _frame(renderer).soft
    np.testing.assert_array_equal(banded.visibility, whole.visibility)
    assert np.isfinite(whole.visibility).sum() > 1000
    for name, values in whole.counters.items():
        np.testing.assert_array_equal(banded.counters[name], values)
    assert len(shares) == calls and shares == sorted(shares) and shares[-1] == 1.0


def test_the_reduced_trace_is_the_windows_alone(renderer):
    full = _frame(renderer)
    renderer.traced.reduce_soft(Upsampling(divisor=3), b"view")
    reduced = _frame(renderer)
    assert reduced.soft.visibility.shape == (18, 32)
    assert reduced.image.shape == full.image.shape
    assert "soft_upsample" in reduced.ms and "soft_upsample" not in full.ms
    assert renderer.traced.reduced_state.size == (32, 18)
    renderer.traced.reduce_soft(None)
    again = _frame(renderer)
    np.testing.assert_array_equal(again.soft.visibility, full.soft.visibility)
    np.testing.assert_array_equal(again.image, full.image)
    assert renderer.traced.reduced_state is None
