"""Long runs: constant live GL objects and flat memory.

The default run renders 200 frames in process and checks the GL objects against the driver's own
count. The full soak, 10,000 frames through the command line, is marked slow and excluded by
default (pyproject addopts); run it with::

    python -m pytest -m slow tests/app/test_soak.py
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from game.gpu import resources
from game.render.renderer import Renderer, View
from game.scene import load_scene
from tests.cli.cli_helpers import run_here
from tests.helpers import ROOT, TINY

SIZE = (64, 36)
WARM_UP = 100            # frames before memory is compared
MAX_GROWTH = 0.05        # peak memory after warm-up may grow at most this share


def test_gl_objects_are_constant_and_counted_by_their_owners(ctx):
    scene = load_scene(TINY)
    before = resources.live_gl_names()
    renderer = Renderer(ctx, scene, SIZE, gbuffer=True)
    try:
        view = View.from_camera(scene.camera, SIZE)
        counts, live = [], []
        for k in range(200):
            frame = renderer.render(k / 30, view)
            counts.append(sum(frame.gl_objects.values()))
            if k in (1, 199):
                live.append(resources.live_gl_names())
        assert len(set(counts)) == 1, set(counts)
        assert live[0] == live[1]
        # The owners' count is what the driver holds beyond what existed before.
        made = sum(live[1].values()) - sum(before.values())
        assert made == counts[-1], (made, counts[-1], live[1], renderer.gl_objects())
    finally:
        renderer.release()
    assert resources.live_gl_names() == before  # release frees every object


def test_stats_record_gl_objects_and_memory_per_frame(tmp_path, capsys):
    stats = tmp_path / "stats.json"
    result = run_here(capsys, "capture", TINY, "--size", "32x18", "--frames", "3", "--out",
                      tmp_path / "out", "--stats", stats)
    assert result.returncode == 0, result.stderr
    frames = json.loads(stats.read_text())["frames"]
    assert len(frames) == 3
    for f in frames:
        assert f["gl_objects"] == sum(f["gl_objects_by_owner"].values()) > 0
        assert f["rss_mib"] > 10


@pytest.mark.slow
def test_soak_10000_frames(tmp_path):
    stats = tmp_path / "stats.json"
    result = subprocess.run(
        [sys.executable, "-m", "game", "capture", str(TINY), "--size", "64x36",
         "--frames", "10000", "--out", str(tmp_path / "out"), "--stats", str(stats)],
        cwd=ROOT, capture_output=True, text=True, timeout=3600)
    assert result.returncode == 0, result.stderr
    frames = json.loads(stats.read_text())["frames"]
    assert len(frames) == 10000
    assert len({f["gl_objects"] for f in frames}) == 1
    warm = frames[WARM_UP]["rss_mib"]
    peak = max(f["rss_mib"] for f in frames[WARM_UP:])
    assert peak <= warm * (1 + MAX_GROWTH), (warm, peak)
