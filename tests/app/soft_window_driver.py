"""Drives the walkaround with soft shadows on, for tests/app/test_soft_window.py.

Runs in its own process (the window's GL context must not meet the test session's headless
one) on GLFW's null platform: a still view until the reduced trace has converged, then the
camera and the characters moving. Saves the first frame (upsampled from one pixel in each
block) as ``first.npy`` and the converged one as ``still.npy``, and prints what it saw as one
JSON line.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import imgui_bundle  # noqa: F401 - before glfw

# isort: split
import numpy as np

from game.app.window import walkaround
from game.app.window.walkaround import PlayOptions, Walkaround
from game.errors import GameError
from game.scene import load_scene

SIZE = (320, 180)
STEP_S = 1.0 / 30.0
MOVING_FRAMES = 4
NO_WINDOW = 77  # exit status: this machine cannot open a null-platform EGL window


def main(scene_path: str, out: str) -> None:
    walkaround.SCREENSHOT_DIR = Path(out)
    scene = load_scene(Path(scene_path))
    try:
        # No overlay and no FXAA: the frame compares pixel for pixel with a capture.
        app = Walkaround(scene, PlayOptions(size=SIZE, time_step=STEP_S, platform="null",
                                            soft=True, overlay=False, antialias=False))
    except GameError as exc:
        print(exc, file=sys.stderr)
        sys.exit(NO_WINDOW)
    # A traced method: its samples accumulate while the view stays (a raster method, the
    # window's default, looks the light up whole every frame: game/soft/direct.py).
    app.set_soft_trace(method="voxel-cache")
    up = app.upsampling
    seen: dict = {"frames": [], "divisor": up.divisor, "rounds": up.rounds}

    def step(phase: str) -> None:
        app.step(STEP_S)
        trace = app.last_figures.soft
        state = app.renderer.traced.reduced_state
        seen["frames"].append({
            "phase": phase, "error": app.ctx.error, "gl_objects": app.gl_objects(),
            "render_size": list(app.renderer.size), "trace_size": list(trace.size),
            "note": trace.state, "trace_ms": app.last_figures.ms.get("soft_trace", 0.0),
            "traced": state.traced, "converged": state.converged})

    def shot(phase: str, name: str) -> None:
        app.key("f12", True)
        app.key("f12", False)
        step(phase)
        np.save(Path(out) / f"{name}.npy", app.screenshot)

    try:
        app.paused = True   # still: the scene's view at time 0, as a capture's frame 0
        shot("still", "first")   # one pixel in divisor x divisor traced, upsampled
        phases = up.divisor ** 2
        for _ in range(phases * up.rounds):
            step("still")
        shot("still", "still")   # converged
        app.paused = False
        app.key("w", True)
        for _ in range(MOVING_FRAMES):
            step("moving")
        app.key("w", False)
    finally:
        app.close()
    print(json.dumps(seen))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
