"""The reduced soft trace and its upsampling (game/soft/upsample.py) on llvmpipe.

A synthetic G-buffer holds two surfaces that meet along a column of pixels that is no block
boundary: a near wall in shadow and, beside it, either a far wall (a depth edge) or a plane
folded towards the camera (a crease, no depth edge). A stand-in tracer gives every point its
true visibility (0 on the wall, 1 on the other surface, carried in the position's w), so every
error in the upsampled visibility is the upsampling's own.
"""

from __future__ import annotations

import numpy as np
import pytest

from game.gpu import resources
from game.gpu.timing import PassTimer
from game.soft import upsample
from game.soft.tracer import TraceResult
from game.soft.upsample import (
    NO_SAMPLE,
    FrameMotion,
    ReducedTrace,
    Upsampling,
    agreed_values,
    phases,
)

SIZE = (70, 46)       # not a multiple of the divisor: blocks cut by the frame's edge
DIVISOR = 4
EDGE_X = 29           # first pixel column of the second surface: inside a block
SKY_ROWS = 3          # the top rows show no geometry
PIXEL_M = 0.01        # metres per pixel on the near wall
MOVING = Upsampling(divisor=DIVISOR, accumulate=False)   # every frame upsampled afresh


def synthetic_gbuffer(kind: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(position, normal, colour, truth) in GL rows (row 0 at the bottom).

    position's w is the true visibility: 0 on the near wall (x < EDGE_X), 1 on the other
    surface; ``kind`` "depth" puts a parallel wall 3 m behind, "crease" a plane through the
    wall's edge, turned 45 degrees towards the camera."""
    w, h = SIZE
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    position = np.zeros((h, w, 4), np.float32)
    normal = np.zeros((h, w, 4), np.float32)
    wall = x < EDGE_X
    position[..., 0] = x * PIXEL_M
    position[..., 1] = y * PIXEL_M
    normal[..., 2] = 1.0
    if kind == "depth":
        position[~wall, 0] = x[~wall] * PIXEL_M * 1.3
        position[~wall, 1] = y[~wall] * PIXEL_M * 1.3
        position[~wall, 2] = -3.0
    else:
        run = (x[~wall] - EDGE_X) * PIXEL_M
        position[~wall, 0] = EDGE_X * PIXEL_M + run * np.sqrt(0.5)
        position[~wall, 2] = run * np.sqrt(0.5)
        normal[~wall, 0] = -np.sqrt(0.5)
        normal[~wall, 2] = np.sqrt(0.5)
    truth = np.where(wall, 0.0, 1.0).astype(np.float32)
    position[..., 3] = truth
    colour = np.zeros((h, w, 4), np.uint8)
    colour[..., 3] = 255
    colour[h - SKY_ROWS:] = 0
    truth[h - SKY_ROWS:] = np.nan
    return position, normal, colour, truth


def fake_trace(textures, size):
    """The tracer's stand-in: every covered point's true visibility (its position's w)."""
    w, h = size
    position = np.frombuffer(textures[0].read(), np.float32).reshape(h, w, 4)
    colour = np.frombuffer(textures[2].read(), np.uint8).reshape(h, w, 4)
    vis = np.where(colour[..., 3] > 0, position[..., 3], np.nan).astype(np.float32)
    return TraceResult(visibility=vis[::-1].copy(), counters={}, ms={"total": 0.0})


class Synthetic:
    """The synthetic G-buffer's textures, a reduced trace and a timer; released by close()."""

    def __init__(self, ctx, kind: str, upsampling: Upsampling):
        position, normal, colour, self.truth = synthetic_gbuffer(kind)
        self.textures = (ctx.texture(SIZE, 4, position.tobytes(), dtype="f4"),
                         ctx.texture(SIZE, 4, normal.tobytes(), dtype="f4"),
                         ctx.texture(SIZE, 4, colour.tobytes()))
        self.reduced = ReducedTrace(ctx, upsampling)
        self.timer = PassTimer(ctx, "cpu-finish")

    def frame(self, key: bytes = b"still") -> np.ndarray:
        """One frame's upsampled visibility, (H, W) in GL rows."""
        motion = FrameMotion(key=key, boxes=np.zeros((0, 2, 3)), camera=np.array([0, 0, 5.0]),
                             light=(0, np.array([-1, 2, 1.0]), np.array([1, 2, 1.0])))
        self.reduced.run(self.textures, SIZE, motion, fake_trace, self.timer)
        w, h = SIZE
        return np.frombuffer(self.reduced.visibility.read(), np.float16).reshape(h, w) \
            .astype(np.float32)

    def close(self) -> None:
        self.reduced.release()
        self.timer.release()
        for tex in self.textures:
            tex.release()


@pytest.fixture
def synthetic(ctx):
    made = []

    def make(kind: str, upsampling: Upsampling = MOVING):
        made.append(Synthetic(ctx, kind, upsampling))
        return made[-1]

    yield make
    for s in made:
        s.close()


def bilinear_upscale(truth: np.ndarray, phase: tuple[int, int]) -> np.ndarray:
    """A plain bilinear upscale of the same samples (one per block, at ``phase``): what the
    upsampling replaces, in GL rows."""
    h, w = truth.shape
    ox, oy = phase
    samples = np.nan_to_num(truth, nan=1.0)[oy::DIVISOR, ox::DIVISOR]
    fy = np.clip((np.arange(h) - oy) / DIVISOR, 0, samples.shape[0] - 1)
    fx = np.clip((np.arange(w) - ox) / DIVISOR, 0, samples.shape[1] - 1)
    y0, x0 = np.floor(fy).astype(int), np.floor(fx).astype(int)
    y1, x1 = np.minimum(y0 + 1, samples.shape[0] - 1), np.minimum(x0 + 1, samples.shape[1] - 1)
    ty, tx = (fy - y0)[:, None], (fx - x0)[None, :]
    top = samples[y0][:, x0] * (1 - tx) + samples[y0][:, x1] * tx
    bottom = samples[y1][:, x0] * (1 - tx) + samples[y1][:, x1] * tx
    return top * (1 - ty) + bottom * ty


@pytest.mark.parametrize("kind", ["depth", "crease"])
def test_upsampling_keeps_the_edge_where_a_bilinear_upscale_bleeds(synthetic, kind):
    s = synthetic(kind)
    vis = s.frame()
    covered = np.isfinite(s.truth)
    error = np.abs(vis - s.truth)[covered]
    assert error.max() < 0.02, np.argwhere(np.abs(vis - s.truth) >= 0.02)[:10]
    assert s.reduced.state.size == (18, 12) and not s.reduced.state.full
    # The same samples scaled up bilinearly smear the edge over the columns around it.
    plain = np.abs(bilinear_upscale(s.truth, phases(DIVISOR)[0]) - s.truth)
    assert plain[covered].max() > 0.3
    assert (plain[:, EDGE_X - 2:EDGE_X + 2][covered[:, EDGE_X - 2:EDGE_X + 2]] > 0.1).mean() > 0.3


def test_a_still_view_traces_every_pixel_then_shows_each_its_own(synthetic):
    rounds = 2
    s = synthetic("depth", Upsampling(divisor=DIVISOR, accumulate=True, rounds=rounds))
    n = len(phases(DIVISOR))
    seen = []
    for _ in range(n * rounds + 2):
        vis = s.frame()
        state = s.reduced.state
        seen.append((state.traced, state.round, state.phase, state.full))
    assert seen[0] == (True, 0, 1, False) and seen[n - 2] == (True, 0, n - 1, False)
    assert seen[n - 1] == (True, 0, n, True)        # every pixel traced once: its own mean
    assert seen[n] == (True, 1, 1, True)
    assert seen[-1] == (False, rounds, n, True)    # converged: nothing more is traced
    assert s.reduced.state.converged
    covered = np.isfinite(s.truth)
    # Each pixel its own mean, its neighbours across the edge weighing next to nothing.
    assert np.abs(vis[covered] - s.truth[covered]).max() < 0.01
    # Something moves: back to one block in every DIVISOR x DIVISOR, upsampled.
    s.frame(b"moved")
    assert s.reduced.state.phase == 1 and s.reduced.state.round == 0


def test_the_upsampling_makes_its_objects_once(ctx, synthetic):
    before = resources.live_gl_names()
    s = synthetic("crease", Upsampling(divisor=DIVISOR, accumulate=True, rounds=1))
    counts = []
    for key in (b"a", b"a", b"b"):
        s.frame(key)
        counts.append(s.reduced.gl_objects())
    for _ in range(len(phases(DIVISOR)) + 1):   # through accumulation to convergence
        s.frame(b"b")
        counts.append(s.reduced.gl_objects())
    assert len(set(counts)) == 1, counts
    s.reduced.set_upsampling(Upsampling(divisor=2))   # other targets, as many
    s.frame(b"c")
    assert s.reduced.gl_objects() == counts[0]
    s.close()
    s.textures = ()
    assert resources.live_gl_names() == before


def test_agreed_values_are_the_windows_one_value():
    rng = np.random.default_rng(3)
    vis = rng.choice([0.0, 0.5, 1.0, np.nan], size=(9, 13), p=[0.45, 0.05, 0.45, 0.05])
    vis[:4, :5] = 1.0
    shift = 5
    agreed = agreed_values(vis.astype(np.float32), shift)
    by_block = np.roll(vis[::-1], shift, axis=1)
    g = upsample.GATHER
    expected = np.empty_like(by_block)
    for y in range(by_block.shape[0]):
        for x in range(by_block.shape[1]):
            window = by_block[y:y + g, x:x + g]
            values = set(window[np.isfinite(window)].tolist())
            expected[y, x] = values.pop() if len(values) == 1 else (1.0 if not values
                                                                    else NO_SAMPLE)
    np.testing.assert_array_equal(agreed, np.roll(expected, -shift, axis=1))
    assert (agreed >= 0).any() and (agreed == NO_SAMPLE).any()


@pytest.mark.parametrize("divisor", [1, 2, 3, 4])
def test_phases_visit_every_pixel_of_a_block_once_middle_first(divisor):
    order = phases(divisor)
    assert order[0] == (divisor // 2, divisor // 2)
    assert sorted(order) == [(x, y) for x in range(divisor) for y in range(divisor)]
