"""A raster soft method in the window (game/soft/direct.py): the blocks' classes and runs, the
window's visibility against the method's own lookup at every pixel, the walkers' layers that keep
no trail of earlier poses, and what a still view keeps of its lookups
(game/soft/still_lookups.py)."""

from __future__ import annotations

import numpy as np
import pytest

from game import transforms
from game.render.renderer import Renderer, View
from game.soft import raster, still_lookups
from game.soft.block_values import INTERPOLATE, LOOKUP, SKIP, TOLERANCE, block_runs, block_values
from game.soft.methods import TraceSettings
from game.soft.raster import RasterSoft
from game.soft.still_lookups import REFINE_POINTS, seen_boxes
from game.soft.upsample import Upsampling
from tests.soft.tracer_helpers import rmse

SIZE = (96, 54)
NAN = np.nan


def test_blocks_agree_interpolate_look_up_or_are_skipped():
    vis = np.ones((5, 7), np.float32)
    vis[:, 5:] = 0.0                     # umbra on the right
    vis[0, 0] = 1.0 - TOLERANCE / 2      # a gentle slope in the top-left corner
    vis[4, 0] = NAN                      # sky in the bottom-left corner
    mixed = np.zeros_like(vis, bool)
    mixed[2, 2] = True
    values = block_values(vis, mixed)
    assert values[2, 3] == 1.0                      # every point around it lit
    assert values[0, 1] == INTERPOLATE              # within the tolerance of its neighbours
    assert values[2, 4] == LOOKUP and values[2, 5] == LOOKUP   # the shadow's edge
    assert values[2, 6] == SKIP                      # the umbra gains nothing
    assert values[4, 0] == SKIP                      # the sky
    assert values[3, 1] == 1.0                       # the sky beside it says nothing
    assert values[2, 2] == LOOKUP                    # mixed coverage: every pixel looks up


def test_runs_cover_the_drawn_blocks_once_and_carry_their_values():
    rng = np.random.default_rng(3)
    values = rng.choice([SKIP, LOOKUP, INTERPOLATE, 0.5, 1.0], size=(6, 9)).astype(np.float32)
    divisor, size = 4, (34, 22)   # the last column and row of blocks cut by the frame
    runs = block_runs(values, divisor, size)
    painted = np.full((size[1], size[0]), SKIP, np.float32)
    hits = np.zeros((size[1], size[0]), int)
    for vertices in (runs.flat, runs.lookup):
        for rect in vertices.reshape(-1, 6, 3):
            x0, y0 = rect[:, :2].min(axis=0).astype(int)
            x1, y1 = rect[:, :2].max(axis=0).astype(int)
            painted[y0:y1, x0:x1] = rect[0, 2]
            hits[y0:y1, x0:x1] += 1
    expected = np.repeat(np.repeat(values, divisor, axis=0), divisor, axis=1)
    expected = expected[:size[1], :size[0]]
    assert np.array_equal(painted, expected)
    assert hits.max() == 1
    assert np.all(runs.lookup[:, 2] == LOOKUP) and np.all(runs.flat[:, 2] != LOOKUP)
    assert runs.blocks["lookup"] == int(np.sum(values == LOOKUP))


def test_runs_of_the_same_columns_and_value_in_consecutive_rows_are_one_rectangle():
    values = np.full((5, 6), SKIP, np.float32)
    values[0:4, 1:3] = LOOKUP       # four rows of the same run: one rectangle
    values[0:2, 4:6] = 1.0          # two rows ...
    values[3:5, 4:6] = 1.0          # ... a gap, two more: two rectangles
    values[2, 0] = 0.5              # a run of one row
    runs = block_runs(values, 2, (12, 10))
    lookup = runs.lookup.reshape(-1, 6, 3)
    assert len(lookup) == 1
    assert lookup[0, :, :2].min(axis=0).tolist() == [2, 0]
    assert lookup[0, :, :2].max(axis=0).tolist() == [6, 8]
    assert len(runs.flat) // 6 == 3


def test_a_frame_with_no_block_to_draw_has_no_runs():
    runs = block_runs(np.full((4, 5), SKIP, np.float32), 4, (20, 16))
    assert len(runs.flat) == 0 and len(runs.lookup) == 0
    assert runs.blocks["skipped"] == 20


