"""The pass timer's clocks (game/gpu/timing.py): the thread clock holds only where llvmpipe
rasterises in the calling thread, and then it counts that thread's work around glFinish."""

from __future__ import annotations

import time

import pytest

from game.errors import GameError
from game.gpu.timing import PassTimer
from tests.cli.cli_helpers import run


def test_the_thread_clock_is_refused_while_llvmpipe_has_threads(ctx, monkeypatch):
    monkeypatch.setenv("LP_NUM_THREADS", "4")
    with pytest.raises(GameError, match="LP_NUM_THREADS=0"):
        PassTimer(ctx, "cpu-thread")


def test_the_thread_clock_counts_this_threads_work_not_its_sleep(ctx, monkeypatch):
    monkeypatch.setenv("LP_NUM_THREADS", "0")
    timer = PassTimer(ctx, "cpu-thread")
    assert timer.clock == "cpu-thread"
    with timer.measure("sleep"):
        time.sleep(0.2)
    with timer.measure("work"):
        end = time.thread_time() + 0.05
        while time.thread_time() < end:
            pass
    assert timer.ms["sleep"] < 20.0 <= timer.ms["work"]


def captured_with(tmp_path, clock: str, frames: int) -> tuple:
    """A capture of the tiny scene timed by ``clock``: the command's result and its stats."""
    out = tmp_path / "stats.json"
    result = run("capture", "tests/scenes/tiny.toml", "--frames", str(frames), "--size", "64x36",
                 "--clock", clock, "--stats", str(out), "--out", str(tmp_path / "cap"))
    return result, out.read_text() if out.is_file() else ""


def test_the_command_line_sets_llvmpipe_to_one_thread_for_the_thread_clock(tmp_path):
    result, stats = captured_with(tmp_path, "cpu-thread", 1)
    assert result.returncode == 0, result.stderr
    assert '"clock": "cpu-thread"' in stats


def test_the_query_clock_times_passes_and_deletes_its_queries(ctx):
    from game.gpu.resources import live_gl_names, release_targets

    before = live_gl_names()["Query"]
    timer = PassTimer(ctx, "gpu-query")
    colour = ctx.texture((64, 36), 4)
    fbo = ctx.framebuffer([colour])
    fbo.use()
    for _ in range(2):
        with timer.measure("clear"):
            fbo.clear(0.5, 0.5, 0.5, 1.0)
    assert timer.gl_objects() == 1 and timer.ms["clear"] >= 0.0
    assert live_gl_names()["Query"] == before + 1
    timer.release()
    release_targets(ctx, [fbo, colour])
    assert live_gl_names()["Query"] == before and timer.gl_objects() == 0


def test_a_capture_timed_by_queries_ends_cleanly(tmp_path):
    result, stats = captured_with(tmp_path, "gpu-query", 2)
    assert result.returncode == 0, result.stderr
    assert '"clock": "gpu-query"' in stats
