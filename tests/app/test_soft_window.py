"""Soft shadows in the walkaround window: the frame at the window's resolution, the linear light
traced at a reduced one and upsampled (game/soft/upsample.py), on GLFW's null platform
(tests/app/soft_window_driver.py runs the window in its own process)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from game import cli
from tests.app.window_helpers import NO_WINDOW, run_game, window_env
from tests.helpers import ROOT, TINY, read_png

DRIVER = ROOT / "tests" / "app" / "soft_window_driver.py"
SIZE = (320, 180)


@pytest.fixture(scope="module")
def soft_run(tmp_path_factory):
    """What the driver saw, and the folder of its still frame."""
    out = tmp_path_factory.mktemp("soft_window")
    result = subprocess.run([sys.executable, str(DRIVER), str(TINY), str(out)],
                            capture_output=True, text=True, timeout=600, env=window_env(), cwd=ROOT)
    if result.returncode == NO_WINDOW:
        pytest.skip(f"no null-platform EGL window here: {result.stderr.strip()}")
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout.strip().splitlines()[-1]), out


def test_soft_frames_make_no_gl_errors_and_no_gl_objects(soft_run):
    seen, _ = soft_run
    frames = seen["frames"]
    assert {f["error"] for f in frames} == {"GL_NO_ERROR"}
    # Everything is made by the first soft frame: accumulating, converging and moving again
    # make nothing more.
    assert len({f["gl_objects"] for f in frames}) == 1, [f["gl_objects"] for f in frames]


def test_the_frame_is_full_size_and_the_trace_a_share_of_it(soft_run):
    seen, _ = soft_run
    d = seen["divisor"]
    assert d > 1
    for f in seen["frames"]:
        assert f["render_size"] == list(SIZE)
        assert f["trace_size"] == [-(-SIZE[0] // d), -(-SIZE[1] // d)]


def test_a_still_view_accumulates_until_converged_then_traces_nothing(soft_run):
    seen, _ = soft_run
    still = [f for f in seen["frames"] if f["phase"] == "still"]
    rounds, phases = seen["rounds"], seen["divisor"] ** 2
    assert [f["traced"] for f in still[:phases * rounds]] == [True] * (phases * rounds)
    assert still[phases * rounds]["converged"] and not still[phases * rounds]["traced"]
    assert still[-1]["trace_ms"] == 0.0 and "converged" in still[-1]["note"]
    moving = [f for f in seen["frames"] if f["phase"] == "moving"]
    assert all(f["traced"] and f["trace_ms"] > 0 and "moving" in f["note"] for f in moving)


@pytest.fixture(scope="module")
def soft_capture(tmp_path_factory):
    """The headless capture of the window's first frame, soft shadows on (no window: in this
    process)."""
    out = tmp_path_factory.mktemp("soft_capture")
    assert cli.main(["capture", str(TINY), "--soft", "--time", "0", "--size",
                     f"{SIZE[0]}x{SIZE[1]}", "--out", str(out)]) == 0
    return read_png(out / "frame_0000.png").astype(int)


@pytest.mark.parametrize("name, mean, far", [("first", 1.0, 0.01), ("still", 0.5, 0.002)])
def test_the_window_matches_a_capture_of_every_pixel(soft_run, soft_capture, name, mean, far):
    # first: one pixel in each block traced, upsampled; still: every pixel, rounds averaged.
    _, out = soft_run
    window = np.load(out / f"{name}.npy").astype(int)
    captured = soft_capture
    diff = np.abs(window - captured).max(axis=2)
    # The capture traces every pixel with its own samples; the window, with fewer samples per
    # pass, averages neighbours on the same surface: they differ by noise in the penumbrae.
    assert 20 < captured.mean() < 235   # a scene, not a blank frame
    assert diff.mean() < mean, diff.mean()
    assert (diff > 24).mean() < far, (diff > 24).mean()


def test_play_soft_writes_its_trace_size_in_the_stats(tmp_path):
    stats = tmp_path / "stats.json"
    result = run_game("play", TINY, "--platform", "null", "--frames", "3", "--soft",
                      "--size", f"{SIZE[0]}x{SIZE[1]}", "--stats", stats)
    if result.returncode == 1 and "window" in result.stderr:
        pytest.skip(f"no null-platform EGL window here: {result.stderr.strip()}")
    assert result.returncode == 0, result.stderr
    doc = json.loads(stats.read_text())
    assert doc["render_size"] == list(SIZE) and doc["soft"]
    for frame in doc["frames"]:
        assert frame["soft_trace_size"] == [80, 45] and frame["soft_samples"] > 0
        assert frame["ms"]["soft_upsample"] > 0 and frame["ms"]["composite"] > 0


@pytest.mark.parametrize("extra", [["--panel"], ["--debug-view", "map"]])
def test_soft_shadows_with_the_panel_or_a_debug_view_play_to_the_end(tmp_path, extra):
    """The panel counts the map records every 30th frame, the first included; a debug view
    shows the hard maps while soft shadows wait."""
    stats = tmp_path / "stats.json"
    result = run_game("play", TINY, "--platform", "null", "--frames", "2", "--soft",
                      "--size", "64x36", "--stats", stats, *extra)
    if result.returncode == 1 and "window" in result.stderr:
        pytest.skip(f"no null-platform EGL window here: {result.stderr.strip()}")
    assert result.returncode == 0, result.stderr
    frames = json.loads(stats.read_text())["frames"]
    assert len(frames) == 2
    waiting = extra[0] == "--debug-view"
    assert all(("composite" in f["ms"]) != waiting for f in frames)


def test_the_overlay_counts_a_raster_methods_maps_and_the_points_a_still_view_refined():
    from dataclasses import replace
    from types import SimpleNamespace

    from game.app.window.figures import SoftFigures
    from game.soft.tracer import TraceSettings
    from game.soft.upsample import ReducedState

    frame = SimpleNamespace(soft=object(), ms={"soft_total": 4.0})
    state = ReducedState(size=(80, 45), divisor=4, traced=True, round=0, rounds=4, phase=1,
                         phases=16, full=False)
    maps = TraceSettings(method="segment-maps", maps=8)
    raster = SoftFigures.of(frame, replace(state, round=1), maps)
    assert (raster.samples, raster.unit) == (8, "maps")
    assert raster.state.startswith("moving: 8 points") and "upsampled" not in raster.state
    assert SoftFigures.of(frame, replace(state, round=2), maps).state == (
        "still: 16 of 32 points along the segment")
    refined = SoftFigures.of(frame, replace(state, round=4), maps)
    assert refined.state == "still: 32 of 32 points along the segment; refined"
    settling = SoftFigures.of(frame, replace(state, round=4, settled=0.25), maps)
    assert settling.state.endswith("; refined; exact at 25% of pixels")
    pcss = SoftFigures.of(frame, replace(state, round=1, rounds=1), TraceSettings(method="pcss"))
    assert "looked up every frame" in pcss.state
    traced = SoftFigures.of(frame, state, TraceSettings(method="voxel-cache", samples=6))
    assert (traced.samples, traced.unit) == (6, "samples")
    assert traced.state.startswith("moving: upsampled")
