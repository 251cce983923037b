"""Running the game and its window drivers in a child process, for the window tests
(tests/app/test_window.py and its neighbours). Not a test module."""

from __future__ import annotations

import os
import subprocess
import sys

from tests.helpers import ROOT

DRIVER = ROOT / "tests" / "app" / "window_driver.py"
NO_WINDOW = 77  # a driver's exit status: this machine cannot open a null-platform EGL window
WIDE = (1280, 720)  # the traced-and-soft run's window: room beside the overlay's panel


def window_env(**extra) -> dict:
    """The environment of a child that opens a window: no display, this checkout importable."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["PYTHONPATH"] = str(ROOT)
    env.update(extra)
    return env


def run_game(*args, cwd=None):
    """``python -m game ARGS`` in a child without a display."""
    return subprocess.run([sys.executable, "-m", "game", *map(str, args)], cwd=cwd or ROOT,
                          capture_output=True, text=True, timeout=300, env=window_env())
