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


def test_the_command_line_sets_llvmpipe_to_one_thread_for_the_thread_clock(tmp_path):
    out = tmp_path / "stats.json"
    result = run("capture", "tests/scenes/tiny.toml", "--frames", "1", "--size", "64x36",
                 "--clock", "cpu-thread", "--stats", str(out), "--out", str(tmp_path / "cap"))
    assert result.returncode == 0, result.stderr
    assert '"clock": "cpu-thread"' in out.read_text()
