"""Drives the real walkaround window with scripted input, for tests/app/test_window.py,
tests/app/test_overlay_layout.py and tests/app/test_lights_panel.py.

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

from game.app.window.walkaround import PlayOptions, Walkaround
from game.errors import GameError
from game.scene import load_scene
from game.shadows.plan import ShadowSettings
from tests.app.window_helpers import WIDE

SIZE = (320, 180)
COARSE = 64         # texels per side of the maps in traced_and_soft
STEP_S = 1.0 / 30.0
MODES_SIZES = ((640, 360), (960, 540))  # the window before and after a resize, overlay_modes
NO_WINDOW = 77  # exit status: this machine cannot open a null-platform EGL window


def screen_matches_screenshot(scene_path: str, shots: str) -> None:
    """Most frames go straight to the window, screenshots through a canvas: same pixels?

    Reads the window's framebuffer (which moderngl cannot) with PyOpenGL just before each swap.
    """
    import numpy as np
    from OpenGL import GL

    import game.app.window.walkaround

    game.app.window.walkaround.SCREENSHOT_DIR = Path(shots)
    scene = load_scene(Path(scene_path))
    result = {}
    for scale in (1.0, 0.5):
        try:
            app = Walkaround(scene, PlayOptions(size=SIZE, time_step=0.0, platform="null",
                                                render_scale=scale))
        except GameError as exc:
            print(exc, file=sys.stderr)
            sys.exit(NO_WINDOW)
        swap, shown = glfw.swap_buffers, []

        def read_then_swap(window, app=app, swap=swap, shown=shown):
            GL.glBindFramebuffer(GL.GL_FRAMEBUFFER, 0)
            data = GL.glReadPixels(0, 0, SIZE[0], SIZE[1], GL.GL_RGB, GL.GL_UNSIGNED_BYTE)
            shown.append(np.frombuffer(data, np.uint8).reshape(SIZE[1], SIZE[0], 3)[::-1])
            app.ctx.detect_framebuffer(0).use()
            swap(window)

        glfw.swap_buffers = read_then_swap
        try:
            app.paused = True
            app.step(0.0)                 # straight to the window
            app.key("f12", True)          # through the canvas, saved
            app.step(0.0)
            x, y, w, h = app.overlay.rect
        finally:
            glfw.swap_buffers = swap
            app.close()
        # The panel's figures change between the frames: compare outside it.
        keep = np.ones(shown[0].shape[:2], bool)
        keep[y:y + h, x:x + w] = False
        result[str(scale)] = {
            "direct_vs_canvas": int(np.abs(shown[0].astype(int) - shown[1].astype(int))[keep]
                                    .max()),
            "screenshot_vs_window": int(np.abs(app.screenshot.astype(int)
                                               - shown[1].astype(int)).max()),
            "mean": float(shown[0].mean())}
    print(json.dumps(result))


def traced_and_soft(scene_path: str, out: str) -> None:
    """Switch to the traced method with M, back, then soft shadows on and off several times.

    Saves the frames shown (F12) as .npy files in ``out`` and prints what it saw.
    """
    import numpy as np

    import game.app.window.walkaround

    game.app.window.walkaround.SCREENSHOT_DIR = Path(out)
    scene = load_scene(Path(scene_path))
    try:
        # Coarse maps, so that the maps' hard shadows differ visibly from the traced ones; no
        # FXAA, so that the frames compare pixel for pixel with captures.
        coarse = ShadowSettings(clump_resolution=COARSE, character_resolution=COARSE)
        app = Walkaround(scene, PlayOptions(size=WIDE, time_step=0.0, platform="null",
                                            settings=coarse, antialias=False))
    except GameError as exc:
        print(exc, file=sys.stderr)
        sys.exit(NO_WINDOW)
    seen: dict = {}

    def shot(name: str) -> None:
        app.step(0.0)
        app.key("f12", True)
        app.key("f12", False)
        app.step(0.0)
        np.save(Path(out) / f"{name}.npy", app.screenshot)
        trace = app.last_figures.soft
        seen[name] = {"method": app.renderer.settings.method, "soft": app.soft,
                      "render_size": list(app.renderer.size), "ms": app.last_figures.ms,
                      "overlay_rect": list(app.overlay.rect),
                      "trace_size": list(trace.size) if trace is not None else None,
                      "hud": list(app.overlay.hud_lines)}

    try:
        app.paused = True
        shot("clumped")
        methods = []
        for _ in range(4):
            app.key("m", True)
            app.key("m", False)
            methods.append(app.renderer.settings.method)
        seen["methods"] = methods
        shot("traced")
        app.key("m", True)
        app.key("m", False)
        seen["after_traced"] = app.renderer.settings.method
        app.set_soft(True)
        shot("soft")
        counts: dict = {"on": [], "off": []}
        for _ in range(4):
            for state in ("off", "on"):
                app.set_soft(state == "on")
                app.step(0.0)
                app.step(0.0)
                counts[state].append(app.gl_objects())
        seen["gl_objects"] = counts
        seen["gl_error"] = app.ctx.error
    finally:
        app.close()
    print(json.dumps(seen))


def overlay_modes(scene_path: str) -> None:
    """F1 through the key callback: the overlay's HUD, its panel at two window sizes, the HUD
    again; then a window opened with the panel (``play --panel``). Prints what it saw."""
    import dataclasses as dc

    from game.app.window.glfw_setup import KEY_NAMES

    scene = load_scene(Path(scene_path))
    seen: dict = {"f1": KEY_NAMES.get(glfw.KEY_F1)}
    try:
        app = Walkaround(scene, PlayOptions(size=MODES_SIZES[0], time_step=0.0,
                                            platform="null"))
    except GameError as exc:
        print(exc, file=sys.stderr)
        sys.exit(NO_WINDOW)

    def look(name: str) -> None:
        for _ in range(3):  # imgui measures a window's content in one frame, uses it the next
            app.step(0.0)
        o = app.overlay
        seen[name] = {"panel": o.panel, "rect": list(o.rect), "size": list(app.framebuffer_size()),
                      "layout": dc.asdict(o.layout) if o.panel else None,
                      "bar": [b.name for b in o.bar]}

    def f1() -> None:  # as glfw reports it
        app.on_key(app.window, glfw.KEY_F1, 0, glfw.PRESS, 0)
        app.on_key(app.window, glfw.KEY_F1, 0, glfw.RELEASE, 0)

    try:
        app.paused = True
        look("hud")
        f1()
        look("panel")
        glfw.set_window_size(app.window, *MODES_SIZES[1])
        look("panel_resized")
        f1()
        look("hud_resized")
    finally:
        app.close()
    app = Walkaround(scene, PlayOptions(size=(160, 90), time_step=0.0, platform="null",
                                        panel=True))
    try:
        look("opened_with_panel")
    finally:
        app.close()
    print(json.dumps(seen))


def light_keys(scene_path: str) -> None:
    """The light keys through the key callback, in a window opened with the panel: "]" selects
    light 1, the right arrow (pressed, repeated once, released) nudges it, L switches it off, "["
    selects light 0 again. Prints what it saw."""
    scene = load_scene(Path(scene_path))
    try:
        app = Walkaround(scene, PlayOptions(size=SIZE, time_step=0.0, platform="null",
                                            panel=True))
    except GameError as exc:
        print(exc, file=sys.stderr)
        sys.exit(NO_WINDOW)
    seen: dict = {"tab": app.overlay.open_tab, "selected": []}

    def press(key: int, repeats: int = 0) -> None:  # as glfw reports it
        app.on_key(app.window, key, 0, glfw.PRESS, 0)
        for _ in range(repeats):
            app.on_key(app.window, key, 0, glfw.REPEAT, 0)
        app.on_key(app.window, key, 0, glfw.RELEASE, 0)

    try:
        app.paused = True
        app.step(0.0)
        app.step(0.0)   # every static map cached
        press(glfw.KEY_RIGHT_BRACKET)
        seen["selected"].append(app.selected_light)
        seen["lamp_before"] = app.renderer.scene.lights[1].position.tolist()
        press(glfw.KEY_RIGHT, repeats=1)
        seen["lamp_after"] = app.renderer.scene.lights[1].position.tolist()
        seen["yaw"] = app.controller.camera.yaw
        app.step(0.0)
        plan, spans = app.renderer.last_plan, app.renderer.last_spans
        seen["render_static"] = list(plan.render_static)
        seen["lamp_span"] = [spans[1].first_map, spans[1].map_count]
        press(glfw.KEY_L)
        app.step(0.0)
        seen["lights_on"] = list(app.renderer.lights_on)
        press(glfw.KEY_LEFT_BRACKET)
        seen["selected"].append(app.selected_light)
        seen["gl_error"] = app.ctx.error
    finally:
        app.close()
    print(json.dumps(seen))


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
                               "notes": list(w.renderer.notes),
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
    if len(sys.argv) > 2 and sys.argv[2] == "overlay-modes":
        overlay_modes(sys.argv[1])
    elif len(sys.argv) > 2 and sys.argv[2] == "lights":
        light_keys(sys.argv[1])
    elif len(sys.argv) > 3 and sys.argv[3] == "traced-soft":
        traced_and_soft(sys.argv[1], sys.argv[2])
    elif len(sys.argv) > 2:
        screen_matches_screenshot(sys.argv[1], sys.argv[2])
    else:
        main(sys.argv[1])
