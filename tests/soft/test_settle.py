"""A still view settled to the exact visibility (game/soft/settle.py): the queue's order, what a
walker's change and the composite's lookups undo, and a window whose still view reaches the
``analytic`` picture pixel for pixel."""

from __future__ import annotations

import numpy as np
import pytest

from game.render.renderer import View
from game.soft import direct, settle
from game.soft.methods import TraceSettings
from game.soft.settle import StillSettle, Tier
from game.soft.still_lookups import REFINE_POINTS
from game.soft.upsample import Upsampling
from tests.soft.tracer_helpers import rmse

SIZE = (96, 54)
DIVISOR = 4
CELLS = (24, 14)   # blocks of DIVISOR pixels over SIZE, the last row cut


def started(tiers: np.ndarray, covered: np.ndarray | None = None) -> StillSettle:
    h, w = tiers.shape
    covered = np.ones((h, w), bool) if covered is None else covered
    made = StillSettle(DIVISOR)
    flat = np.arange(h * w, dtype=np.float32).reshape(h, w)
    made.start(np.repeat(flat[..., None], 3, axis=2), np.zeros((h, w, 3)), covered, tiers)
    return made


def everywhere() -> np.ndarray:
    return np.ones((CELLS[1], CELLS[0]), bool)


def by_index(points: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """A stand-in tracer: each point's x is its pixel's flat index (see :func:`started`)."""
    return points[:, 0] / 1e4


def test_the_queue_takes_the_penumbra_first_then_block_by_block():
    tiers = np.full((SIZE[1], SIZE[0]), Tier.AGREED)
    tiers[20:30, 40:60] = Tier.LOOKED_UP
    tiers[24:28, 44:52] = Tier.PARTLY_LIT   # two whole blocks
    covered = np.ones_like(tiers, bool)
    covered[0, :] = False   # the sky
    made = started(tiers, covered)
    order = made.queue
    assert len(order) == covered.sum()
    ranks = tiers.reshape(-1)[order]
    assert np.all(np.diff(ranks) >= 0)
    assert np.count_nonzero(ranks == Tier.PARTLY_LIT) == 4 * 8
    # Within a tier a block's pixels follow one another: the first block's 16, then the next.
    rows, cols = np.divmod(order[:32], SIZE[0])
    blocks = (rows // DIVISOR) * CELLS[0] + cols // DIVISOR
    assert np.all(blocks[:16] == blocks[0]) and np.all(blocks[16:] == blocks[16])
    assert blocks[16] > blocks[0]


def test_a_batch_takes_only_kept_blocks_and_its_pixels_come_back_in_order(monkeypatch):
    monkeypatch.setattr(settle, "FIRST_BATCH", 40)
    made = started(np.full((SIZE[1], SIZE[0]), Tier.AGREED))
    kept = everywhere()
    kept[0, 0] = False   # the first block waits
    batch = made.next_batch(kept, frame_ms=10.0)
    assert len(batch) == 40
    pixels, visibility = made.settle(batch, by_index)
    assert np.allclose(visibility, pixels / 1e4)
    rows, cols = np.divmod(pixels, SIZE[0])
    assert not np.any((rows < DIVISOR) & (cols < DIVISOR))
    assert made.settled.sum() == 40
    done = made.settled_blocks(CELLS)
    assert done.sum() == 2 and not done[0, 0]   # 40 pixels: two whole blocks and a half
    # The pace of the last batch sizes the next, by the share of the frames since it that it
    # may take (a larger one where nothing on screen moved); the frames between take none.
    for share, static in ((settle.SETTLE_SHARE, False), (settle.STATIC_SHARE, True)):
        made.pace_ms = pace = 0.01 * share   # four frames of 10 ms: 4000 pixels
        for _ in range(settle.SETTLE_EVERY - 1):
            assert made.next_batch(kept, frame_ms=10.0, static=static) is None
        expected = int(share * 10.0 * settle.SETTLE_EVERY / pace)
        assert expected == 4000
        assert len(made.next_batch(kept, frame_ms=10.0, static=static)) == expected


def test_a_changed_or_drawn_block_loses_what_it_settled(monkeypatch):
    monkeypatch.setattr(settle, "SETTLE_EVERY", 1)
    made = started(np.full((SIZE[1], SIZE[0]), Tier.AGREED))
    made.pace_ms = 1e-3   # everything in one batch
    made.settle(made.next_batch(everywhere(), frame_ms=1e4), by_index)
    assert made.share == 1.0 and made.settled_blocks(CELLS).all()
    changed = everywhere()
    changed[3, 5] = False
    made.forget_changed(changed)
    assert made.settled_blocks(CELLS).sum() == CELLS[0] * CELLS[1] - 1
    assert np.array_equal(made.waiting_blocks(CELLS), ~changed)
    assert not made.settled[12:16, 20:24].any() and made.settled.sum() == SIZE[0] * SIZE[1] - 16
    drawn = ~everywhere()
    drawn[13, 0] = True   # the last row of blocks holds two rows of pixels
    made.forget_drawn(drawn)
    assert made.settled.sum() == SIZE[0] * SIZE[1] - 16 - 8
    again = made.next_batch(everywhere(), frame_ms=1e4)
    pixels, _ = made.settle(again, by_index)
    assert len(pixels) == 24 and made.share == 1.0


@pytest.mark.parametrize("method", ["segment-maps", "pcss"])
def test_a_still_view_settles_to_the_exact_visibility_pixel_for_pixel(renderer, method,
                                                                      monkeypatch):
    """The walkers stand still. Once refined, each frame settles its pixels, the penumbrae
    first; with a share of the frame large enough for every pixel, the next frame shows the
    ``analytic`` visibility at every pixel, and the frames after it trace nothing."""
    settings = TraceSettings(method=method, maps=8)
    view = View.from_camera(renderer.scene.camera, SIZE)
    renderer.render(1.0, view)
    exact = renderer.trace(1.0, TraceSettings(method="analytic")).visibility
    covered = np.isfinite(exact)
    renderer.traced.reduce_soft(Upsampling(divisor=DIVISOR), b"view", np.zeros(3))
    rounds = REFINE_POINTS // settings.maps if method == "segment-maps" else 1
    errors, settled = [], []
    for _ in range(rounds + 1):
        frame = renderer.render(1.0, view, soft=settings)
        shown = renderer.traced.window_visibility(renderer.target)
        errors.append(rmse(shown[covered], exact[covered]))
        settled.append(frame.ms["soft_settle"])
    assert max(settled[:rounds]) == 0.0 and settled[rounds] > 0.0
    assert errors[rounds] < 0.5 * errors[rounds - 1]   # the penumbrae went first
    monkeypatch.setattr(settle, "SETTLE_SHARE", 1e6)
    monkeypatch.setattr(settle, "STATIC_SHARE", 1e6)
    monkeypatch.setattr(settle, "SETTLE_EVERY", 1)
    renderer.render(1.0, view, soft=settings)
    assert renderer.traced.direct.blocks.settle.share == 1.0
    frame = renderer.render(1.0, view, soft=settings)
    shown = renderer.traced.window_visibility(renderer.target)
    assert np.array_equal(np.isnan(shown), ~covered)
    assert np.max(np.abs(shown[covered] - exact[covered])) < 1e-6
    assert frame.ms["soft_settle"] == 0.0
    assert renderer.traced.reduced_state.settled == 1.0


def test_a_walker_unsettles_what_it_changes_and_it_settles_again(renderer, monkeypatch):
    """The walkers walk: the blocks a walker changes look the light up again and lose their
    settled pixels, and wait while it changes them; once the walkers stop, the view settles
    to the exact visibility of their last poses."""
    monkeypatch.setattr(settle, "SETTLE_SHARE", 1e6)
    monkeypatch.setattr(settle, "STATIC_SHARE", 1e6)
    monkeypatch.setattr(settle, "SETTLE_EVERY", 1)
    monkeypatch.setattr(direct, "REFRESH_FRAMES", 1)
    settings = TraceSettings(method="pcss")
    view = View.from_camera(renderer.scene.camera, SIZE)
    renderer.traced.reduce_soft(Upsampling(divisor=DIVISOR), b"view", np.zeros(3))
    for t in (0.0, 0.0, 0.0):
        renderer.render(t, view, soft=settings)
    blocks = renderer.traced.direct.blocks
    assert blocks.settle.share == 1.0
    renderer.render(0.3, view, soft=settings)   # the walkers moved
    # What they changed waits for a frame in which they change it no more; what they crossed
    # on screen waits for the G-buffer, drawn again once nothing else is left.
    changed = blocks.still.changed
    assert changed.any() and 0.0 < blocks.settle.share < 1.0
    assert not (blocks.settle.settled_blocks(blocks.cells) & changed).any()
    renderer.render(0.3, view, soft=settings)   # they stand: everything settles
    assert blocks.settle.share == 1.0
    shown = renderer.traced.window_visibility(renderer.target)
    renderer.render(0.3, view)
    exact = renderer.trace(0.3, TraceSettings(method="analytic")).visibility
    covered = np.isfinite(exact)
    assert np.max(np.abs(shown[covered] - exact[covered])) < 1e-6