@pytest.mark.parametrize("method", ["segment-maps", "pcss"])
def test_the_window_composite_matches_the_lookup_at_every_pixel(renderer, method):
    settings = TraceSettings(method=method, maps=8)
    view = View.from_camera(renderer.scene.camera, SIZE)
    renderer.render(1.0, view)
    every = renderer.trace(1.0, settings).visibility       # every pixel looked up
    renderer.traced.reduce_soft(Upsampling(divisor=4), b"view", np.zeros(3))
    frame = renderer.render(1.0, view, soft=settings)
    shown = renderer.traced.window_visibility(renderer.target)
    covered = np.isfinite(every)
    assert frame.soft.visibility.shape == (-(-SIZE[1] // 4), -(-SIZE[0] // 4))   # the points
    blocks = renderer.traced.direct.blocks.runs.blocks
    assert blocks["lookup"] > 0 and blocks["flat"] > 0
    # Interpolated blocks carry at most the tolerance; most pixels are exact.
    assert rmse(shown[covered], every[covered]) < TOLERANCE / 4
    assert np.mean(np.abs(shown[covered] - every[covered]) < 1e-4) > 0.8


def test_a_view_of_the_sky_alone_is_lit_by_nothing_and_drawn(renderer):
    """A window turned to the sky: every block is skipped, and the frame is still drawn."""
    camera = renderer.scene.camera
    up = transforms.look_at(camera.position, camera.position + np.array([0.0, 1.0, 0.01]))
    view = View(up, View.from_camera(camera, SIZE).proj, SIZE)
    renderer.traced.reduce_soft(Upsampling(divisor=4), b"sky", np.zeros(3))
    renderer.render(1.0, view, soft=TraceSettings(method="segment-maps", maps=8))
    runs = renderer.traced.direct.blocks.runs
    assert len(runs.flat) == 0 and len(runs.lookup) == 0
    assert np.all(np.isnan(renderer.traced.window_visibility(renderer.target)))


def test_counting_a_soft_frames_map_records_keeps_its_picture(ctx, tiny):
    """The panel's record count draws the shading pass again: the lean G-buffer's variant,
    with the soft blocks bound as the frame bound them."""
    settings = TraceSettings(method="segment-maps", maps=8)
    view = View.from_camera(tiny.camera, SIZE)
    frames = []
    for count in (False, True):
        made = Renderer(ctx, tiny, SIZE, gbuffer=True)
        try:
            made.count_candidates = count
            made.traced.reduce_soft(Upsampling(divisor=4), b"view", np.zeros(3))
            frames.append([made.render(1.0, view, soft=settings) for _ in range(2)])
        finally:
            made.release()
    plain, counted = frames
    assert all(f.map_candidates_per_fragment is not None for f in counted)
    for a, b in zip(plain, counted, strict=True):
        assert np.array_equal(a.image, b.image)


def test_a_still_view_makes_no_gl_objects_after_it_starts_settling(renderer):
    """The view's first frame, its refining ones and its first settling one make what they
    need (the exact tracer on first use, kept); the frames after them make nothing."""
    settings = TraceSettings(method="segment-maps", maps=8)
    view = View.from_camera(renderer.scene.camera, SIZE)
    renderer.traced.reduce_soft(Upsampling(divisor=4), b"view", np.zeros(3))
    rounds = REFINE_POINTS // settings.maps
    for t in np.linspace(0.0, 0.1, rounds + 1):
        renderer.render(t, view, soft=settings)
    assert renderer.traced.direct.blocks.settle.started
    objects = renderer.gl_objects()
    for t in np.linspace(0.2, 1.5, 6):   # the walkers walk
        renderer.render(t, view, soft=settings)
        assert renderer.gl_objects() == objects


def test_the_walkers_layers_keep_no_trail_of_earlier_poses(ctx, renderer):
    settings = TraceSettings(method="segment-maps", maps=4)
    view = View.from_camera(renderer.scene.camera, SIZE)
    for t in (0.0, 0.6, 1.2):   # the walkers' layers restored where they were, then redrawn
        renderer.render(t, view)
        kept = renderer.trace(t, settings).visibility
    fresh = RasterSoft(ctx, renderer.geom, renderer.scene)
    try:
        target = renderer.target
        anew = fresh.trace((target.position, target.normal, target.colour), SIZE,
                           renderer.models(1.2), settings, renderer.traced.segment())
    finally:
        fresh.release()
    assert np.array_equal(np.isnan(kept), np.isnan(anew.visibility))
    covered = np.isfinite(kept)
    assert np.max(np.abs(kept[covered] - anew.visibility[covered])) < 1e-6


def _window_frames(renderer, view, settings, times) -> np.ndarray:
    """The window's visibility after frames at ``times`` of one view (the walkers walk)."""
    renderer.traced.reduce_soft(Upsampling(divisor=4), b"view", np.zeros(3))
    for t in times:
        renderer.render(float(t), view, soft=settings)
    return renderer.traced.window_visibility(renderer.target)


def test_a_still_view_keeps_its_lookups_and_shows_what_a_fresh_window_would(ctx, tiny,
                                                                            renderer,
                                                                            monkeypatch):
    settings = TraceSettings(method="segment-maps", maps=8)
    monkeypatch.setattr(still_lookups, "REFINE_POINTS", settings.maps)   # keeping, no refining
    renderer.traced.settle = False   # nor settling
    view = View.from_camera(renderer.scene.camera, SIZE)
    kept = _window_frames(renderer, view, settings, np.linspace(0.0, 1.5, 16))
    assert renderer.traced.direct.blocks.runs.blocks["cached"] > 0
    fresh = Renderer(ctx, tiny, SIZE, gbuffer=True)
    try:
        anew = _window_frames(fresh, view, settings, [1.5])
        assert fresh.traced.direct.blocks.runs.blocks["cached"] == 0
    finally:
        fresh.release()
    assert np.array_equal(np.isnan(kept), np.isnan(anew))
    assert np.nanmax(np.abs(kept - anew)) < 1e-5


def test_a_still_view_refines_toward_the_exact_visibility_and_then_stops(renderer):
    settings = TraceSettings(method="segment-maps", maps=8)
    view = View.from_camera(renderer.scene.camera, SIZE)
    renderer.traced.settle = False   # the refining alone (tests/soft/test_settle.py)
    renderer.render(1.0, view)
    exact = renderer.trace(1.0, TraceSettings(method="analytic")).visibility
    covered = np.isfinite(exact)
    rounds = REFINE_POINTS // settings.maps
    shown, refine_ms = [], []
    for _ in range(rounds + 2):   # the walkers stand still
        frame = renderer.render(1.0, view, soft=settings) if shown else _first(renderer, view,
                                                                               settings)
        refine_ms.append(frame.ms["soft_refine"])
        shown.append(renderer.traced.window_visibility(renderer.target))
    errors = [rmse(s[covered], exact[covered]) for s in shown]
    assert refine_ms[0] == 0.0 and min(refine_ms[1:rounds]) > 0.0 and max(refine_ms[rounds:]) == 0.0
    # A round's lookups show from the next frame on.
    assert errors[rounds] < 0.85 * errors[0]
    assert np.array_equal(shown[rounds + 1], shown[rounds], equal_nan=True)   # it stopped


def _first(renderer, view, settings):
    renderer.traced.reduce_soft(Upsampling(divisor=4), b"view", np.zeros(3))
    return renderer.render(1.0, view, soft=settings)


def test_a_moved_box_changes_the_blocks_it_covers_seen_from_the_camera():
    size, divisor = (96, 54), 4
    cells = (24, 14)
    view_proj = transforms.perspective(60.0, size[0] / size[1], 0.1, 100.0) @ transforms.look_at(
        np.array([0.0, 0.0, 5.0]), np.zeros(3))
    centred = seen_boxes(np.array([[[0.0, 0.0, 0.0], [0.2, 0.2, 0.2]]]), view_proj, size,
                         divisor, cells)
    assert centred[cells[1] // 2, cells[0] // 2] and not centred[0, 0]
    assert 0 < centred.sum() < 30
    behind = seen_boxes(np.array([[[0.0, 0.0, 6.0], [0.5, 0.5, 0.5]]]), view_proj, size,
                        divisor, cells)
    assert behind.all()   # a box that reaches behind the camera may cover any pixel


@pytest.mark.parametrize("coarser, kept", [
    (1.0, False),   # only as fine as the view's: tiny's whole scene is coarser, drawn again
    (None, True),   # the default: tiny's whole scene is fine enough, kept
])
def test_a_turning_window_keeps_the_statics_maps_where_the_whole_scenes_are_fine_enough(
        ctx, tiny, monkeypatch, coarser, kept):
    if coarser is not None:
        monkeypatch.setattr(raster, "WHOLE_COARSER", coarser)
    renderer = Renderer(ctx, tiny, SIZE, gbuffer=True)
    try:
        view = View.from_camera(renderer.scene.camera, SIZE)
        turn = np.eye(4)
        turn[:3, :3] = transforms.euler_xyz(np.array([0.0, 8.0, 0.0]))
        stats = []
        for key, seen in ((b"view", view), (b"turned", View(turn @ view.view, view.proj, SIZE))):
            renderer.traced.reduce_soft(Upsampling(divisor=4), key, np.zeros(3))
            settings = TraceSettings(method="segment-maps", maps=4)
            stats.append(renderer.render(1.0, seen, soft=settings).soft.maps)
    finally:
        renderer.release()
    assert stats[0]["soft_maps_static_rendered"] == 4
    assert stats[1]["soft_maps_static_cached"] == (4 if kept else 0)
