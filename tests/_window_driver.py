"""Drives the real walkaround window with scripted input, for tests/test_window.py.

Runs in its own process (the window's GL context must not meet the test session's headless
one) on GLFW's null platform with an EGL context, and prints what it saw as one JSON line.
"""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import imgui_bundle  # noqa: F401 - before glfw

# isort: split
import glfw

from game.errors import GameError
from game.scene import load_scene
from game.window import PlayOptions, Walkaround

SIZE = (320, 180)
STEP_S = 1.0 / 30.0
NO_WINDOW = 77  # exit status: this machine cannot open a null-platform EGL window


def main(scene_path: str) -> None:
    scene = load_scene(Path(scene_path))
    try:
        app = Walkaround(scene, PlayOptions(size=SIZE, frames=None, time_step=STEP_S,
                                            platform="null"))
    except GameError as exc:
        print(exc, file=sys.stderr)
        sys.exit(NO_WINDOW)
    seen: dict = {"positions": [], "methods": [], "sizes": [], "framebuffers": [], "errors": []}
    calls = 0

    def script(w: Walkaround) -> None:
        nonlocal calls
        k = calls
        calls += 1
        seen["positions"].append(w.controller.camera.position.tolist())
        seen["methods"].append(w.renderer.settings.method)
        seen["sizes"].append(list(w.renderer.size))
        seen["framebuffers"].append(list(glfw.get_framebuffer_size(w.window)))
        seen["errors"].append(w.ctx.error)
        if k == 3:
            w.key("w", True)
        elif k == 13:
            w.key("w", False)
        elif k == 15:
            w.key("m", True)
            w.key("m", False)
        elif k == 18:
            glfw.set_window_size(w.window, 200, 120)
        elif k == 21:
            glfw.iconify_window(w.window)
            seen["frames_before_minimise"] = w.frames
        elif k == 25:
            seen["frames_while_minimised"] = w.frames - seen["frames_before_minimise"]
            glfw.restore_window(w.window)
        elif k == 28:
            glfw.set_window_size(w.window, *SIZE)
        elif k == 35:  # a map larger than the GL allows: undone, and said in the panel
            w.renderer.set_settings(dataclasses.replace(w.renderer.settings,
                                                        single_resolution=1 << 20))
        elif k == 36:
            seen["refused"] = {"message": w.overlay.message,
                               "notes": list(w.renderer.method.notes),
                               "resolution": w.renderer.settings.single_resolution}
        elif k == 41:
            w.key("escape", True)

    try:
        app.run(script)
        f = app.last_figures
        seen["figures"] = {"ms": f.ms, "clock": f.clock, "maps_rendered": f.maps_rendered,
                           "maps_cached": f.maps_cached,
                           "triangles_to_maps": f.triangles_to_maps,
                           "maps_per_fragment": f.maps_per_fragment, "fps": f.fps}
        seen["overlay_rect"] = list(app.overlay.rect)
        seen["frames"] = app.frames
        seen["final_error"] = app.ctx.error
    finally:
        app.close()
    print(json.dumps(seen))


if __name__ == "__main__":
    main(sys.argv[1])
